#pragma once
// Shared helpers for the render tests: one renderer per backend for the whole test program, the toy
// model, and cameras.
#include "common/toy_model.h"
#include "render/renderer.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <map>
#include <memory>

namespace facesynth::testkit {

inline render::Renderer& shared_renderer(render::Backend backend = render::Backend::kEgl) {
    static std::map<render::Backend, std::unique_ptr<render::Renderer>> renderers;
    auto& r = renderers[backend];
    if (!r) r = std::make_unique<render::Renderer>(render::RendererOptions{backend, false});
    return *r;
}

inline const morph::MorphableModel& toy() {
    static const morph::MorphableModel model = make_toy_model();
    return model;
}

inline render::Camera make_camera(double yaw, double pitch, double roll, int width, int height,
                                  double fov = 30.0, double distance = 600.0) {
    render::Camera camera;
    camera.intrinsics = morph::intrinsics_from_fov(fov, width, height);
    camera.pose.rotation = morph::rotation_from_euler({yaw, pitch, roll});
    camera.pose.translation = Eigen::Vector3d(0, 0, distance);
    return camera;
}

// Resident memory of this process (VmRSS, KiB), for checks that repeated renders do not grow it.
inline long resident_kib() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
    return -1;
}

// Writes an RGB frame as PNG under the test temporary folder for a person to look at.
inline void save_for_inspection(const cv::Mat& rgb, const std::string& name) {
    const char* tmp = std::getenv("FACESYNTH_TEST_TMP");
    const std::filesystem::path dir = std::filesystem::path(tmp ? tmp : "/tmp") / "render";
    std::filesystem::create_directories(dir);
    cv::Mat bgr;
    if (rgb.channels() == 3) cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR); else bgr = rgb;
    cv::imwrite((dir / name).string(), bgr);
}

}  // namespace facesynth::testkit
