#include "fit/affine_camera.h"

#include "morph/camera.h"
#include "core/error.h"
#include "core/random.h"

#include <gtest/gtest.h>

#include <limits>

namespace facesynth::fit {
namespace {

Eigen::Matrix3Xd random_points(core::Rng& rng, int n) {
    Eigen::Matrix3Xd p(3, n);
    for (int i = 0; i < n; ++i) p.col(i) << rng.uniform(-80, 80), rng.uniform(-100, 100), rng.uniform(-60, 90);
    return p;
}

Eigen::Matrix2Xd project_all(const AffineCamera& c, const Eigen::Matrix3Xd& p) {
    Eigen::Matrix2Xd out(2, p.cols());
    for (Eigen::Index i = 0; i < p.cols(); ++i) out.col(i) = c.project(p.col(i));
    return out;
}

TEST(AffineCamera, GoldStandardRecoversAGeneralAffineCameraExactly) {
    for (int trial = 0; trial < 20; ++trial) {
        core::Rng rng(7, static_cast<std::uint64_t>(trial));
        AffineCamera truth;
        for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 4; ++c) truth.matrix(r, c) = c < 3 ? rng.uniform(-3, 3) : rng.uniform(0, 500);
        truth.matrix(2, 3) = 1;
        const Eigen::Matrix3Xd points = random_points(rng, 4 + trial);
        const AffineCamera fitted = estimate_affine_camera(project_all(truth, points), points);
        EXPECT_LT((fitted.matrix - truth.matrix).norm() / truth.matrix.norm(), 1e-6) << "trial " << trial;
    }
}

TEST(AffineCamera, WeightsIgnoreOutliersWithZeroWeight) {
    core::Rng rng(3, 0);
    const ScaledOrthographic truth{2.5, morph::rotation_from_euler({20, -10, 5}), {300, 200}, {}};
    const Eigen::Matrix3Xd points = random_points(rng, 12);
    Eigen::Matrix2Xd image = project_all(truth.to_affine(), points);
    image.col(3) += Eigen::Vector2d(50, -40);
    Eigen::VectorXd w = Eigen::VectorXd::Ones(12);
    w(3) = 0;
    const AffineCamera fitted = estimate_affine_camera(image, points, w);
    EXPECT_LT((fitted.matrix - truth.to_affine().matrix).norm() / truth.to_affine().matrix.norm(), 1e-6);
}

TEST(AffineCamera, DecompositionRoundTripsEulerAnglesScaleAndTranslation) {
    core::Rng rng(11, 0);
    for (int trial = 0; trial < 200; ++trial) {
        const morph::EulerAngles angles{rng.uniform(-85, 85), rng.uniform(-60, 60), rng.uniform(-60, 60)};
        const ScaledOrthographic truth{rng.uniform(0.5, 5), morph::rotation_from_euler(angles), {rng.uniform(0, 600), rng.uniform(0, 600)}, angles};
        const Eigen::Matrix3Xd points = random_points(rng, 10);
        const ScaledOrthographic got = decompose(estimate_affine_camera(project_all(truth.to_affine(), points), points));
        EXPECT_NEAR(got.angles.yaw, angles.yaw, 1e-6);
        EXPECT_NEAR(got.angles.pitch, angles.pitch, 1e-6);
        EXPECT_NEAR(got.angles.roll, angles.roll, 1e-6);
        EXPECT_NEAR(got.scale, truth.scale, 1e-8 * truth.scale);
        EXPECT_LT((got.translation - truth.translation).norm(), 1e-6);
        EXPECT_LT((got.rotation - truth.rotation).norm(), 1e-8);
    }
}

// The decomposed pose must mean what the renderer's ground truth means: project with the pinhole
// camera of morph/camera.h from far away (nearly orthographic) and compare the angles.
TEST(AffineCamera, AnglesAgreeWithThePerspectiveCameraConvention) {
    core::Rng rng(5, 0);
    const Eigen::Matrix3Xd points = random_points(rng, 30);
    const morph::Intrinsics k{20000, 20000, 256, 256, 512, 512};
    for (const morph::EulerAngles angles : {morph::EulerAngles{30, 0, 0}, morph::EulerAngles{0, 20, 0}, morph::EulerAngles{0, 0, 15}, morph::EulerAngles{-40, 15, -10}}) {
        morph::CameraPose pose{morph::rotation_from_euler(angles), {10, -5, 40000}};
        const Eigen::Matrix2Xd image = project(k, pose, points.cast<float>());
        const ScaledOrthographic got = decompose(estimate_affine_camera(image, points));
        EXPECT_NEAR(got.angles.yaw, angles.yaw, 0.2);
        EXPECT_NEAR(got.angles.pitch, angles.pitch, 0.2);
        EXPECT_NEAR(got.angles.roll, angles.roll, 0.2);
        EXPECT_NEAR(got.scale, 0.5, 0.01);
    }
}

TEST(AffineCamera, DegenerateInputsThrowClearErrors) {
    core::Rng rng(1, 0);
    const Eigen::Matrix3Xd points = random_points(rng, 6);
    const AffineCamera cam = ScaledOrthographic{2, Eigen::Matrix3d::Identity(), {100, 100}, {}}.to_affine();
    const Eigen::Matrix2Xd image = project_all(cam, points);
    EXPECT_THROW((void)estimate_affine_camera(image.leftCols(3), points.leftCols(3)), core::Error);
    EXPECT_THROW((void)estimate_affine_camera(image, points.leftCols(5)), core::Error);
    Eigen::Matrix2Xd with_nan = image;
    with_nan(1, 2) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW((void)estimate_affine_camera(with_nan, points), core::Error);
    Eigen::Matrix2Xd collinear(2, 6);
    for (int i = 0; i < 6; ++i) collinear.col(i) << 10.0 * i, 5.0 * i + 1;
    EXPECT_THROW((void)estimate_affine_camera(collinear, points), core::Error);
    Eigen::Matrix3Xd collinear3(3, 6);
    for (int i = 0; i < 6; ++i) collinear3.col(i) << 1.0 * i, 2.0 * i, -1.0 * i;
    EXPECT_THROW((void)estimate_affine_camera(image, collinear3), core::Error);
    try {
        (void)estimate_affine_camera(image.leftCols(3), points.leftCols(3));
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("at least 4"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace facesynth::fit
