// Jaw points spaced as 300-W annotators space them (render::space_jaw_evenly): unevenly spaced points
// on a known outline come back on it, evenly spaced, with the ends, the chin and the other points
// kept (synth's `landmarks.mode = even`: tests/synth/test_landmark_modes.cpp).
#include "core/random.h"
#include "render/landmarks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace facesynth {
namespace {

// Arc lengths of the polyline through points first..last.
std::vector<double> steps(const Eigen::Matrix2Xd& p, int first, int last) {
    std::vector<double> out;
    for (int i = first; i < last; ++i) out.push_back((p.col(i + 1) - p.col(i)).norm());
    return out;
}

double spread(const std::vector<double>& v) {
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return *hi / *lo;
}

TEST(JawSpacing, UnevenPointsOnACircleComeBackEvenlySpacedOnIt) {
    // The jaw on a half circle of radius 100 around (200, 100): 1 at the left end, 9 at the bottom, 17 at
    // the right end, the points in between bunched toward the ends (steps along the arc up to twice as long near
    // the chin as near the ends, more uneven than the model's jaw points).
    constexpr double kRadius = 100;
    const Eigen::Vector2d centre(200, 100);
    Eigen::Matrix2Xd pixels(2, 68);
    Eigen::Matrix3Xd model_points(3, 68);
    std::vector<std::uint8_t> visible(68, 1);
    core::Rng rng(7, 0);
    for (int i = 0; i < 68; ++i) {
        pixels.col(i) = Eigen::Vector2d(rng.uniform(0, 400), rng.uniform(0, 400));
        model_points.col(i) = Eigen::Vector3d(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(0, 50));
    }
    for (int i = 0; i < 17; ++i) {
        const double s = (i - 8) / 8.0;  // -1 .. 1
        const double bunched = (s < 0 ? -1 : 1) * std::pow(std::abs(s), 0.75);
        const double angle = std::numbers::pi / 2 * (1 - bunched);  // pi .. 0, the chin at pi / 2
        pixels.col(i) = centre + kRadius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
        model_points.col(i) = Eigen::Vector3d(pixels(0, i), pixels(1, i), 10.0 * i);
    }
    visible[6] = 0;  // between 6 and 7 the respaced point near 7 takes its visibility
    ASSERT_GT(spread(steps(pixels, 0, 8)), 1.8);

    const render::RespacedJaw even = render::space_jaw_evenly(pixels, model_points, visible);
    for (int i = 0; i < 17; ++i) EXPECT_NEAR((even.pixels.col(i) - centre).norm(), kRadius, 0.5) << "point " << i + 1;
    EXPECT_LT(spread(steps(even.pixels, 0, 8)), 1.02);
    EXPECT_LT(spread(steps(even.pixels, 8, 16)), 1.02);
    for (int i : {0, 8, 16}) {
        EXPECT_EQ(even.pixels.col(i), pixels.col(i)) << "point " << i + 1;
        EXPECT_EQ(even.model_points.col(i), model_points.col(i)) << "point " << i + 1;
    }
    EXPECT_EQ(even.pixels.rightCols(51), pixels.rightCols(51));
    EXPECT_EQ(even.model_points.rightCols(51), model_points.rightCols(51));
    // The 3D points follow the same curve: here x and y are the pixels, z grows along it.
    for (int i = 1; i < 16; ++i) {
        EXPECT_NEAR(even.model_points(0, i), even.pixels(0, i), 1e-9);
        EXPECT_GT(even.model_points(2, i + 1), even.model_points(2, i)) << "point " << i + 1;
    }
    // Visibility: each moved point takes that of the nearer original point.
    ASSERT_EQ(even.visible.size(), 68u);
    int hidden = 0;
    for (int i = 0; i < 17; ++i) hidden += even.visible[static_cast<std::size_t>(i)] == 0;
    EXPECT_LE(hidden, 2);
}

TEST(JawSpacing, HalvesWithoutFinitePointsOrLengthStayAsTheyAre) {
    Eigen::Matrix2Xd pixels = Eigen::Matrix2Xd::Zero(2, 68);
    for (int i = 0; i < 17; ++i) pixels.col(i) = Eigen::Vector2d(10.0 * i * i, 5.0 * i);
    pixels(0, 3) = std::numeric_limits<double>::quiet_NaN();
    const std::vector<std::uint8_t> visible(68, 1);
    const render::RespacedJaw even = render::space_jaw_evenly(pixels, Eigen::Matrix3Xd(), visible);
    for (int i = 0; i < 9; ++i)  // the half with the NaN
        EXPECT_TRUE(i == 3 ? std::isnan(even.pixels(0, i)) : even.pixels.col(i) == pixels.col(i)) << "point " << i + 1;
    EXPECT_NE(even.pixels.col(12), pixels.col(12));  // the other half is respaced
    EXPECT_EQ(even.model_points.cols(), 0);

    const Eigen::Matrix2Xd still = Eigen::Matrix2Xd::Constant(2, 68, 3.0);  // no length at all
    EXPECT_EQ(render::space_jaw_evenly(still, Eigen::Matrix3Xd(), visible).pixels, still);
    const Eigen::Matrix2Xd few = Eigen::Matrix2Xd::Random(2, 17);  // not a 68-point set
    EXPECT_EQ(render::space_jaw_evenly(few, Eigen::Matrix3Xd(), {}).pixels, few);
}

}  // namespace
}  // namespace facesynth
