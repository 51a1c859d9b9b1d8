#pragma once
// Differences between two renders of the same face in 8-bit levels, over the face pixels: for tests
// that compare a cheaper shading path with its per-pixel reference.
#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>

namespace facesynth::testkit {

struct ColourDifference {
    int max_level = 0;          // largest channel difference, 8-bit levels
    double level_sum = 0;       // sum of channel differences over face pixels
    long differing_pixels = 0;  // face pixels with any channel differing
    long over_two_levels = 0;   // face pixels with a channel more than 2 levels apart
    long face_pixels = 0;

    // Mean channel difference over the face pixels.
    [[nodiscard]] double mean_level() const { return level_sum / (3.0 * static_cast<double>(std::max(face_pixels, 1L))); }
    [[nodiscard]] double share_over_two_levels() const {
        return static_cast<double>(over_two_levels) / static_cast<double>(std::max(face_pixels, 1L));
    }

    // Adds the pixels where `mask` is non-zero of two CV_8UC3 images.
    void add(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
        for (int y = 0; y < mask.rows; ++y)
            for (int x = 0; x < mask.cols; ++x) {
                if (mask.at<std::uint8_t>(y, x) == 0) continue;
                ++face_pixels;
                const cv::Vec3b p = a.at<cv::Vec3b>(y, x), q = b.at<cv::Vec3b>(y, x);
                int largest = 0;
                for (int c = 0; c < 3; ++c) {
                    const int d = std::abs(int(p[c]) - int(q[c]));
                    largest = std::max(largest, d);
                    level_sum += d;
                }
                max_level = std::max(max_level, largest);
                if (largest > 0) ++differing_pixels;
                if (largest > 2) ++over_two_levels;
            }
    }
};

}  // namespace facesynth::testkit
