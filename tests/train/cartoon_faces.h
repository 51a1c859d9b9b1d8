#pragma once
// Cartoon faces drawn with OpenCV from a jittered 68-point template, with exactly known landmarks:
// enough structure to test the mechanics of the regressors without any rendered or real data.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>

namespace facesynth::testkit {

struct CartoonFace {
    cv::Mat gray;                // 8-bit
    Eigen::Matrix2Xd landmarks;  // 0-based pixels, iBUG 68 order
};

// Face i of a reproducible family: random shape jitter, position, scale, rotation, noise.
[[nodiscard]] CartoonFace make_cartoon_face(std::uint64_t seed, std::uint64_t index, int image_size = 200);

}  // namespace facesynth::testkit
