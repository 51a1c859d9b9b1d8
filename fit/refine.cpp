// The only translation unit that includes Ceres (keeps build times down).
#include "fit/refine.h"

#include "fit/landmark_basis.h"
#include "core/error.h"
#include "morph/landmarks.h"

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

namespace facesynth::fit {
namespace {

// Pixel of model point X under x_cam = flip · R(angle_axis) · X + t, pixel = f · x_cam.xy / x_cam.z + c.
template <class T>
void project_point(const T* angle_axis, const T* t, const T* log_focal, const T* x, double cx, double cy, T* pixel) {
    T p[3];
    ceres::AngleAxisRotatePoint(angle_axis, x, p);
    const T xc = p[0] + t[0], yc = -p[1] + t[1], zc = -p[2] + t[2];
    const T f = exp(log_focal[0]);
    pixel[0] = f * xc / zc + cx;
    pixel[1] = f * yc / zc + cy;
}

// One landmark: residual (pixel - observed) · sqrt(w) / σ. Parameter blocks: rotation (angle-axis, 3),
// translation (3), log focal (1), α (K) and, when fitted, ψ (E). The point X = m + V α + E ψ is linear
// in the coefficients, so the Jacobian is forward-mode autodiff over (pose, X) chained with V and E.
class LandmarkCost final : public ceres::CostFunction {
public:
    LandmarkCost(Eigen::Vector3d mean, Eigen::MatrixXd identity, Eigen::MatrixXd expression, Eigen::Vector2d observed,
                 double scale, double cx, double cy)
        : mean_(std::move(mean)), identity_(std::move(identity)), expression_(std::move(expression)),
          observed_(std::move(observed)), scale_(scale), cx_(cx), cy_(cy) {
        set_num_residuals(2);
        auto* sizes = mutable_parameter_block_sizes();
        *sizes = {3, 3, 1, static_cast<int>(identity_.cols())};
        if (expression_.cols() > 0) sizes->push_back(static_cast<int>(expression_.cols()));
    }

    bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
        const auto k = identity_.cols(), e = expression_.cols();
        Eigen::Vector3d x = mean_ + identity_ * Eigen::Map<const Eigen::VectorXd>(parameters[3], k);
        if (e > 0) x += expression_ * Eigen::Map<const Eigen::VectorXd>(parameters[4], e);
        using Jet = ceres::Jet<double, 10>;
        Jet aa[3], t[3], lf[1], xj[3], pixel[2];
        for (int i = 0; i < 3; ++i) {
            aa[i] = Jet(parameters[0][i], i);
            t[i] = Jet(parameters[1][i], 3 + i);
            xj[i] = Jet(x(i), 7 + i);
        }
        lf[0] = Jet(parameters[2][0], 6);
        project_point(aa, t, lf, xj, cx_, cy_, pixel);
        residuals[0] = scale_ * (pixel[0].a - observed_(0));
        residuals[1] = scale_ * (pixel[1].a - observed_(1));
        if (!jacobians) return std::isfinite(residuals[0]) && std::isfinite(residuals[1]);
        for (int r = 0; r < 2; ++r) {
            const auto& v = pixel[r].v;
            if (jacobians[0])
                for (int i = 0; i < 3; ++i) jacobians[0][r * 3 + i] = scale_ * v(i);
            if (jacobians[1])
                for (int i = 0; i < 3; ++i) jacobians[1][r * 3 + i] = scale_ * v(3 + i);
            if (jacobians[2]) jacobians[2][r] = scale_ * v(6);
            const Eigen::RowVector3d d_x = scale_ * v.segment<3>(7).transpose();
            if (jacobians[3]) Eigen::Map<Eigen::RowVectorXd>(jacobians[3] + r * k, k) = d_x * identity_;
            if (e > 0 && jacobians[4]) Eigen::Map<Eigen::RowVectorXd>(jacobians[4] + r * e, e) = d_x * expression_;
        }
        return std::isfinite(residuals[0]) && std::isfinite(residuals[1]);
    }

private:
    Eigen::Vector3d mean_;
    Eigen::MatrixXd identity_, expression_;
    Eigen::Vector2d observed_;
    double scale_, cx_, cy_;
};

// Blendshape weights must stay >= 0. Hard bounds make Levenberg-Marquardt crawl (projected steps
// disagree with the model's predicted decrease), so a one-sided quadratic penalty keeps them there:
// r_j = κ · min(ψ_j, 0); the result is clamped at 0 afterwards (the penalty leaves |ψ_j| ≲ 1/κ² below).
class NonNegativePenalty final : public ceres::CostFunction {
public:
    NonNegativePenalty(int size, double kappa) : kappa_(kappa) {
        set_num_residuals(size);
        mutable_parameter_block_sizes()->push_back(size);
    }
    bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
        const int n = num_residuals();
        if (jacobians && jacobians[0]) std::fill(jacobians[0], jacobians[0] + n * n, 0.0);
        for (int j = 0; j < n; ++j) {
            const bool negative = parameters[0][j] < 0;
            residuals[j] = negative ? kappa_ * parameters[0][j] : 0.0;
            if (jacobians && jacobians[0] && negative) jacobians[0][j * n + j] = kappa_;
        }
        return true;
    }

private:
    double kappa_;
};

}  // namespace

RefineResult refine(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const FitResult& initial,
                    const FitOptions& fit_options, const RefineOptions& options) {
    const morph::MorphableModel& model = fitter.model();
    if (landmarks.cols() != morph::kNumIbugLandmarks)
        throw core::Error("refine: expected 68 iBUG landmarks, got " + std::to_string(landmarks.cols()));
    if (initial.correspondences.size() != static_cast<std::size_t>(morph::kNumIbugLandmarks) || initial.used.size() < 4)
        throw core::Error("refine: the initial fit is incomplete");
    if (!(options.landmark_sigma_px > 0) || !(options.huber_px > 0)) throw core::Error("refine: sigma and Huber threshold must be > 0");

    const int k_all = model.num_shape_components();
    const int k = fit_options.shape_components > 0 ? std::min(fit_options.shape_components, k_all) : k_all;
    LandmarkBasis basis(model, k);
    const int e = fit_options.fit_expression ? basis.e() : 0;
    const auto* blendshapes = model.expression ? std::get_if<std::vector<morph::Blendshape>>(&*model.expression) : nullptr;

    RefineResult result;
    result.correspondences = initial.correspondences;
    // Principal point and focal length.
    result.intrinsics = options.intrinsics;
    if (options.intrinsics.width <= 0) {
        Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::max()), high = -low;
        for (int id : initial.used) {
            low = low.cwiseMin(landmarks.col(id));
            high = high.cwiseMax(landmarks.col(id));
        }
        result.intrinsics.cx = 0.5 * (low.x() + high.x());
        result.intrinsics.cy = 0.5 * (low.y() + high.y());
    }
    const bool estimate_focal = !(options.intrinsics.fx > 0);
    double focal = options.intrinsics.fx;
    if (estimate_focal) {
        focal = options.intrinsics.width > 0 ? 1.5 * std::max(options.intrinsics.width, options.intrinsics.height)
                                             : initial.pose.scale * 800.0;
    }
    const double cx = result.intrinsics.cx, cy = result.intrinsics.cy;

    // Start: the weak-perspective camera of the linear fit placed at depth f / s.
    double angle_axis[3], translation[3], log_focal[1] = {std::log(focal)};
    const double prior_log_focal = log_focal[0];
    {
        const Eigen::Matrix3d r = initial.pose.rotation;
        ceres::RotationMatrixToAngleAxis(r.data(), angle_axis);  // column-major, as Eigen stores it
        const double z = focal / initial.pose.scale;
        translation[0] = (initial.pose.translation.x() - cx) / initial.pose.scale;
        translation[1] = (initial.pose.translation.y() - cy) / initial.pose.scale;
        translation[2] = z;
    }
    Eigen::VectorXd alpha = Eigen::VectorXd::Zero(k), psi = Eigen::VectorXd::Zero(std::max(e, 0));
    for (int c = 0; c < k; ++c) alpha(c) = initial.alpha[static_cast<std::size_t>(c)];
    for (int c = 0; c < e; ++c) psi(c) = initial.psi[static_cast<std::size_t>(c)];

    std::vector<int> jaw_used;
    if (fit_options.jaw == JawMode::kContour)
        for (int id : initial.used)
            if (id < morph::kNumJawLandmarks && id != morph::kChinLandmark) jaw_used.push_back(id);
    const int rounds = jaw_used.empty() ? 1 : std::max(1, options.contour_rounds);
    const auto n = static_cast<Eigen::Index>(initial.used.size());

    auto weight_of = [&](int id) { return fit_options.weights.size() ? fit_options.weights(id) : 1.0; };
    for (int round = 0; round < rounds; ++round) {
        if (round > 0) {
            RefineResult current = result;
            current.pose.rotation = Eigen::Matrix3d::Zero();
            ceres::AngleAxisToRotationMatrix(angle_axis, current.pose.rotation.data());
            current.pose.translation = Eigen::Vector3d(translation[0], translation[1], translation[2]);
            current.intrinsics.fx = current.intrinsics.fy = std::exp(log_focal[0]);
            std::vector<float> a(static_cast<std::size_t>(k_all), 0.0f), p(static_cast<std::size_t>(basis.e()), 0.0f);
            for (int c = 0; c < k; ++c) a[static_cast<std::size_t>(c)] = static_cast<float>(alpha(c));
            for (int c = 0; c < e; ++c) p[static_cast<std::size_t>(c)] = static_cast<float>(psi(c));
            // The same pinhole projection synth's labels use (morph/jaw_contour.h under perspective).
            const PinholeView view{current.pose.rotation, current.pose.translation, current.intrinsics.fx, cx, cy};
            const auto jaw = fitter.contour().jaw_correspondences(landmarks, view, a, p, jaw_used);
            for (int id : jaw_used)
                if (jaw[static_cast<std::size_t>(id)])
                    result.correspondences[static_cast<std::size_t>(id)] = *jaw[static_cast<std::size_t>(id)];
        }
        basis.resize(n);
        for (Eigen::Index i = 0; i < n; ++i) basis.set_point(i, result.correspondences[static_cast<std::size_t>(initial.used[static_cast<std::size_t>(i)])]);

        ceres::Problem problem;
        for (Eigen::Index i = 0; i < n; ++i) {
            const int id = initial.used[static_cast<std::size_t>(i)];
            if (!defined(result.correspondences[static_cast<std::size_t>(id)])) continue;
            const double scale = std::sqrt(weight_of(id)) / options.landmark_sigma_px;
            auto* cost = new LandmarkCost(basis.rows().mean.col(i), basis.rows().identity.middleRows(3 * i, 3),
                                          e > 0 ? Eigen::MatrixXd(basis.rows().expression.middleRows(3 * i, 3)) : Eigen::MatrixXd(3, 0),
                                          landmarks.col(id), scale, cx, cy);
            auto* loss = new ceres::HuberLoss(options.huber_px / options.landmark_sigma_px);
            if (e > 0)
                problem.AddResidualBlock(cost, loss, {angle_axis, translation, log_focal, alpha.data(), psi.data()});
            else
                problem.AddResidualBlock(cost, loss, {angle_axis, translation, log_focal, alpha.data()});
        }
        problem.AddResidualBlock(new ceres::NormalPrior(std::sqrt(options.identity_prior) * Eigen::MatrixXd::Identity(k, k),
                                                        Eigen::VectorXd::Zero(k)),
                                 nullptr, alpha.data());
        if (e > 0) {
            problem.AddResidualBlock(new ceres::NormalPrior(std::sqrt(options.expression_prior) * Eigen::MatrixXd::Identity(e, e),
                                                            Eigen::VectorXd::Zero(e)),
                                     nullptr, psi.data());
            if (blendshapes) problem.AddResidualBlock(new NonNegativePenalty(e, 100.0), nullptr, psi.data());
        }
        if (estimate_focal) {
            Eigen::MatrixXd a(1, 1);
            a(0, 0) = 1.0 / std::numbers::ln2;
            problem.AddResidualBlock(new ceres::NormalPrior(a, Eigen::VectorXd::Constant(1, prior_log_focal)), nullptr, log_focal);
        } else {
            problem.SetParameterBlockConstant(log_focal);
        }

        ceres::Solver::Options solver;
        solver.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
        solver.max_num_iterations = options.max_iterations;
        solver.num_threads = 1;
        solver.logging_type = ceres::SILENT;
        solver.minimizer_progress_to_stdout = false;
        solver.function_tolerance = 1e-6;
        solver.parameter_tolerance = 1e-8;
        ceres::Solver::Summary summary;
        ceres::Solve(solver, &problem, &summary);
        if (summary.termination_type == ceres::FAILURE) throw core::Error("refine: solver failed: " + summary.message);
        result.iterations += static_cast<int>(summary.iterations.size());
    }

    result.intrinsics.fx = result.intrinsics.fy = std::exp(log_focal[0]);
    result.pose.rotation = Eigen::Matrix3d::Zero();
    ceres::AngleAxisToRotationMatrix(angle_axis, result.pose.rotation.data());
    result.pose.translation = Eigen::Vector3d(translation[0], translation[1], translation[2]);
    result.angles = morph::euler_from_rotation(result.pose.rotation);
    result.alpha.assign(static_cast<std::size_t>(k_all), 0.0f);
    for (int c = 0; c < k; ++c) result.alpha[static_cast<std::size_t>(c)] = static_cast<float>(alpha(c));
    result.psi.assign(static_cast<std::size_t>(basis.e()), 0.0f);
    if (blendshapes) psi = psi.cwiseMax(0.0);
    for (int c = 0; c < e; ++c) result.psi[static_cast<std::size_t>(c)] = static_cast<float>(psi(c));

    LandmarkBasis all(model, k);
    all.resize(morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) all.set_point(i, result.correspondences[static_cast<std::size_t>(i)]);
    Eigen::VectorXd psi_all = Eigen::VectorXd::Zero(all.e());
    psi_all.head(e) = psi;
    const Eigen::Matrix3Xd points = all.positions(alpha, psi_all);
    result.projected.resize(2, morph::kNumIbugLandmarks);
    double sum = 0, weights = 0;
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        if (!defined(result.correspondences[static_cast<std::size_t>(i)])) {
            result.projected.col(i).setConstant(std::numeric_limits<double>::quiet_NaN());
            continue;
        }
        result.projected.col(i) = project(result.intrinsics, to_camera(result.pose, Eigen::Vector3d(points.col(i))));
    }
    for (int id : initial.used) {
        if (!defined(result.correspondences[static_cast<std::size_t>(id)])) continue;
        sum += weight_of(id) * (result.projected.col(id) - landmarks.col(id)).squaredNorm();
        weights += weight_of(id);
    }
    result.reprojection_rms_px = weights > 0 ? std::sqrt(sum / weights) : 0.0;
    return result;
}

RefineResult fit_and_refine(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const FitOptions& fit_options,
                            const RefineOptions& options) {
    return refine(fitter, landmarks, fitter.fit(landmarks, fit_options), fit_options, options);
}

}  // namespace facesynth::fit
