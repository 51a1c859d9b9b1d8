#pragma once
// Pose and camera conventions (docs/conventions.md), written down once.
//
// Model space: mm, right-handed, +x toward the viewer's right, +y up, +z out of the face.
// R = Rz(roll) · Rx(pitch) · Ry(yaw), angles in degrees, applied to model points, where
//   yaw   > 0 turns the face toward the viewer's right (the nose moves to image +x),
//   pitch > 0 makes the face look up (the nose moves to model +y),
//   roll  > 0 turns the face counter-clockwise in the image.
// Ry and Rz are the right-handed rotations about +y and +z; Rx(pitch) is the right-handed
// rotation about +x by -pitch (a right-handed +x rotation would tip the nose down).
//
// Camera space (OpenCV): x right, y down, z forward. x_cam = kModelToCamera · R · X + t.
#include <Eigen/Core>

namespace facesynth::morph {

struct EulerAngles {
    double yaw = 0;    // degrees
    double pitch = 0;  // degrees
    double roll = 0;   // degrees
};

[[nodiscard]] Eigen::Matrix3d rotation_from_euler(const EulerAngles& angles);

// Inverse of rotation_from_euler for any rotation matrix; pitch is in [-90, 90].
[[nodiscard]] EulerAngles euler_from_rotation(const Eigen::Matrix3d& rotation);

// Fixed flip of y and z taking (rotated) model space into OpenCV camera space.
[[nodiscard]] inline Eigen::Matrix3d model_to_camera_flip() {
    return Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
}

}  // namespace facesynth::morph
