// Renders one random face of the built-in model at a given yaw and writes the image and its 68
// landmarks (iBUG .pts) with their visibility.
//   render_face OUT_DIR [SEED] [YAW_DEGREES]
#include "core/error.h"
#include "core/random.h"
#include "morph/builtin.h"
#include "morph/camera.h"
#include "morph/landmarks.h"
#include "morph/pose.h"
#include "morph/sampling.h"
#include "render/landmarks.h"
#include "render/renderer.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

using namespace facesynth;

int main(int argc, char** argv) try {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR [SEED] [YAW_DEGREES]\n", argv[0]);
        return 2;
    }
    const std::filesystem::path out = argv[1];
    const std::uint64_t seed = argc > 2 ? std::stoull(argv[2]) : 1;
    const double yaw = argc > 3 ? std::stod(argv[3]) : 30.0;

    // A random identity and colour: coefficients in σ units from the model's prior.
    const morph::MorphableModel& model = morph::builtin_model();
    core::Rng rng = core::make_rng(seed, 0, core::RandomStream::kIdentity);
    const auto alpha = morph::sample_coefficients(rng, model.num_shape_components(), 3.0);
    const auto beta = morph::sample_coefficients(rng, model.num_albedo_components(), 3.0);
    const morph::Mesh mesh = model.instance(alpha, {}, beta);

    // A 256² perspective camera 70 cm in front of the face (docs/conventions.md for the axes).
    render::Camera camera;
    camera.intrinsics = morph::intrinsics_from_fov(20.0, 256, 256);
    camera.pose.rotation = morph::rotation_from_euler({.yaw = yaw, .pitch = 0, .roll = 0});
    camera.pose.translation = {0, 0, 700};

    render::Renderer renderer;
    const render::Frame frame = renderer.render(mesh, camera);
    const render::ProjectedLandmarks landmarks = render::project_landmarks(model.landmarks, mesh, camera, frame);

    std::filesystem::create_directories(out);
    cv::Mat bgr;
    cv::cvtColor(frame.rgb, bgr, cv::COLOR_RGB2BGR);
    if (!cv::imwrite((out / "image.png").string(), bgr)) throw core::file_error((out / "image.png").string(), "cannot write");
    morph::write_pts(out / "image.pts", landmarks.pixels);
    int visible = 0;
    for (const auto v : landmarks.visible) visible += v;
    std::printf("%s: yaw %.0f°, %d of %zu landmarks visible\n", (out / "image.png").c_str(), yaw, visible,
                landmarks.visible.size());
    return 0;
} catch (const std::logic_error&) {  // std::stoi and friends: not a number
    std::fprintf(stderr, "render_face: SEED and YAW_DEGREES must be numbers\n");
    return 2;
} catch (const std::exception& e) {
    std::fprintf(stderr, "render_face: %s\n", e.what());
    return 1;
}
