// The camera degradations (synth/degrade.h): the sensor noise's statistics, its clamping and its
// dependence on (seed, index) only; the sharpening's overshoot.
#include "synth/degrade.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>

namespace facesynth::synth {
namespace {

TEST(SensorNoise, HasTheRequestedMeanAndSpreadOnAFlatImage) {
    for (const double sigma : {1.0, 3.5, 8.0}) {
        cv::Mat image(256, 256, CV_8UC3, cv::Scalar::all(128));
        core::Rng rng(7, 3, 0);
        add_sensor_noise(image, sigma, rng);
        cv::Scalar mean, stddev;
        cv::meanStdDev(image.reshape(1), mean, stddev);
        // Rounding to whole levels adds a variance of 1/12.
        const double expected = std::sqrt(sigma * sigma + 1.0 / 12.0);
        EXPECT_NEAR(mean[0], 128.0, 0.05) << "sigma " << sigma;
        EXPECT_NEAR(stddev[0], expected, 0.02 * expected) << "sigma " << sigma;
        // The tails: a rounded offset of at least k levels is a Gaussian value beyond k - 0.5.
        const int k = static_cast<int>(2 * sigma) + 1;
        const double expected_share = std::erfc((k - 0.5) / (sigma * std::sqrt(2.0)));
        const cv::Mat beyond = cv::abs(image.reshape(1) - 128) >= k;
        const double share = cv::countNonZero(beyond) / static_cast<double>(image.total() * 3);
        EXPECT_NEAR(share, expected_share, 0.003) << "sigma " << sigma;
    }
}

TEST(SensorNoise, ClampsAtBlackAndWhite) {
    cv::Mat image(64, 64, CV_8UC3, cv::Scalar(0, 255, 1));
    core::Rng rng(1, 2, 3);
    add_sensor_noise(image, 8, rng);
    double low = 0, high = 0;
    cv::minMaxLoc(image.reshape(1), &low, &high);
    EXPECT_EQ(low, 0);
    EXPECT_EQ(high, 255);
    cv::Scalar mean = cv::mean(image);
    EXPECT_GT(mean[0], 2.0);    // black only rises
    EXPECT_LT(mean[1], 253.0);  // white only falls
}

TEST(Degrade, DependsOnlyOnSeedAndIndex) {
    DegradationSpec spec;
    spec.noise_sigma = 4;
    spec.jpeg_quality = 70;
    spec.blur_sigma = 0.8;
    const cv::Mat source(96, 128, CV_8UC3, cv::Scalar(90, 140, 200));
    auto degraded = [&](std::uint64_t seed, std::int64_t index) {
        cv::Mat image = source.clone();
        degrade(image, spec, seed, index);
        return image;
    };
    EXPECT_EQ(cv::norm(degraded(5, 11), degraded(5, 11), cv::NORM_INF), 0);
    EXPECT_GT(cv::norm(degraded(5, 11), degraded(5, 12), cv::NORM_INF), 0);
    EXPECT_GT(cv::norm(degraded(5, 11), degraded(6, 11), cv::NORM_INF), 0);
}

// The unsharp mask: a soft edge gets the overshoot a camera's sharpening gives it (darker on the dark
// side, brighter on the bright side, steeper between), flat areas away from it stay as they were.
TEST(Degrade, SharpeningOvershootsAnEdgeAndLeavesFlatAreas) {
    cv::Mat soft(32, 64, CV_8UC3);
    for (int x = 0; x < 64; ++x) soft.col(x).setTo(cv::Scalar::all(x < 32 ? 80 : 160));
    DegradationSpec blur_only;
    blur_only.blur_sigma = 1.0;
    degrade(soft, blur_only, 1, 0);
    cv::Mat sharp = soft.clone();
    DegradationSpec sharpen;
    sharpen.sharpen_amount = 1.5;
    degrade(sharp, sharpen, 1, 0);
    const auto grey = [](const cv::Mat& m, int x) { return static_cast<int>(m.at<cv::Vec3b>(16, x)[0]); };
    EXPECT_LT(grey(sharp, 30), grey(soft, 30));
    EXPECT_GT(grey(sharp, 33), grey(soft, 33));
    EXPECT_LT(grey(sharp, 30), 80);   // the overshoot
    EXPECT_GT(grey(sharp, 33), 160);
    EXPECT_GT(grey(sharp, 32) - grey(sharp, 31), grey(soft, 32) - grey(soft, 31));
    for (const int x : {0, 8, 56, 63}) EXPECT_EQ(grey(sharp, x), grey(soft, x)) << x;
}

}  // namespace
}  // namespace facesynth::synth
