#include "fit/fit.h"

#include "common/toy_model.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "core/random.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

namespace facesynth::fit {
namespace {

// The toy model with its 68 landmarks moved to well-spread front-facing vertices (every 7th one),
// so that a linear identity fit is well determined by the landmarks alone.
morph::MorphableModel spread_landmark_model(int components) {
    morph::MorphableModel m = testkit::make_toy_model({.shape_components = components});
    const auto mean = morph::as_points(m.shape.mean);
    std::vector<int> front;
    for (int v = 0; v < m.num_vertices(); ++v)
        if (mean(2, v) > 30) front.push_back(v);
    for (int l = 0; l < 68; ++l) m.landmarks[static_cast<std::size_t>(l)] = morph::SurfacePoint::at_vertex(front[static_cast<std::size_t>(l * 7 % front.size())]);
    return m;
}

Eigen::Matrix2Xd project_landmarks(const morph::MorphableModel& m, const ScaledOrthographic& camera, std::span<const float> alpha,
                                   std::span<const float> psi = {}) {
    const Eigen::Matrix3Xf shape = m.shape_instance(alpha, psi);
    const AffineCamera a = camera.to_affine();
    Eigen::Matrix2Xd out(2, 68);
    for (int l = 0; l < 68; ++l) out.col(l) = a.project(m.landmarks[static_cast<std::size_t>(l)].position(shape).cast<double>());
    return out;
}

TEST(LinearFit, RecoversIdentityForAKnownCameraWithVanishingRegularisation) {
    const morph::MorphableModel m = spread_landmark_model(10);
    for (int trial = 0; trial < 5; ++trial) {
        core::Rng rng(20, static_cast<std::uint64_t>(trial));
        const std::vector<float> alpha = morph::sample_coefficients(rng, 10, 3.0);
        const morph::EulerAngles angles{rng.uniform(-50, 50), rng.uniform(-20, 20), rng.uniform(-20, 20)};
        const ScaledOrthographic camera{rng.uniform(1, 4), morph::rotation_from_euler(angles), {256, 240}, angles};
        FitOptions o;
        o.lambda = 1e-12;
        const std::vector<float> got = fit_identity_for_camera(m, camera.to_affine(), project_landmarks(m, camera, alpha), o);
        for (int c = 0; c < 10; ++c) EXPECT_NEAR(got[static_cast<std::size_t>(c)], alpha[static_cast<std::size_t>(c)], 1e-4) << "component " << c;
    }
}

TEST(LinearFit, AlternationFromScratchConvergesOnExactLandmarks) {
    const morph::MorphableModel m = spread_landmark_model(10);
    for (int trial = 0; trial < 3; ++trial) {
        core::Rng rng(21, static_cast<std::uint64_t>(trial));
        const std::vector<float> alpha = morph::sample_coefficients(rng, 10, 3.0);
        const morph::EulerAngles angles{rng.uniform(-30, 30), rng.uniform(-15, 15), rng.uniform(-10, 10)};
        const ScaledOrthographic camera{3.0, morph::rotation_from_euler(angles), {256, 240}, angles};
        FitOptions o;
        o.lambda = 1e-10;
        o.fit_expression = false;
        o.iterations = 200;
        o.convergence_px = 1e-12;
        const FitResult r = fit_landmarks(m, project_landmarks(m, camera, alpha), o);
        // Block-coordinate descent creeps along the camera/shape valley (the toy components contain
        // linear shears an affine camera can partly absorb), so it gets close, not exact.
        const Eigen::Matrix3Xf truth = m.shape_instance(alpha);
        const double fitted_rmse = std::sqrt((fitted_shape(m, r) - truth).colwise().squaredNorm().mean());
        const double mean_rmse = std::sqrt((morph::as_points(m.shape.mean) - truth).colwise().squaredNorm().mean());
        EXPECT_LT(fitted_rmse, 0.5 * mean_rmse) << "trial " << trial;
        EXPECT_NEAR(r.pose.angles.yaw, angles.yaw, 0.5);
        EXPECT_NEAR(r.pose.angles.pitch, angles.pitch, 0.5);
        EXPECT_NEAR(r.pose.angles.roll, angles.roll, 0.5);
        EXPECT_LT(r.reprojection_rms_px, 0.1);
    }
}

TEST(LinearFit, FirstKComponentsOnlyAndRegularisationShrinks) {
    const morph::MorphableModel m = spread_landmark_model(10);
    core::Rng rng(2, 0);
    const std::vector<float> alpha = morph::sample_coefficients(rng, 10, 3.0);
    const ScaledOrthographic camera{3.0, morph::rotation_from_euler({10, 0, 0}), {256, 240}, {}};
    const Eigen::Matrix2Xd lm = project_landmarks(m, camera, alpha);
    FitOptions o;
    o.fit_expression = false;
    o.shape_components = 4;
    const FitResult r = fit_landmarks(m, lm, o);
    ASSERT_EQ(r.alpha.size(), 10u);
    for (int c = 4; c < 10; ++c) EXPECT_EQ(r.alpha[static_cast<std::size_t>(c)], 0.0f);
    FitOptions weak = o, strong = o;
    weak.shape_components = strong.shape_components = 0;
    weak.lambda = 0.01;
    strong.lambda = 1e4;
    const auto norm = [](const std::vector<float>& a) { return Eigen::Map<const Eigen::VectorXf>(a.data(), static_cast<Eigen::Index>(a.size())).norm(); };
    EXPECT_LT(norm(fit_landmarks(m, lm, strong).alpha), 0.5f * norm(fit_landmarks(m, lm, weak).alpha));
}

TEST(ExpressionFit, RecoversNonNegativeBlendshapeWeightsAlternatingWithIdentity) {
    const morph::MorphableModel base = testkit::make_toy_model({.shape_components = 6});
    core::Rng rng(4, 0);
    const std::vector<float> alpha = morph::sample_coefficients(rng, 6, 2.0);
    const std::vector<float> psi{0.6f, 0.8f};
    const ScaledOrthographic camera{2.0, morph::rotation_from_euler({15, 5, 0}), {200, 220}, {}};
    FitOptions o;
    o.lambda = 1e-8;
    o.expression_lambda = 1e-8;
    o.iterations = 100;
    o.convergence_px = 1e-10;
    const FitResult r = fit_landmarks(base, project_landmarks(base, camera, alpha, psi), o);
    ASSERT_EQ(r.psi.size(), 2u);
    EXPECT_NEAR(r.psi[0], 0.6, 0.02);
    EXPECT_NEAR(r.psi[1], 0.8, 0.02);
    EXPECT_LT(r.reprojection_rms_px, 0.05);

    // A negative "truth" is out of reach: the weight clamps at zero instead of going negative.
    const std::vector<float> negative{-0.8f, 0.0f};
    const FitResult n = fit_landmarks(base, project_landmarks(base, camera, {}, negative), o);
    EXPECT_GE(n.psi[0], 0.0f);
    EXPECT_GE(n.psi[1], 0.0f);
}

TEST(Fit, SubsetsAndMaskedPointsUseOnlyWhatIsGiven) {
    const morph::MorphableModel m = testkit::make_toy_model({});
    const ScaledOrthographic camera{2.0, morph::rotation_from_euler({-20, 10, 5}), {200, 220}, {}};
    Eigen::Matrix2Xd lm = project_landmarks(m, camera, {});
    for (auto subset : {morph::LandmarkSubset::k7, morph::LandmarkSubset::k13, morph::LandmarkSubset::k49, morph::LandmarkSubset::k68}) {
        FitOptions o;
        const auto ids = morph::landmark_subset(subset);
        o.subset.assign(ids.begin(), ids.end());
        Eigen::Matrix2Xd masked = Eigen::Matrix2Xd::Constant(2, 68, std::numeric_limits<double>::quiet_NaN());
        for (int i : o.subset) masked.col(i) = lm.col(i);
        const FitResult r = fit_landmarks(m, masked, o);
        EXPECT_EQ(r.used.size(), ids.size());
        EXPECT_NEAR(r.pose.angles.yaw, -20, 1.0);
        EXPECT_NEAR(r.pose.angles.roll, 5, 1.0);
    }
    FitOptions o;
    o.weights = Eigen::VectorXd::Ones(68);
    lm.col(30) = Eigen::Vector2d(1e4, -1e4);  // a wild point, masked out
    o.weights(30) = 0;
    const FitResult r = fit_landmarks(m, lm, o);
    EXPECT_EQ(r.used.size(), 67u);
    EXPECT_LT(r.reprojection_rms_px, 0.5);
}

// The Fitter caches the landmark basis's Gram blocks for the model's own correspondences and adds only
// what a call's subset, weights or component count change (or starts from scratch when most points
// change). Each of those paths must give the fit of a model in which the excluded points simply do
// not exist.
TEST(Fit, CachedNormalEquationsMatchAModelWithoutTheExcludedPoints) {
    const morph::MorphableModel m = spread_landmark_model(10);
    core::Rng rng(7, 0);
    const std::vector<float> alpha = morph::sample_coefficients(rng, 10, 2.0);
    const ScaledOrthographic camera{2.5, morph::rotation_from_euler({25, -10, 5}), {250, 230}, {}};
    Eigen::Matrix2Xd lm = project_landmarks(m, camera, alpha);
    for (int i = 0; i < 68; ++i) lm.col(i) += Eigen::Vector2d(rng.normal(), rng.normal()) * 0.5;  // so weighting matters
    const auto compare = [&](const FitOptions& options, const std::vector<int>& kept, const char* what) {
        morph::MorphableModel reduced = m;
        for (int i = 0; i < 68; ++i)
            if (std::find(kept.begin(), kept.end(), i) == kept.end()) reduced.landmarks[static_cast<std::size_t>(i)] = morph::SurfacePoint{{}, {0.0f, 0.0f, 0.0f}};  // undefined
        FitOptions plain;
        plain.shape_components = options.shape_components;
        plain.lambda = options.lambda;
        const FitResult expected = fit_landmarks(reduced, lm, plain);
        const FitResult got = fit_landmarks(m, lm, options);
        ASSERT_EQ(got.used.size(), kept.size()) << what;
        for (std::size_t c = 0; c < expected.alpha.size(); ++c) EXPECT_NEAR(got.alpha[c], expected.alpha[c], 1e-3) << what << ", α" << c;
        EXPECT_NEAR(got.pose.angles.yaw, expected.pose.angles.yaw, 1e-3) << what;
    };
    std::vector<int> most, few;
    for (int i = 0; i < 68; ++i) (i % 9 == 4 ? few : most).push_back(i);
    FitOptions subset;
    subset.lambda = 0.1;  // data-dominated, so each point's weight shows in α
    subset.subset = most;  // 8 points removed: the cached blocks minus those points
    compare(subset, most, "small change");
    FitOptions masked;
    masked.lambda = 0.1;
    masked.weights = Eigen::VectorXd::Zero(68);
    for (int i : few) masked.weights(i) = 1;  // 60 points removed: built from scratch
    compare(masked, few, "large change");
    FitOptions truncated = subset;
    truncated.shape_components = 4;  // the top-left block of the cached matrices
    compare(truncated, most, "first 4 components");
}

TEST(Fit, BadInputsThrowClearErrors) {
    const morph::MorphableModel m = testkit::make_toy_model({});
    const ScaledOrthographic camera{2.0, Eigen::Matrix3d::Identity(), {200, 220}, {}};
    const Eigen::Matrix2Xd lm = project_landmarks(m, camera, {});
    auto message = [&](const Eigen::Matrix2Xd& points, const FitOptions& o) -> std::string {
        try {
            (void)fit_landmarks(m, points, o);
        } catch (const core::Error& e) {
            return e.what();
        }
        return "no error";
    };
    EXPECT_NE(message(lm.leftCols(67), {}).find("expected 68"), std::string::npos);
    Eigen::Matrix2Xd nan = lm;
    nan(0, 40) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_NE(message(nan, {}).find("landmark 41"), std::string::npos);
    FitOptions three;
    three.subset = {30, 36, 45};
    EXPECT_NE(message(lm, three).find("at least 4"), std::string::npos);
    Eigen::Matrix2Xd collinear = lm;
    for (int i = 0; i < 68; ++i) collinear.col(i) << i, 2.0 * i;
    EXPECT_NE(message(collinear, {}).find("collinear"), std::string::npos);
}

}  // namespace
}  // namespace facesynth::fit

namespace facesynth::fit {
namespace {

TEST(AnnotatedYaw, IsNothingForPointsThatCannotBeFitted) {
    const morph::MorphableModel model = testkit::make_toy_model();
    const Fitter fitter(model);
    Eigen::Matrix2Xd points = Eigen::Matrix2Xd::Constant(2, 68, std::numeric_limits<double>::quiet_NaN());
    EXPECT_FALSE(annotated_yaw(fitter, points).has_value());
    points.setZero();  // every point in one place: degenerate
    EXPECT_FALSE(annotated_yaw(fitter, points).has_value());
}

}  // namespace
}  // namespace facesynth::fit
