#include "degrade/degrade.h"

#include "core/error.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace facesynth::degrade {

// The unsharp mask's radius: a camera's sharpening acts on edges a pixel or two wide.
constexpr double kSharpenSigma = 1.0;

// Gaussian noise of `sigma` 8-bit levels, rounded: the rounded offset's distribution depends on sigma
// alone, so each channel value draws it from a 16-bit inverse-CDF table (four draws per 64-bit random
// number) rather than by Box-Muller, which took a fifth of a sample's CPU. The table's resolution,
// 2^-16 in probability, loses only tails beyond about 4.3 sigma.
void add_sensor_noise(cv::Mat& image, double sigma, core::Rng& rng) {
    constexpr int kTableSize = 1 << 16;
    std::vector<std::int16_t> offset_of(kTableSize);
    const int widest = static_cast<int>(std::ceil(6 * sigma)) + 1;
    int filled = 0;
    for (int k = -widest; k <= widest && filled < kTableSize; ++k) {
        // P(round(sigma z) <= k) = Phi((k + 0.5) / sigma); entry j stands for probability (j + 0.5) / 2^16.
        const double below = 0.5 * std::erfc(-(k + 0.5) / (sigma * std::numbers::sqrt2));
        const int end = k == widest ? kTableSize : std::clamp(static_cast<int>(std::lround(below * kTableSize)), filled, kTableSize);
        std::fill(offset_of.begin() + filled, offset_of.begin() + end, static_cast<std::int16_t>(k));
        filled = end;
    }
    const int values_per_row = image.cols * image.channels();
    std::uint64_t bits = 0;
    int unused = 0;
    for (int y = 0; y < image.rows; ++y) {
        auto* row = image.ptr<uchar>(y);
        for (int x = 0; x < values_per_row; ++x) {
            if (unused == 0) bits = rng.next_u64(), unused = 4;
            const int offset = offset_of[bits & 0xffffu];
            bits >>= 16, --unused;
            row[x] = static_cast<uchar>(std::clamp(row[x] + offset, 0, 255));
        }
    }
}

void apply(cv::Mat& image, const DegradationSpec& d, core::Rng& noise) {
    if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
        throw core::Error("degrade: expected an 8-bit grey or RGB image, got " + std::to_string(image.channels()) + " channels of depth " +
                          std::to_string(image.depth()));
    const bool grey = image.channels() == 1;
    if (grey && (d.gains[1] != d.gains[0] || d.gains[2] != d.gains[0]))
        throw core::Error("degrade: a grey image takes one gain, got three different ones");
    if (d.downscale < 1) {
        cv::Mat small;
        const cv::Size size(std::max(1, static_cast<int>(image.cols * d.downscale)), std::max(1, static_cast<int>(image.rows * d.downscale)));
        cv::resize(image, small, size, 0, 0, cv::INTER_AREA);
        cv::resize(small, image, image.size(), 0, 0, cv::INTER_LINEAR);
    }
    if (d.blur_sigma > 0) cv::GaussianBlur(image, image, cv::Size(0, 0), d.blur_sigma, d.blur_sigma, cv::BORDER_REFLECT);
    if (d.sharpen_amount > 0) {
        cv::Mat blurred;
        cv::GaussianBlur(image, blurred, cv::Size(0, 0), kSharpenSigma, kSharpenSigma, cv::BORDER_REFLECT);
        cv::addWeighted(image, 1 + d.sharpen_amount, blurred, -d.sharpen_amount, 0, image);  // saturating
    }
    if (d.gamma != 1 || d.gains != Eigen::Vector3d::Ones()) {
        cv::Mat lut(1, 256, CV_8UC(image.channels()));
        for (int v = 0; v < 256; ++v) {
            const double curved = 255.0 * std::pow(v / 255.0, d.gamma);
            for (int c = 0; c < image.channels(); ++c) lut.ptr<uchar>(0)[v * image.channels() + c] = cv::saturate_cast<uchar>(curved * d.gains[c]);
        }
        cv::LUT(image, lut, image);
    }
    if (d.noise_sigma > 0) add_sensor_noise(image, d.noise_sigma, noise);
    if (d.greyscale && !grey) {
        cv::Mat luminance;
        cv::cvtColor(image, luminance, cv::COLOR_RGB2GRAY);
        cv::cvtColor(luminance, image, cv::COLOR_GRAY2RGB);
    }
    if (d.jpeg_quality > 0) {
        std::vector<uchar> bytes;
        if (grey) {
            cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, d.jpeg_quality});
            cv::imdecode(bytes, cv::IMREAD_GRAYSCALE).copyTo(image);
        } else {
            cv::Mat bgr;
            cv::cvtColor(image, bgr, cv::COLOR_RGB2BGR);
            cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, d.jpeg_quality});
            cv::cvtColor(cv::imdecode(bytes, cv::IMREAD_COLOR), image, cv::COLOR_BGR2RGB);
        }
    }
}

}  // namespace facesynth::degrade
