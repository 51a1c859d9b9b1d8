#include "synth/exposure.h"

#include "render/landmarks.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <vector>

namespace facesynth::synth {
namespace {

constexpr double kMostGain = 4.0;

// Grey levels (0-255, BT.601) of the metered pixels, read once: the gain search only rescales them.
std::vector<double> metered_greys(const cv::Mat& rgb, const cv::Mat& inside) {
    std::vector<double> greys;
    for (int y = 0; y < rgb.rows; ++y) {
        const auto* pixel = rgb.ptr<cv::Vec3b>(y);
        const auto* in = inside.ptr<std::uint8_t>(y);
        for (int x = 0; x < rgb.cols; ++x)
            if (in[x] != 0) greys.push_back(0.299 * pixel[x][0] + 0.587 * pixel[x][1] + 0.114 * pixel[x][2]);
    }
    return greys;
}

}  // namespace

double face_luminance(const cv::Mat& rgb, const cv::Mat& coverage, const Eigen::Matrix2Xd& landmarks) {
    const std::vector<double> greys = metered_greys(rgb, render::landmark_hull_mask(coverage, landmarks));
    if (greys.empty()) return std::numeric_limits<double>::quiet_NaN();
    double sum = 0;
    for (const double g : greys) sum += g;
    return sum / static_cast<double>(greys.size()) / 255.0;
}

double expose_face(cv::Mat& rgb, const cv::Mat& coverage, const Eigen::Matrix2Xd& landmarks, double target, double gamma) {
    const std::vector<double> greys = metered_greys(rgb, render::landmark_hull_mask(coverage, landmarks));
    if (greys.empty()) return 1.0;
    // A linear gain k multiplies the encoded values by k^(1/gamma). The grey of a clipped pixel is
    // approximated by clipping its grey, which is exact for white and close for pale skin.
    const double most = std::pow(kMostGain, 1.0 / gamma);
    const auto mean_after = [&](double encoded_gain) {
        double sum = 0;
        for (const double g : greys) sum += std::min(g * encoded_gain, 255.0);
        return sum / static_cast<double>(greys.size()) / 255.0;
    };
    // The mean is increasing in the gain: bisection on its logarithm within the allowed range.
    double low = 1.0 / most, high = most;
    if (mean_after(high) <= target) low = high;
    else if (mean_after(low) >= target) high = low;
    for (int step = 0; step < 30 && high / low > 1.0001; ++step) {
        const double middle = std::sqrt(low * high);
        (mean_after(middle) < target ? low : high) = middle;
    }
    const double encoded_gain = std::sqrt(low * high);
    // Each covered pixel's own colour (un-premultiplied) is scaled and clipped, then multiplied by its
    // coverage again, so that the silhouette's blended pixels keep their coverage.
    std::array<std::uint8_t, 256> covered_value{};
    for (int v = 0; v < 256; ++v) covered_value[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(std::lround(std::min(v * encoded_gain, 255.0)));
    for (int y = 0; y < rgb.rows; ++y) {
        auto* pixel = rgb.ptr<cv::Vec3b>(y);
        const auto* covered = coverage.ptr<std::uint8_t>(y);
        for (int x = 0; x < rgb.cols; ++x) {
            const int alpha = covered[x];
            if (alpha == 255) {
                for (int c = 0; c < 3; ++c) pixel[x][c] = covered_value[pixel[x][c]];
            } else if (alpha > 0) {
                for (int c = 0; c < 3; ++c) {
                    const double colour = std::min(pixel[x][c] * 255.0 / alpha * encoded_gain, 255.0);
                    pixel[x][c] = static_cast<std::uint8_t>(std::lround(colour * alpha / 255.0));
                }
            }
        }
    }
    return std::pow(encoded_gain, gamma);
}

}  // namespace facesynth::synth
