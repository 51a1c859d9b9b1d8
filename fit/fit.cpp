#include "fit/fit.h"

#include "fit/landmark_basis.h"
#include "morph/error.h"
#include "morph/landmarks.h"

#include <Eigen/Cholesky>

#include <cmath>
#include <limits>
#include <string>

namespace facesynth::fit {
namespace {

// Regularised weighted linear least squares for the coefficients c of one basis:
//   min_c Σ_i w_i ‖A (m_i + B_i c) + a − x_i‖² / σ² + λ ‖c‖²   (Eq. 2 in docs/fit.md),
// optionally with c >= 0 (projected Gauss-Seidel on the normal equations, exact for this convex QP).
Eigen::VectorXd nonnegative_solve(Eigen::MatrixXd h, const Eigen::VectorXd& g, const Eigen::VectorXd& start);

// Scalar: float in the alternation (twice the SIMD width; the system is regularised), double where
// exactness matters (fit_identity_for_camera).
template <class Scalar>
Eigen::VectorXd solve_coefficients(const Eigen::Matrix<double, 2, 3>& a3, const Eigen::Vector2d& a,
                                   const Eigen::Matrix3Xd& fixed_part,
                                   const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& bt,
                                   const Eigen::Matrix2Xd& observed, const Eigen::VectorXd& weights, double sigma,
                                   double lambda, bool non_negative, const Eigen::VectorXd& start) {
    // bt: the basis rows transposed (K x 3n), so each point's three rows are contiguous columns.
    using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
    using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
    const Eigen::Index n = observed.cols(), k = bt.rows();
    Matrix jt(k, 2 * n);  // Jᵀ
    Vector b(2 * n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const double sw = std::sqrt(weights(i)) / sigma;
        const Eigen::Matrix<double, 2, 3> m = sw * a3;
        for (int r = 0; r < 2; ++r)
            jt.col(2 * i + r) = Scalar(m(r, 0)) * bt.col(3 * i) + Scalar(m(r, 1)) * bt.col(3 * i + 1) + Scalar(m(r, 2)) * bt.col(3 * i + 2);
        b.template segment<2>(2 * i) = (sw * (observed.col(i) - a - a3 * fixed_part.col(i))).cast<Scalar>();
    }
    Matrix h = Matrix::Identity(k, k) * Scalar(lambda);
    h.template selfadjointView<Eigen::Lower>().rankUpdate(jt);
    const Vector g = jt * b;
    if (!non_negative) return h.template selfadjointView<Eigen::Lower>().ldlt().solve(g).template cast<double>();
    return nonnegative_solve(h.template cast<double>(), g.template cast<double>(), start);
}

// min ½ cᵀHc − gᵀc subject to c >= 0 (H's lower triangle holds the matrix).
Eigen::VectorXd nonnegative_solve(Eigen::MatrixXd h, const Eigen::VectorXd& g, const Eigen::VectorXd& start) {
    const Eigen::Index k = h.rows();
    h.triangularView<Eigen::StrictlyUpper>() = h.transpose();
    Eigen::VectorXd c = Eigen::VectorXd::Zero(k);
    if (start.size() == k) c = start.cwiseMax(0.0);
    for (int sweep = 0; sweep < 200; ++sweep) {
        double change = 0;
        for (Eigen::Index q = 0; q < k; ++q) {
            if (!(h(q, q) > 0)) continue;
            const double updated = std::max(0.0, c(q) - (h.col(q).dot(c) - g(q)) / h(q, q));
            change = std::max(change, std::abs(updated - c(q)));
            c(q) = updated;
        }
        if (change < 1e-7) break;
    }
    return c;
}


// Checks the input and lists the iBUG points that take part (and, in contour mode, the jaw points
// whose correspondences are re-chosen).
std::vector<int> select_points(const MorphableModel& model, const Eigen::Matrix2Xd& landmarks, const FitOptions& options,
                               bool contour_mode, std::vector<int>* jaw_used) {
    if (landmarks.cols() != kNumIbugLandmarks)
        throw Error("fit: expected " + std::to_string(kNumIbugLandmarks) + " iBUG landmarks, got " + std::to_string(landmarks.cols()));
    if (static_cast<int>(model.landmarks.size()) != kNumIbugLandmarks)
        throw Error("fit: model '" + model.name + "' defines " + std::to_string(model.landmarks.size()) +
                    " landmarks, expected " + std::to_string(kNumIbugLandmarks));
    if (options.weights.size() != 0 && options.weights.size() != kNumIbugLandmarks)
        throw Error("fit: " + std::to_string(options.weights.size()) + " landmark weights, expected 68");
    if (options.iterations < 1) throw Error("fit: iterations must be at least 1");
    if (!(options.lambda >= 0) || !(options.expression_lambda >= 0)) throw Error("fit: regularisation must be >= 0");

    std::vector<int> candidates = options.subset;
    if (candidates.empty())
        for (int i = 0; i < kNumIbugLandmarks; ++i) candidates.push_back(i);
    std::vector<int> used;
    for (int i : candidates) {
        if (i < 0 || i >= kNumIbugLandmarks) throw Error("fit: landmark index " + std::to_string(i) + " out of range 0..67");
        const double w = options.weights.size() ? options.weights(i) : 1.0;
        if (!std::isfinite(w) || w < 0) throw Error("fit: landmark " + std::to_string(i + 1) + " has an invalid weight");
        if (w == 0) continue;
        const bool contour_point = contour_mode && i < kNumJawLandmarks && i != kChinLandmark;
        if (!defined(model.landmarks[static_cast<std::size_t>(i)]) && !contour_point) continue;
        if (!landmarks.col(i).allFinite())
            throw Error("fit: landmark " + std::to_string(i + 1) + " has non-finite coordinates");
        used.push_back(i);
        if (contour_point && jaw_used) jaw_used->push_back(i);
    }
    if (used.size() < 4) throw Error("fit: needs at least 4 usable landmarks, got " + std::to_string(used.size()));
    return used;
}

}  // namespace

std::vector<float> fit_identity_for_camera(const MorphableModel& model, const AffineCamera& camera,
                                           const Eigen::Matrix2Xd& landmarks, const FitOptions& options,
                                           std::span<const float> psi) {
    const std::vector<int> used = select_points(model, landmarks, options, false, nullptr);
    const auto n = static_cast<Eigen::Index>(used.size());
    const int k_all = model.num_shape_components();
    const int k = options.shape_components > 0 ? std::min(options.shape_components, k_all) : k_all;
    LandmarkBasis lin(model, k);
    lin.resize(n);
    Eigen::Matrix2Xd observed(2, n);
    Eigen::VectorXd weights(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const int id = used[static_cast<std::size_t>(i)];
        observed.col(i) = landmarks.col(id);
        weights(i) = options.weights.size() ? options.weights(id) : 1.0;
        lin.set_point(i, model.landmarks[static_cast<std::size_t>(id)]);
    }
    Eigen::Matrix3Xd fixed = lin.rows().mean;
    if (lin.e() > 0 && !psi.empty()) {
        Eigen::VectorXd p = Eigen::VectorXd::Zero(lin.e());
        for (std::size_t i = 0; i < psi.size() && i < static_cast<std::size_t>(lin.e()); ++i) p(static_cast<Eigen::Index>(i)) = psi[i];
        const Eigen::VectorXd ex = lin.rows().expression * p;
        fixed += Eigen::Map<const Eigen::Matrix3Xd>(ex.data(), 3, n);
    }
    const double sigma = options.landmark_sigma_px > 0 ? options.landmark_sigma_px : decompose(camera).scale;
    const Eigen::VectorXd alpha = solve_coefficients<double>(camera.matrix.topLeftCorner<2, 3>(), camera.matrix.block<2, 1>(0, 3), fixed,
                                                     Eigen::MatrixXd(lin.rows().identity.transpose()), observed, weights, sigma, options.lambda, false, {});
    std::vector<float> out(static_cast<std::size_t>(k_all), 0.0f);
    for (int c = 0; c < k; ++c) out[static_cast<std::size_t>(c)] = static_cast<float>(alpha(c));
    return out;
}

Fitter::Fitter(const MorphableModel& model) : model_(model), contour_(model) {}

FitResult Fitter::fit(const Eigen::Matrix2Xd& landmarks, const FitOptions& options) const {
    const bool contour_mode = options.jaw == JawMode::kContour && !model_.contour.right.empty() && !model_.contour.left.empty();
    FitResult result;
    result.correspondences = model_.landmarks;
    std::vector<int> jaw_used;
    result.used = select_points(model_, landmarks, options, contour_mode, &jaw_used);
    const auto n = static_cast<Eigen::Index>(result.used.size());

    const int k_all = model_.num_shape_components();
    const int k = options.shape_components > 0 ? std::min(options.shape_components, k_all) : k_all;
    LandmarkBasis lin(model_, k);
    const int e = options.fit_expression ? lin.e() : 0;
    lin.resize(n);
    Eigen::Matrix2Xd observed(2, n);
    Eigen::VectorXd given_weights(n), weights(n);  // weights: 0 while a point has no model correspondence
    for (Eigen::Index i = 0; i < n; ++i) {
        const int id = result.used[static_cast<std::size_t>(i)];
        observed.col(i) = landmarks.col(id);
        given_weights(i) = options.weights.size() ? options.weights(id) : 1.0;
        const SurfacePoint& p = result.correspondences[static_cast<std::size_t>(id)];
        weights(i) = defined(p) ? given_weights(i) : 0.0;
        lin.set_point(i, p);
    }

    Eigen::VectorXd alpha = Eigen::VectorXd::Zero(k), psi = Eigen::VectorXd::Zero(lin.e());
    auto to_floats = [](const Eigen::VectorXd& v, std::size_t size) {
        std::vector<float> out(size, 0.0f);
        for (Eigen::Index i = 0; i < v.size(); ++i) out[static_cast<std::size_t>(i)] = static_cast<float>(v(i));
        return out;
    };
    auto estimate_camera = [&]() {
        const Eigen::Matrix3Xd x3 = lin.positions(alpha, psi);
        result.camera = estimate_affine_camera(observed, x3, weights);
        result.pose = decompose(result.camera);
        // Re-centre the translation for the orthonormalised camera (weighted mean residual).
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (model_to_camera_flip() * result.pose.rotation).topRows<2>();
        result.pose.translation = ((observed - a3 * x3) * weights).rowwise().sum() / weights.sum();
        return x3;
    };
    auto rms = [&]() {
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (model_to_camera_flip() * result.pose.rotation).topRows<2>();
        const Eigen::Matrix2Xd r = (a3 * lin.positions(alpha, psi)).colwise() + result.pose.translation - observed;
        return std::sqrt((r.colwise().squaredNorm().transpose().cwiseProduct(weights)).sum() / weights.sum());
    };

    // Float, transposed copies of the basis rows for the solves; refreshed when correspondences change.
    Eigen::MatrixXf identity_t, expression_t;
    auto refresh_transposed = [&]() {
        identity_t = lin.rows().identity.transpose().cast<float>();
        expression_t = lin.rows().expression.transpose().cast<float>();
    };
    refresh_transposed();

    double previous = std::numeric_limits<double>::max();
    for (int it = 0; it < options.iterations; ++it) {
        estimate_camera();
        if (!jaw_used.empty()) {
            const auto jaw = contour_.jaw_correspondences(landmarks, result.pose, to_floats(alpha, k_all),
                                                          to_floats(psi, static_cast<std::size_t>(lin.e())), jaw_used);
            for (Eigen::Index i = 0; i < n; ++i) {
                const int id = result.used[static_cast<std::size_t>(i)];
                if (id >= kNumJawLandmarks || !jaw[static_cast<std::size_t>(id)]) continue;
                result.correspondences[static_cast<std::size_t>(id)] = *jaw[static_cast<std::size_t>(id)];
                lin.set_point(i, result.correspondences[static_cast<std::size_t>(id)]);
                weights(i) = given_weights(i);
            }
            refresh_transposed();
            estimate_camera();
        }
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (model_to_camera_flip() * result.pose.rotation).topRows<2>();
        const double sigma = options.landmark_sigma_px > 0 ? options.landmark_sigma_px : result.pose.scale;
        const auto& rows = lin.rows();
        {
            Eigen::Matrix3Xd fixed = rows.mean;
            if (lin.e() > 0) {
                const Eigen::VectorXd ex = rows.expression * psi;
                fixed += Eigen::Map<const Eigen::Matrix3Xd>(ex.data(), 3, n);
            }
            alpha = solve_coefficients<float>(a3, result.pose.translation, fixed, identity_t, observed, weights, sigma,
                                       options.lambda, false, {});
        }
        if (e > 0) {
            const Eigen::VectorXd id_part = rows.identity * alpha;
            const Eigen::Matrix3Xd fixed = rows.mean + Eigen::Map<const Eigen::Matrix3Xd>(id_part.data(), 3, n);
            psi = solve_coefficients<float>(a3, result.pose.translation, fixed, expression_t, observed, weights, sigma,
                                     options.expression_lambda, lin.has_blendshapes(), psi);
        }
        result.iterations = it + 1;
        const double now = rms();
        if (std::abs(previous - now) < options.convergence_px) break;
        previous = now;
    }
    estimate_camera();
    result.reprojection_rms_px = rms();
    result.camera = result.pose.to_affine();
    result.alpha = to_floats(alpha, static_cast<std::size_t>(k_all));
    result.psi = to_floats(psi, static_cast<std::size_t>(lin.e()));

    // Projections of all 68 correspondences (NaN where the model has none).
    LandmarkBasis all(model_, k);
    all.resize(kNumIbugLandmarks);
    for (int i = 0; i < kNumIbugLandmarks; ++i) all.set_point(i, result.correspondences[static_cast<std::size_t>(i)]);
    const Eigen::Matrix3Xd points = all.positions(alpha, psi);
    result.projected.resize(2, kNumIbugLandmarks);
    for (int i = 0; i < kNumIbugLandmarks; ++i)
        result.projected.col(i) = defined(result.correspondences[static_cast<std::size_t>(i)])
                                      ? result.camera.project(points.col(i))
                                      : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    return result;
}

FitResult fit_landmarks(const MorphableModel& model, const Eigen::Matrix2Xd& landmarks, const FitOptions& options) {
    return Fitter(model).fit(landmarks, options);
}

Eigen::Matrix3Xf fitted_shape(const MorphableModel& model, const FitResult& result) {
    return model.shape_instance(result.alpha, result.psi);
}

}  // namespace facesynth::fit
