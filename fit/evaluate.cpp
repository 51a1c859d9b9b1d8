#include "fit/evaluate.h"

#include "core/error.h"
#include "core/random.h"
#include "morph/sampling.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>

namespace facesynth::fit {
namespace {

// a - b wrapped to [-180, 180).
double signed_angle_difference(double a, double b) {
    const double d = std::fmod(a - b + 180.0, 360.0);
    return (d < 0 ? d + 360.0 : d) - 180.0;
}

double thread_cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

double rmse(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
    return std::sqrt(3.0 * (a - b).cast<double>().squaredNorm() / static_cast<double>(a.size()));  // per vertex
}

}  // namespace

FitMetrics evaluate_fit(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const FitTruth& truth, const EvalOptions& options) {
    const morph::MorphableModel& model = fitter.model();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = thread_cpu_ms();
    std::vector<float> alpha;
    FitMetrics m;
    const FitResult linear = fitter.fit(landmarks, options.fit);
    if (options.refine) {
        const RefineResult r = refine(fitter, landmarks, linear, options.fit, options.refine_options);
        m.fitted = r.angles;
        m.reprojection_px = r.reprojection_rms_px;
        alpha = r.alpha;
    } else {
        m.fitted = linear.pose.angles;
        m.reprojection_px = linear.reprojection_rms_px;
        alpha = linear.alpha;
    }
    m.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    m.cpu_ms = thread_cpu_ms() - cpu_start;

    m.truth = morph::euler_from_rotation(truth.rotation);
    m.yaw_signed_error_deg = signed_angle_difference(m.fitted.yaw, m.truth.yaw);
    m.pitch_signed_error_deg = signed_angle_difference(m.fitted.pitch, m.truth.pitch);
    m.roll_signed_error_deg = signed_angle_difference(m.fitted.roll, m.truth.roll);
    m.yaw_error_deg = std::abs(m.yaw_signed_error_deg);
    m.pitch_error_deg = std::abs(m.pitch_signed_error_deg);
    m.roll_error_deg = std::abs(m.roll_signed_error_deg);

    const int k = model.num_shape_components();
    Eigen::VectorXf true_alpha = Eigen::VectorXf::Zero(k), fit_alpha = Eigen::VectorXf::Zero(k);
    for (int c = 0; c < k && c < static_cast<int>(truth.alpha.size()); ++c) true_alpha(c) = truth.alpha[static_cast<std::size_t>(c)];
    for (int c = 0; c < k && c < static_cast<int>(alpha.size()); ++c) fit_alpha(c) = alpha[static_cast<std::size_t>(c)];
    m.alpha_rmse = k > 0 ? std::sqrt((fit_alpha - true_alpha).cast<double>().squaredNorm() / k) : 0.0;
    const Eigen::VectorXf true_shape = model.shape.draw(truth.alpha);
    m.vertex_rmse_mm = rmse(model.shape.draw(alpha), true_shape);
    m.vertex_rmse_mm_meanshape = rmse(model.shape.mean, true_shape);
    return m;
}

SyntheticCase make_synthetic_case(const morph::MorphableModel& model, std::uint64_t seed, std::uint64_t index,
                                  const SyntheticOptions& o) {
    SyntheticCase c;
    core::Rng identity = core::make_rng(seed, index, core::RandomStream::kIdentity);
    c.truth.alpha = morph::sample_coefficients(identity, model.num_shape_components(), 3.0);
    const int e = model.num_expression_components();
    core::Rng expression = core::make_rng(seed, index, core::RandomStream::kExpression);
    const bool blendshapes = model.expression && std::holds_alternative<std::vector<morph::Blendshape>>(*model.expression);
    for (int i = 0; i < e; ++i)
        c.psi.push_back(static_cast<float>(blendshapes ? expression.uniform(0, o.expression_scale)
                                                       : o.expression_scale * expression.truncated_normal(3.0)));
    core::Rng pose = core::make_rng(seed, index, core::RandomStream::kPose);
    const morph::EulerAngles angles{pose.uniform(-o.max_yaw_deg, o.max_yaw_deg), pose.uniform(-o.max_pitch_deg, o.max_pitch_deg),
                             pose.uniform(-o.max_roll_deg, o.max_roll_deg)};
    c.truth.rotation = morph::rotation_from_euler(angles);
    c.intrinsics = morph::intrinsics_from_fov(o.fov_deg, o.image_size, o.image_size);
    // Distance so that the model's height fills about 60% of the image.
    const auto mean = morph::as_points(model.shape.mean);
    const double height = static_cast<double>(mean.row(1).maxCoeff() - mean.row(1).minCoeff());
    const double distance = c.intrinsics.fy * height / (0.6 * o.image_size);
    core::Rng camera = core::make_rng(seed, index, core::RandomStream::kCamera);
    c.pose.rotation = c.truth.rotation;
    // One draw per statement, z, y, x: the order GCC drew them in when they were one expression.
    const double depth = distance * camera.uniform(0.9, 1.1);
    const double shift_y = camera.uniform(-0.05, 0.05) * height;
    const double shift_x = camera.uniform(-0.05, 0.05) * height;
    c.pose.translation = Eigen::Vector3d(shift_x, shift_y, depth);
    const Eigen::Matrix3Xf shape = model.shape_instance(c.truth.alpha, c.psi);
    c.landmarks = project(c.intrinsics, c.pose, model.landmark_positions(shape));
    core::Rng noise = core::make_rng(seed, index, core::RandomStream::kNoise);
    for (Eigen::Index i = 0; i < c.landmarks.cols(); ++i) {
        const auto& p = model.landmarks[static_cast<std::size_t>(i)];
        if (p.weights[0] + p.weights[1] + p.weights[2] == 0.0f) {
            c.landmarks.col(i).setConstant(std::numeric_limits<double>::quiet_NaN());
            continue;
        }
        if (o.noise_px > 0) {
            const double dy = noise.normal();  // y before x: GCC's order (see above)
            const double dx = noise.normal();
            c.landmarks.col(i) += o.noise_px * Eigen::Vector2d(dx, dy);
        }
    }
    return c;
}

std::vector<LambdaScore> score_lambdas(const Fitter& fitter, const std::vector<double>& candidates, int count,
                                       std::uint64_t seed, const SyntheticOptions& synthetic, const FitOptions& base) {
    if (count < 1) throw core::Error("lambda selection: needs at least one validation case");
    std::vector<SyntheticCase> cases;
    cases.reserve(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) cases.push_back(make_synthetic_case(fitter.model(), seed, static_cast<std::uint64_t>(i), synthetic));
    std::vector<LambdaScore> scores;
    for (double lambda : candidates) {
        EvalOptions o;
        o.fit = base;
        o.fit.lambda = o.fit.expression_lambda = lambda;
        LambdaScore s;
        s.lambda = lambda;
        for (const auto& c : cases) {
            const FitMetrics m = evaluate_fit(fitter, c.landmarks, c.truth, o);
            s.vertex_rmse_mm += m.vertex_rmse_mm / count;
            s.vertex_rmse_mm_meanshape += m.vertex_rmse_mm_meanshape / count;
            s.alpha_rmse += m.alpha_rmse / count;
        }
        scores.push_back(s);
    }
    return scores;
}

}  // namespace facesynth::fit
