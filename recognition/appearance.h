#pragma once
// A face's appearance as OpenCV's LBPH matcher sees it (the spatial histograms of local binary
// patterns of an eye-aligned crop, recognition/face_crop.h), kept as a descriptor so that one face can
// be compared with many without recomputing them: the tracker recognises a face that comes back after
// a scene cut this way (docs/track.md).
#include <opencv2/core.hpp>

namespace facesynth::recognition {

struct LbphSettings {
    int radius = 1;
    int neighbours = 8;
    int grid = 8;  // cells per side
};

// The LBPH histograms of an 8-bit grey image (one row, CV_32F). Throws core::Error on an empty image
// or one that is not 8-bit grey.
[[nodiscard]] cv::Mat lbph_descriptor(const cv::Mat& grey, const LbphSettings& settings = {});

// The distance LBPH's predict() uses between two descriptors of the same settings (chi-square,
// OpenCV's HISTCMP_CHISQR_ALT): 0 for equal ones, larger for less alike.
[[nodiscard]] double lbph_distance(const cv::Mat& a, const cv::Mat& b);

}  // namespace facesynth::recognition
