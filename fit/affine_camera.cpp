#include "fit/affine_camera.h"

#include "core/error.h"

#include <Eigen/Dense>

#include <cmath>
#include <string>

namespace facesynth::fit {
namespace {

// Similarity transform (as a (D+1) x (D+1) matrix) moving the weighted centroid to the origin and
// scaling the weighted RMS distance from it to √D.
template <int D>
Eigen::Matrix<double, D + 1, D + 1> normalising_transform(const Eigen::Matrix<double, D, Eigen::Dynamic>& points,
                                                          const Eigen::VectorXd& w) {
    const double total = w.sum();
    const Eigen::Matrix<double, D, 1> centroid = points * w / total;
    const double mean_sq = ((points.colwise() - centroid).colwise().squaredNorm().transpose().cwiseProduct(w)).sum() / total;
    if (!(mean_sq > 0)) throw core::Error("affine camera: all points coincide");
    const double s = std::sqrt(static_cast<double>(D) / mean_sq);
    Eigen::Matrix<double, D + 1, D + 1> t = Eigen::Matrix<double, D + 1, D + 1>::Identity();
    t.template topLeftCorner<D, D>() *= s;
    t.template topRightCorner<D, 1>() = -s * centroid;
    return t;
}

}  // namespace

AffineCamera ScaledOrthographic::to_affine() const {
    AffineCamera c;
    const Eigen::Matrix3d m = morph::model_to_camera_flip() * rotation;
    c.matrix.topLeftCorner<2, 3>() = scale * m.topRows<2>();
    c.matrix.block<2, 1>(0, 3) = translation;
    c.matrix(2, 3) = 1;
    return c;
}

AffineCamera estimate_affine_camera(const Eigen::Matrix2Xd& image_points, const Eigen::Matrix3Xd& model_points,
                                    const Eigen::VectorXd& weights_in) {
    const Eigen::Index n = image_points.cols();
    if (model_points.cols() != n)
        throw core::Error("affine camera: " + std::to_string(n) + " image points but " + std::to_string(model_points.cols()) +
                    " model points");
    const Eigen::VectorXd weights = weights_in.size() == 0 ? Eigen::VectorXd::Ones(n) : weights_in;
    if (weights.size() != n) throw core::Error("affine camera: " + std::to_string(weights.size()) + " weights for " + std::to_string(n) + " points");
    if (!image_points.allFinite() || !model_points.allFinite() || !weights.allFinite())
        throw core::Error("affine camera: non-finite (NaN or infinite) coordinates");
    if ((weights.array() < 0).any()) throw core::Error("affine camera: negative weight");
    const Eigen::Index used = (weights.array() > 0).count();
    if (used < 4) throw core::Error("affine camera: needs at least 4 points, got " + std::to_string(used));

    const Eigen::Matrix3d t2 = normalising_transform<2>(image_points, weights);
    const Eigen::Matrix4d t3 = normalising_transform<3>(model_points, weights);
    const Eigen::Matrix2Xd x = (t2.topLeftCorner<2, 2>() * image_points).colwise() + t2.topRightCorner<2, 1>();
    const Eigen::Matrix3Xd big_x = (t3.topLeftCorner<3, 3>() * model_points).colwise() + t3.topRightCorner<3, 1>();

    // 2D collinearity: the weighted scatter of the normalised image points must have two directions.
    const Eigen::VectorXd sw = weights.cwiseSqrt();
    const Eigen::Matrix2d scatter = x * weights.asDiagonal() * x.transpose();
    const Eigen::Vector2d scatter_ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter, Eigen::EigenvaluesOnly).eigenvalues();
    if (scatter_ev(0) < 1e-9 * scatter_ev(1)) throw core::Error("affine camera: image points are collinear");

    // The 2n x 8 system of Alg. 7.2 splits into two least-squares problems (one per image row)
    // sharing the design matrix [X̃ᵀ 1].
    Eigen::MatrixXd design(n, 4);
    design.leftCols<3>() = big_x.transpose();
    design.col(3).setOnes();
    design = sw.asDiagonal() * design;
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::Vector4d sv = svd.singularValues();
    if (sv(3) < 1e-9 * sv(0)) throw core::Error("affine camera: model points are degenerate (collinear or coincident)");
    const Eigen::MatrixXd rhs = sw.asDiagonal() * x.transpose();  // n x 2
    const Eigen::Matrix<double, 4, 2> p_rows = svd.solve(rhs);

    Eigen::Matrix<double, 3, 4> p_normalised = Eigen::Matrix<double, 3, 4>::Zero();
    p_normalised.topRows<2>() = p_rows.transpose();
    p_normalised(2, 3) = 1;
    AffineCamera camera;
    camera.matrix = t2.inverse() * p_normalised * t3;
    return camera;
}

ScaledOrthographic decompose(const AffineCamera& camera) {
    Eigen::Matrix<double, 2, 3> b = camera.matrix.topLeftCorner<2, 3>();
    b.row(1) *= -1.0;  // undo the y flip: b = scale · [r1; r2]
    Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(b, Eigen::ComputeFullU | Eigen::ComputeFullV);
    if (!(svd.singularValues()(1) > 0)) throw core::Error("affine camera: rank-deficient camera matrix");
    const Eigen::Matrix<double, 2, 3> rows = svd.matrixU() * svd.matrixV().leftCols<2>().transpose();
    ScaledOrthographic s;
    s.scale = svd.singularValues().mean();
    s.rotation.row(0) = rows.row(0);
    s.rotation.row(1) = rows.row(1);
    s.rotation.row(2) = rows.row(0).cross(rows.row(1));
    s.translation = camera.matrix.block<2, 1>(0, 3);
    s.angles = morph::euler_from_rotation(s.rotation);
    return s;
}

}  // namespace facesynth::fit
