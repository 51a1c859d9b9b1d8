#pragma once
// Float images as OpenEXR bytes (OpenImageIO, in memory), for depth maps.
#include <opencv2/core.hpp>

#include <string>

namespace facesynth::synth {

// CV_32FC1 -> single-channel float EXR ("Z"); throws core::Error prefixed with `context`.
[[nodiscard]] std::string encode_depth_exr(const cv::Mat& depth, const std::string& context);

}  // namespace facesynth::synth
