#pragma once
// Cartoon faces drawn with OpenCV from a jittered 68-point template, with exactly known landmarks:
// enough structure to test the mechanics of the regressors without any rendered or real data.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "train/sdm.h"

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace facesynth::testkit {

struct CartoonFace {
    cv::Mat gray;                // 8-bit
    Eigen::Matrix2Xd landmarks;  // 0-based pixels, iBUG 68 order
};

// Face i of a reproducible family: random shape jitter, position, scale, rotation, noise. A non-zero
// `yaw_deg` turns the face as if its points lay on a rounded head with a protruding nose (positive:
// the nose toward the image's right), so that the drawn face is asymmetric like a profile view.
[[nodiscard]] CartoonFace make_cartoon_face(std::uint64_t seed, std::uint64_t index, int image_size = 200,
                                            double yaw_deg = 0);

// Cartoon faces cut out around a box derived from their landmarks with a little jitter (the
// detector-miss path of real training), as canonical training faces. With a yaw, each face is turned
// by yaw ± 5° (recorded in yaw_deg) and gets the view of a multi-view detector: frontal below 20°,
// else nose-left (negative yaw) or nose-right.
[[nodiscard]] std::vector<train::TrainingFace> cartoon_training_faces(std::uint64_t seed, int count, double yaw_deg = 0);

// Frontal, nose-left (yaw -45°) and nose-right (+45°) cartoon faces interleaved, `per_view` of each,
// as a multi-view detector would label them.
[[nodiscard]] std::vector<train::TrainingFace> three_view_faces(std::uint64_t seed, int per_view);

[[nodiscard]] std::vector<train::TrainingFace> concatenate(std::initializer_list<std::vector<train::TrainingFace>> parts);

}  // namespace facesynth::testkit
