// The camera degradations (degrade/degrade.h): the sensor noise's statistics, its clamping and its
// dependence on its random stream only; the sharpening's overshoot; grey images.
#include "core/error.h"
#include "degrade/degrade.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>

namespace facesynth::degrade {
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

TEST(Degrade, DependsOnlyOnItsNoiseStream) {
    DegradationSpec spec;
    spec.noise_sigma = 4;
    spec.jpeg_quality = 70;
    spec.blur_sigma = 0.8;
    const cv::Mat source(96, 128, CV_8UC3, cv::Scalar(90, 140, 200));
    auto degraded = [&](std::uint64_t seed, std::uint64_t index) {
        cv::Mat image = source.clone();
        core::Rng noise(seed, index, 0);
        apply(image, spec, noise);
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
    core::Rng unused(1, 0, 0);
    apply(soft, blur_only, unused);
    cv::Mat sharp = soft.clone();
    DegradationSpec sharpen;
    sharpen.sharpen_amount = 1.5;
    apply(sharp, sharpen, unused);
    const auto grey = [](const cv::Mat& m, int x) { return static_cast<int>(m.at<cv::Vec3b>(16, x)[0]); };
    EXPECT_LT(grey(sharp, 30), grey(soft, 30));
    EXPECT_GT(grey(sharp, 33), grey(soft, 33));
    EXPECT_LT(grey(sharp, 30), 80);   // the overshoot
    EXPECT_GT(grey(sharp, 33), 160);
    EXPECT_GT(grey(sharp, 32) - grey(sharp, 31), grey(soft, 32) - grey(soft, 31));
    for (const int x : {0, 8, 56, 63}) EXPECT_EQ(grey(sharp, x), grey(soft, x)) << x;
}

// train's copies of its photographs are grey: gamma and one gain through the same table, JPEG as grey,
// the image stays one channel of its size; three different gains have no meaning there.
TEST(Degrade, GreyImagesTakeGammaOneGainAndJpeg) {
    cv::Mat ramp(32, 256, CV_8UC1);
    for (int x = 0; x < 256; ++x) ramp.col(x).setTo(x);
    DegradationSpec curve;
    curve.gamma = 2;
    curve.gains = Eigen::Vector3d::Constant(0.5);
    cv::Mat curved = ramp.clone();
    core::Rng noise(3, 0, 0);
    apply(curved, curve, noise);
    ASSERT_EQ(curved.type(), CV_8UC1);
    for (const int x : {0, 64, 128, 200, 255})
        EXPECT_EQ(curved.at<uchar>(5, x), cv::saturate_cast<uchar>(0.5 * 255.0 * std::pow(x / 255.0, 2))) << x;

    DegradationSpec jpeg;
    jpeg.jpeg_quality = 30;
    jpeg.noise_sigma = 3;
    jpeg.greyscale = true;
    cv::Mat compressed = ramp.clone();
    apply(compressed, jpeg, noise);
    EXPECT_EQ(compressed.type(), CV_8UC1);
    EXPECT_EQ(compressed.size(), ramp.size());
    EXPECT_GT(cv::norm(compressed, ramp, cv::NORM_INF), 0);
    EXPECT_LT(cv::norm(compressed, ramp, cv::NORM_L1) / static_cast<double>(ramp.total()), 6.0);

    DegradationSpec tinted;
    tinted.gains = Eigen::Vector3d(1.0, 1.1, 0.9);
    cv::Mat grey = ramp.clone();
    EXPECT_THROW(apply(grey, tinted, noise), core::Error);
    cv::Mat wide(4, 4, CV_16UC1, cv::Scalar(0));
    EXPECT_THROW(apply(wide, jpeg, noise), core::Error);
}

}  // namespace
}  // namespace facesynth::degrade
