#include "morph/camera.h"

#include <cmath>
#include <numbers>

namespace facesynth::morph {

Eigen::Vector3d to_camera(const CameraPose& pose, const Eigen::Vector3d& x) {
    return model_to_camera_flip() * (pose.rotation * x) + pose.translation;
}

Eigen::Matrix3Xd to_camera(const CameraPose& pose, const Eigen::Matrix3Xf& points) {
    const Eigen::Matrix3d m = model_to_camera_flip() * pose.rotation;
    Eigen::Matrix3Xd out = m * points.cast<double>();
    out.colwise() += pose.translation;
    return out;
}

Eigen::Vector2d project(const Intrinsics& k, const Eigen::Vector3d& c) {
    return {k.fx * c.x() / c.z() + k.cx, k.fy * c.y() / c.z() + k.cy};
}

Eigen::Matrix2Xd project(const Intrinsics& k, const CameraPose& pose, const Eigen::Matrix3Xf& points) {
    const Eigen::Matrix3Xd c = to_camera(pose, points);
    Eigen::Matrix2Xd out(2, c.cols());
    for (Eigen::Index i = 0; i < c.cols(); ++i) out.col(i) = project(k, Eigen::Vector3d(c.col(i)));
    return out;
}

Intrinsics intrinsics_from_fov(double fov, int width, int height) {
    Intrinsics k;
    k.width = width;
    k.height = height;
    k.fy = 0.5 * height / std::tan(0.5 * fov * std::numbers::pi / 180.0);
    k.fx = k.fy;
    k.cx = 0.5 * (width - 1);
    k.cy = 0.5 * (height - 1);
    return k;
}

}  // namespace facesynth::morph
