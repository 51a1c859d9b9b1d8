#include "fit/refine.h"

#include "common/toy_model.h"
#include "morph/camera.h"
#include "core/random.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>

namespace facesynth::fit {
namespace {

Eigen::Matrix2Xd perspective_landmarks(const morph::MorphableModel& m, const morph::Intrinsics& k, const morph::CameraPose& pose,
                                       std::span<const float> alpha, std::span<const float> psi = {}) {
    const Eigen::Matrix3Xf shape = m.shape_instance(alpha, psi);
    return project(k, pose, m.landmark_positions(shape));
}

TEST(Refine, KnownFocalRecoversPoseUnderPerspective) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 10});
    const Fitter fitter(m);
    const morph::Intrinsics k = morph::intrinsics_from_fov(30, 512, 512);
    for (int trial = 0; trial < 5; ++trial) {
        core::Rng rng(31, static_cast<std::uint64_t>(trial));
        const std::vector<float> alpha = morph::sample_coefficients(rng, 10, 2.0);
        const morph::EulerAngles angles{rng.uniform(-60, 60), rng.uniform(-20, 20), rng.uniform(-20, 20)};
        const morph::CameraPose pose{morph::rotation_from_euler(angles), {rng.uniform(-20, 20), rng.uniform(-20, 20), 600}};
        const Eigen::Matrix2Xd lm = perspective_landmarks(m, k, pose, alpha);
        RefineOptions o;
        o.intrinsics = k;
        o.identity_prior = 1e-6;
        FitOptions fo;
        fo.fit_expression = false;
        const FitResult linear = fitter.fit(lm, fo);
        const RefineResult r = refine(fitter, lm, linear, fo, o);
        EXPECT_NEAR(r.angles.yaw, angles.yaw, 0.1) << "trial " << trial;
        EXPECT_NEAR(r.angles.pitch, angles.pitch, 0.1);
        EXPECT_NEAR(r.angles.roll, angles.roll, 0.1);
        EXPECT_LT(r.reprojection_rms_px, 0.05);
        EXPECT_LT(r.reprojection_rms_px, linear.reprojection_rms_px);
        EXPECT_NEAR(r.pose.translation.z(), 600, 15);
    }
}

TEST(Refine, EstimatesFocalAndKeepsBlendshapesNonNegative) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 6});
    const Fitter fitter(m);
    const morph::Intrinsics k = morph::intrinsics_from_fov(40, 640, 480);
    const std::vector<float> psi{0.7f, 0.0f};
    const morph::EulerAngles angles{25, -10, 5};
    const morph::CameraPose pose{morph::rotation_from_euler(angles), {5, 10, 500}};
    const Eigen::Matrix2Xd lm = perspective_landmarks(m, k, pose, {}, psi);
    RefineOptions o;
    o.intrinsics = k;
    o.intrinsics.fx = o.intrinsics.fy = 0;  // unknown focal, known image size
    const RefineResult r = fit_and_refine(fitter, lm, {}, o);
    EXPECT_NEAR(r.angles.yaw, angles.yaw, 1.0);
    EXPECT_NEAR(r.angles.pitch, angles.pitch, 1.0);
    EXPECT_NEAR(r.angles.roll, angles.roll, 1.0);
    EXPECT_LT(r.reprojection_rms_px, 0.5);
    ASSERT_EQ(r.psi.size(), 2u);
    EXPECT_GE(r.psi[1], 0.0f);
    EXPECT_NEAR(r.psi[0], 0.7, 0.15);
}

}  // namespace
}  // namespace facesynth::fit
