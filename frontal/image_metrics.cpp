#include "frontal/image_metrics.h"

#include "core/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace facesynth::frontal {

ImageComparison compare_images(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
    if (a.size() != b.size() || a.type() != b.type() || a.depth() != CV_8U)
        throw core::Error("image comparison: the images differ in size or type, or are not 8-bit");
    if (mask.size() != a.size() || mask.type() != CV_8UC1) throw core::Error("image comparison: the mask must be 8-bit, one channel, same size");
    ImageComparison out;
    out.pixels = cv::countNonZero(mask);
    if (out.pixels == 0) throw core::Error("image comparison: the mask is empty");
    const int channels = a.channels();

    cv::Mat fa, fb;
    a.convertTo(fa, CV_32F);
    b.convertTo(fb, CV_32F);
    cv::Mat difference = fa - fb;
    cv::Mat absolute = cv::abs(difference);
    cv::Mat squared = difference.mul(difference);
    const double n = static_cast<double>(out.pixels) * channels;
    const cv::Scalar abs_sum = cv::sum(absolute.setTo(0, mask == 0));
    const cv::Scalar sq_sum = cv::sum(squared.setTo(0, mask == 0));
    double l1 = 0, mse = 0;
    for (int c = 0; c < channels; ++c) {
        l1 += abs_sum[c];
        mse += sq_sum[c];
    }
    out.l1 = l1 / n;
    mse /= n;
    out.psnr_db = mse > 0 ? std::min(100.0, 10 * std::log10(255.0 * 255.0 / mse)) : 100.0;

    constexpr double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
    const cv::Size window(11, 11);
    constexpr double sigma = 1.5;
    std::vector<cv::Mat> pa, pb;
    cv::split(fa, pa);
    cv::split(fb, pb);
    double ssim_sum = 0;
    for (int c = 0; c < channels; ++c) {
        cv::Mat mu_a, mu_b, aa, bb, ab;
        cv::GaussianBlur(pa[static_cast<std::size_t>(c)], mu_a, window, sigma);
        cv::GaussianBlur(pb[static_cast<std::size_t>(c)], mu_b, window, sigma);
        cv::GaussianBlur(pa[static_cast<std::size_t>(c)].mul(pa[static_cast<std::size_t>(c)]), aa, window, sigma);
        cv::GaussianBlur(pb[static_cast<std::size_t>(c)].mul(pb[static_cast<std::size_t>(c)]), bb, window, sigma);
        cv::GaussianBlur(pa[static_cast<std::size_t>(c)].mul(pb[static_cast<std::size_t>(c)]), ab, window, sigma);
        const cv::Mat mu_aa = mu_a.mul(mu_a), mu_bb = mu_b.mul(mu_b), mu_ab = mu_a.mul(mu_b);
        const cv::Mat var_a = aa - mu_aa, var_b = bb - mu_bb, cov = ab - mu_ab;
        cv::Mat numerator = (2 * mu_ab + c1).mul(2 * cov + c2);
        cv::Mat denominator = (mu_aa + mu_bb + c1).mul(var_a + var_b + c2);
        cv::Mat ssim_map;
        cv::divide(numerator, denominator, ssim_map);
        ssim_sum += cv::mean(ssim_map, mask)[0];
    }
    out.ssim = ssim_sum / channels;
    return out;
}

}  // namespace facesynth::frontal
