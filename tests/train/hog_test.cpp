#include "train/hog.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace facesynth::train {
namespace {

// One 8-pixel cell (10x10 patch with the gradient ring): left half 0, right half 255. The central
// differences are 255 at x = 4 and x = 5 of every interior row: 16 pixels of magnitude 255, all in
// signed bin 0 (+x). One cell: every block energy is 4·4080², factor 1 / (2·4080), normalised value
// 0.5 -> clamped to 0.2; each of the 4 blocks adds 0.5·0.2 (orientation) or 0.2357·0.2 (texture).
TEST(Hog, VerticalEdgeHandComputed) {
    cv::Mat patch(10, 10, CV_8UC1, cv::Scalar(0));
    patch.colRange(5, 10).setTo(255);
    std::vector<float> f(HogLayout{.cells = 1}.dims());
    compute_hog(patch, {.cells = 1}, 8, f);
    for (int k = 0; k < 8; ++k) EXPECT_NEAR(f[k], k == 0 ? 0.4f : 0.f, 1e-6) << "signed bin " << k;
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(f[8 + k], k == 0 ? 0.4f : 0.f, 1e-6) << "unsigned bin " << k;
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(f[12 + k], 0.2357f * 0.2f, 1e-6) << "texture " << k;
}

TEST(Hog, EdgeDirectionsPickTheirBins) {
    cv::Mat dark_top(10, 10, CV_8UC1, cv::Scalar(0));
    dark_top.rowRange(5, 10).setTo(200);  // gradient +y: signed bin 2 (90°)
    std::vector<float> f(HogLayout{.cells = 1}.dims());
    compute_hog(dark_top, {.cells = 1}, 8, f);
    EXPECT_GT(f[2], 0.3f);
    for (int k : {0, 1, 3, 4, 5, 6, 7}) EXPECT_EQ(f[k], 0.f) << k;
    EXPECT_GT(f[8 + 2], 0.3f);

    cv::Mat bright_left(10, 10, CV_8UC1, cv::Scalar(0));
    bright_left.colRange(0, 5).setTo(200);  // gradient -x: signed bin 4 (180°), unsigned bin 0
    compute_hog(bright_left, {.cells = 1}, 8, f);
    EXPECT_GT(f[4], 0.3f);
    EXPECT_EQ(f[0], 0.f);
    EXPECT_GT(f[8 + 0], 0.3f);
}

TEST(Hog, FlatPatchIsZeroAndCellsAreRowMajor) {
    cv::Mat flat(10, 10, CV_8UC1, cv::Scalar(77));
    std::vector<float> f(HogLayout{.cells = 1}.dims());
    compute_hog(flat, {.cells = 1}, 8, f);
    for (float v : f) EXPECT_EQ(v, 0.f);

    // 2x2 cells of 4 px: an edge only in the bottom-right cell (pixels (7..9, 6..9): every gradient falls in interior rows 5..8, columns 6..7).
    cv::Mat patch(10, 10, CV_8UC1, cv::Scalar(0));
    patch(cv::Rect(7, 6, 3, 4)).setTo(255);
    std::vector<float> g(HogLayout{.cells = 2}.dims());
    compute_hog(patch, {.cells = 2}, 4, g);
    for (int cell = 0; cell < 3; ++cell)
        for (int k = 0; k < 16; ++k) EXPECT_EQ(g[cell * 16 + k], 0.f) << "cell " << cell << " dim " << k;
    EXPECT_GT(g[3 * 16 + 0], 0.f);
}

TEST(Hog, RejectsWrongPatchSize) {
    cv::Mat patch(9, 9, CV_8UC1, cv::Scalar(0));
    std::vector<float> f(HogLayout{.cells = 1}.dims());
    EXPECT_THROW(compute_hog(patch, {.cells = 1}, 8, f), std::exception);
}

// Nine orientations (VLFeat's default, 31 values per cell): signed bins every 20°. A linear ramp
// rising along direction a (slope 10 grey levels per pixel, so rounding to bytes turns the gradient
// by at most 4°) puts every vote in a's bin; read with 4 orientations it lands in the 45° bin
// nearest to a. (A step edge would not do: central differences of a step point only every 45°.)
TEST(Hog, NineOrientationsResolveDirectionsFourCannot) {
    const HogLayout nine{.cells = 1, .orientations = 9};
    ASSERT_EQ(nine.dims_per_cell(), 31);
    ASSERT_EQ(nine.dims(), 31);
    std::vector<float> f(static_cast<std::size_t>(nine.dims()));
    std::vector<float> four(HogLayout{.cells = 1}.dims());
    // Angles at least 7.5° from the 4-orientation sector borders (22.5° + k·45°).
    for (int gradient_deg : {0, 40, 80, 100, 180, 220, 260, 320}) {
        const double rad = gradient_deg * 3.14159265358979323846 / 180.0;
        cv::Mat patch(18, 18, CV_8UC1);
        for (int y = 0; y < 18; ++y)
            for (int x = 0; x < 18; ++x)
                patch.at<std::uint8_t>(y, x) =
                    cv::saturate_cast<std::uint8_t>(128 + 10 * ((x - 8.5) * std::cos(rad) + (y - 8.5) * std::sin(rad)));
        compute_hog(patch, nine, 16, f);
        const int expected = gradient_deg / 20;
        const auto largest = std::max_element(f.begin(), f.begin() + 18) - f.begin();
        EXPECT_EQ(largest, expected) << gradient_deg << "°";
        const auto unsigned_largest = std::max_element(f.begin() + 18, f.begin() + 27) - (f.begin() + 18);
        EXPECT_EQ(unsigned_largest, expected % 9) << gradient_deg << "°";
        compute_hog(patch, {.cells = 1}, 16, four);
        const auto largest_of_four = std::max_element(four.begin(), four.begin() + 8) - four.begin();
        EXPECT_EQ(largest_of_four, ((gradient_deg + 22) / 45) % 8) << gradient_deg << "° with 4 orientations";
    }
}

TEST(Hog, RejectsOrientationsOutOfRange) {
    cv::Mat patch(10, 10, CV_8UC1, cv::Scalar(0));
    std::vector<float> f(64);
    EXPECT_THROW(compute_hog(patch, {.cells = 1, .orientations = 0}, 8, f), std::exception);
    EXPECT_THROW(compute_hog(patch, {.cells = 1, .orientations = kMaxHogOrientations + 1}, 8, f), std::exception);
    std::vector<float> wrong_size(HogLayout{.cells = 1}.dims());
    EXPECT_THROW(compute_hog(patch, {.cells = 1, .orientations = 9}, 8, wrong_size), std::exception);
}

TEST(Hog, ExtractPatchSamplesAroundCentre) {
    cv::Mat image(100, 100, CV_8UC1, cv::Scalar(0));
    image.colRange(50, 100).setTo(255);
    cv::Mat patch;
    // Centre on the edge (between columns 49 and 50), 20 px side resampled to 10 + 2 px.
    extract_patch(image, Eigen::Vector2d(49.5, 50), 20, 1, 10, patch);
    ASSERT_EQ(patch.rows, 12);
    EXPECT_EQ(patch.at<std::uint8_t>(6, 0), 0);
    EXPECT_EQ(patch.at<std::uint8_t>(6, 11), 255);
}

}  // namespace
}  // namespace facesynth::train
