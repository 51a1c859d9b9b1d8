#include "synth/texture_mix.h"

#include "core/error.h"
#include "core/srgb.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace facesynth::synth {

void mix_coarse_colour(const cv::Mat& features, const cv::Mat& colour, double weight, cv::Mat& out) {
    if (features.type() != CV_8UC3 || colour.type() != CV_8UC3 || features.empty() || colour.empty())
        throw core::Error("texture mix: expected two non-empty 8-bit RGB textures");
    cv::Mat decode(1, 256, CV_32FC1);
    for (int v = 0; v < 256; ++v) decode.at<float>(v) = static_cast<float>(core::srgb_decode(v / 255.0));
    cv::Mat linear_features, linear_colour;
    cv::LUT(features, decode, linear_features);
    cv::LUT(colour, decode, linear_colour);
    const cv::Size coarse(std::max(1, features.cols / 16), std::max(1, features.rows / 16));
    cv::Mat coarse_features, coarse_colour;
    cv::resize(linear_features, coarse_features, coarse, 0, 0, cv::INTER_AREA);
    cv::resize(linear_colour, coarse_colour, coarse, 0, 0, cv::INTER_AREA);
    // A ratio of linear albedos, so that a dark feature (a brow on pale skin) keeps its contrast to the
    // skin around it instead of being pushed below black by a darker tone.
    constexpr float kFloor = 1e-3f;
    cv::Mat ratio;
    cv::divide(cv::max(coarse_colour, kFloor), cv::max(coarse_features, kFloor), ratio);
    cv::pow(ratio, weight, ratio);
    cv::Mat full_ratio;
    cv::resize(ratio, full_ratio, features.size(), 0, 0, cv::INTER_LINEAR);
    linear_features = linear_features.mul(full_ratio);
    // Back to 8-bit sRGB through a table of 4096 linear steps (finer than 8 bits in the darks).
    constexpr int kSteps = 4096;
    std::vector<std::uint8_t> encode(kSteps + 1);
    for (int i = 0; i <= kSteps; ++i)
        encode[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(std::lround(255.0 * core::srgb_encode(static_cast<double>(i) / kSteps)));
    out.create(features.size(), CV_8UC3);
    for (int y = 0; y < out.rows; ++y) {
        const float* in = linear_features.ptr<float>(y);
        std::uint8_t* o = out.ptr<std::uint8_t>(y);
        for (int x = 0; x < out.cols * 3; ++x) {
            const auto step = std::lround(std::clamp(in[x], 0.0f, 1.0f) * kSteps);
            o[x] = encode[static_cast<std::size_t>(step)];
        }
    }
}

}  // namespace facesynth::synth
