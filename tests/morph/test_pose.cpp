#include "morph/pose.h"
#include "core/random.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

using namespace facesynth;

TEST(Pose, PositiveYawMovesNoseToImageRight) {
    const Eigen::Vector3d nose(0, 0, 100);
    const Eigen::Vector3d cam = morph::model_to_camera_flip() * morph::rotation_from_euler({30, 0, 0}) * nose;
    EXPECT_GT(cam.x(), 0.0);  // camera x = image right
}

TEST(Pose, PositivePitchLiftsNose) {
    const Eigen::Vector3d cam = morph::model_to_camera_flip() * morph::rotation_from_euler({0, 20, 0}) * Eigen::Vector3d(0, 0, 100);
    EXPECT_LT(cam.y(), 0.0);  // camera y points down, so up is negative
}

TEST(Pose, PositiveRollIsCounterClockwiseInImage) {
    // The subject's left eye is at model +x (viewer's right). Counter-clockwise in the image moves it up.
    const Eigen::Vector3d cam = morph::model_to_camera_flip() * morph::rotation_from_euler({0, 0, 15}) * Eigen::Vector3d(30, 0, 0);
    EXPECT_LT(cam.y(), 0.0);
}

TEST(Pose, FrontalFaceLooksAtCamera) {
    const Eigen::Vector3d cam = morph::model_to_camera_flip() * morph::rotation_from_euler({0, 0, 0}) * Eigen::Vector3d(0, 0, 100);
    EXPECT_LT(cam.z(), 0.0);  // nose is nearer the camera than the head centre
}

TEST(Pose, EulerRoundTrip) {
    core::Rng rng(7, 0);
    for (int i = 0; i < 1000; ++i) {
        const morph::EulerAngles a{rng.uniform(-179, 179), rng.uniform(-89, 89), rng.uniform(-179, 179)};
        const morph::EulerAngles b = morph::euler_from_rotation(morph::rotation_from_euler(a));
        EXPECT_NEAR(a.yaw, b.yaw, 1e-7);
        EXPECT_NEAR(a.pitch, b.pitch, 1e-7);
        EXPECT_NEAR(a.roll, b.roll, 1e-7);
    }
}

TEST(Pose, RotationIsOrthonormal) {
    const Eigen::Matrix3d r = morph::rotation_from_euler({33, -12, 7});
    EXPECT_LT((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
}
