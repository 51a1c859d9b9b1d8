#include "fit/evaluate.h"

#include "common/toy_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace facesynth::fit {
namespace {

// The toy model's components move a vertex by ~0.2 mm per σ; scale them to the size of a real face
// model's (the Surrey model's first component: ~2-3 mm per σ) so identity is measurable.
morph::MorphableModel face_sized_toy(int components) {
    morph::MorphableModel m = testkit::make_toy_model({.shape_components = components});
    m.shape.eigenvalues *= 100.0f;
    return m;
}

TEST(Evaluate, RefinedFitOfExactPerspectiveLandmarksBeatsTheMeanShape) {
    const morph::MorphableModel m = face_sized_toy(10);
    const Fitter fitter(m);
    double fitted = 0, mean = 0;
    for (int i = 0; i < 10; ++i) {
        const SyntheticCase c = make_synthetic_case(m, 77, static_cast<std::uint64_t>(i));
        EvalOptions o;
        o.refine = true;
        o.refine_options.intrinsics = c.intrinsics;
        const FitMetrics metrics = evaluate_fit(fitter, c.landmarks, c.truth, o);
        EXPECT_LT(metrics.yaw_error_deg, 1.0) << "case " << i;
        EXPECT_LT(metrics.pitch_error_deg, 1.0) << "case " << i;
        EXPECT_LT(metrics.roll_error_deg, 1.0) << "case " << i;
        EXPECT_LT(metrics.reprojection_px, 1.0);
        EXPECT_GE(metrics.ms, 0.0);
        fitted += metrics.vertex_rmse_mm;
        mean += metrics.vertex_rmse_mm_meanshape;
    }
    EXPECT_LT(fitted, 0.7 * mean);
}

TEST(Evaluate, MetricsOfThePerfectAnswerAreZero) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 4});
    const Fitter fitter(m);
    const SyntheticCase c = make_synthetic_case(m, 5, 0);
    FitTruth truth = c.truth;
    truth.alpha.assign(4, 0.0f);
    EvalOptions o;
    o.fit.lambda = 1e9;  // pins α to the mean shape
    const FitMetrics metrics = evaluate_fit(fitter, c.landmarks, truth, o);
    EXPECT_NEAR(metrics.vertex_rmse_mm, 0.0, 1e-3);
    EXPECT_NEAR(metrics.vertex_rmse_mm_meanshape, 0.0, 1e-6);
    EXPECT_NEAR(metrics.alpha_rmse, 0.0, 1e-3);
}

TEST(Evaluate, LambdaScoresPunishOverRegularisation) {
    const morph::MorphableModel m = face_sized_toy(8);
    const Fitter fitter(m);
    SyntheticOptions s;
    s.noise_px = 2.0;
    const auto scores = score_lambdas(fitter, {0.1, 3.0, 1e4}, 8, 1234, s);
    ASSERT_EQ(scores.size(), 3u);
    for (const auto& sc : scores) EXPECT_TRUE(std::isfinite(sc.vertex_rmse_mm));
    EXPECT_GT(scores[2].vertex_rmse_mm, std::min(scores[0].vertex_rmse_mm, scores[1].vertex_rmse_mm));
}

}  // namespace
}  // namespace facesynth::fit
