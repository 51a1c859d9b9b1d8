#pragma once
// Float images as OpenEXR bytes (written in memory with the OpenEXR library), for depth maps.
#include <opencv2/core.hpp>

#include <string>

namespace facesynth::synth {

// CV_32FC1 -> single-channel float EXR ("Z", zip-compressed, no time stamp in the header, so the
// bytes depend on the pixels only); throws core::Error prefixed with `context`.
[[nodiscard]] std::string encode_depth_exr(const cv::Mat& depth, const std::string& context);

}  // namespace facesynth::synth
