#pragma once
// Pinhole camera in the OpenCV convention (docs/conventions.md): camera looks along +z, image x right,
// y down, the centre of the top-left pixel is (0, 0). A model point X maps to camera space as
// x_cam = model_to_camera_flip() · R · X + t, then to pixels with K.
#include "morph/pose.h"

#include <Eigen/Core>

namespace facesynth::morph {

struct Intrinsics {
    double fx = 0, fy = 0;  // pixels
    double cx = 0, cy = 0;  // pixels, 0-based
    int width = 0, height = 0;
};

struct CameraPose {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // model-space rotation R (pose.h)
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // camera space, mm (t.z = distance)
};

// x_cam = flip · R · X + t.
[[nodiscard]] Eigen::Vector3d to_camera(const CameraPose& pose, const Eigen::Vector3d& model_point);
[[nodiscard]] Eigen::Matrix3Xd to_camera(const CameraPose& pose, const Eigen::Matrix3Xf& model_points);
// Pixel coordinates of a camera-space point (z > 0).
[[nodiscard]] Eigen::Vector2d project(const Intrinsics& k, const Eigen::Vector3d& camera_point);
[[nodiscard]] Eigen::Matrix2Xd project(const Intrinsics& k, const CameraPose& pose, const Eigen::Matrix3Xf& model_points);

// Intrinsics for a given vertical field of view (degrees), principal point at the image centre.
[[nodiscard]] Intrinsics intrinsics_from_fov(double vertical_fov_degrees, int width, int height);

}  // namespace facesynth::morph
