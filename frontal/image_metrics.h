#pragma once
// Image similarity inside a mask, for comparing a frontalised face with the true frontal render
// (docs/conventions.md, Metrics). Images are 8-bit with the same size and channel count; the mask is 8-bit, non-zero
// where pixels count.
#include <opencv2/core.hpp>

namespace facesynth::frontal {

struct ImageComparison {
    double psnr_db = 0;  // 10·log10(255² / MSE) over the masked pixels and channels; capped at 100
    double ssim = 0;     // mean of the SSIM map (Wang et al. 2004: Gaussian window σ 1.5, 11 x 11,
                         // K1 0.01, K2 0.03, per channel then averaged) over the masked pixels
    double l1 = 0;       // mean absolute difference in 8-bit levels over the masked pixels and channels
    int pixels = 0;      // masked pixel count
};

// Throws core::Error on mismatched sizes or types, or an empty mask.
[[nodiscard]] ImageComparison compare_images(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask);

}  // namespace facesynth::frontal
