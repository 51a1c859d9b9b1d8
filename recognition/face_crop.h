#pragma once
// The `org` representation of the recognition experiment: the face cut out of the image by a
// similarity transform that puts the eye centres (means of iBUG points 37-42 and 43-48, 1-based)
// at fixed places, as face recognisers have long aligned faces.
#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace facesynth::recognition {

struct CropOptions {
    int size = 96;             // square crop, px
    double eye_height = 0.36;  // eye centres' row, as a share of the size
    double eye_span = 0.40;    // distance between the eye centres, as a share of the size
};

// 8-bit grey crop; `landmarks` are 68 iBUG points in 0-based pixels. Throws core::Error when the
// eye centres coincide or are not finite.
[[nodiscard]] cv::Mat eye_aligned_crop(const cv::Mat& image, const Eigen::Matrix2Xd& landmarks, const CropOptions& options = {});

// The `LM` representation: a frontal rendering (fixed framing, frontal/frontalise.h) in the same
// form as the crops: 8-bit grey, options.size square.
[[nodiscard]] cv::Mat frontal_crop(const cv::Mat& frontal, const CropOptions& options = {});

}  // namespace facesynth::recognition
