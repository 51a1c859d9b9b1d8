#pragma once
// Affine camera estimation by the Gold Standard Algorithm (Hartley & Zisserman, 2nd ed., Alg. 7.2)
// and its decomposition into the project's pose convention (morph/pose.h, docs/conventions.md).
#include "morph/pose.h"

#include <Eigen/Core>

namespace facesynth::fit {

// x_pixel = P · [X; 1] with P a 3 x 4 matrix whose last row is (0, 0, 0, 1); X in model space (mm),
// x_pixel 0-based pixels.
struct AffineCamera {
    Eigen::Matrix<double, 3, 4> matrix = Eigen::Matrix<double, 3, 4>::Zero();

    [[nodiscard]] Eigen::Vector2d project(const Eigen::Vector3d& model_point) const {
        return matrix.topLeftCorner<2, 3>() * model_point + matrix.block<2, 1>(0, 3);
    }
};

// Scaled orthographic camera: x_pixel = scale · (flip · R · X)_xy + translation, with R a rotation in
// the pose.h convention (R = Rz(roll) Rx(pitch) Ry(yaw)) and flip = diag(1, -1, -1), so yaw, pitch and
// roll mean the same as in the renderer's ground truth.
struct ScaledOrthographic {
    double scale = 1;                                  // pixels per mm
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector2d translation = Eigen::Vector2d::Zero();  // pixels: where the model origin projects
    morph::EulerAngles angles;

    [[nodiscard]] AffineCamera to_affine() const;
};

// Least-squares affine camera from n >= 4 correspondences (columns). Points are normalised first
// (2D: centroid at the origin, RMS distance √2; 3D: RMS distance √3). `weights` (size n, >= 0,
// may be empty for all ones) weights each correspondence. Throws core::Error on fewer than 4
// (weighted) points, non-finite coordinates, or a degenerate (collinear / coplanar-degenerate) set.
[[nodiscard]] AffineCamera estimate_affine_camera(const Eigen::Matrix2Xd& image_points,
                                                  const Eigen::Matrix3Xd& model_points,
                                                  const Eigen::VectorXd& weights = {});

// Nearest scaled orthographic camera: the 2 x 3 part's rows are orthonormalised by SVD (scale = mean
// singular value), the third row of R completes a right-handed frame.
[[nodiscard]] ScaledOrthographic decompose(const AffineCamera& camera);

}  // namespace facesynth::fit
