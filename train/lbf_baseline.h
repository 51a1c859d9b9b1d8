#pragma once
// OpenCV contrib's FacemarkLBF (Ren et al. 2014, local binary features) as a baseline, trained on the
// same canonical training crops as our cascade: its face detector is replaced by the canonical box,
// so training and test use exactly our box convention.
#include "train/sdm.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>

namespace facesynth::train {

struct LbfTrainOptions {
    int augment = 10;    // initial shapes per face (LBF initShape_n)
    int stages = 5;
    std::uint64_t seed = 1;
};

// Trains and writes the OpenCV LBF model file (YAML, written atomically).
void train_lbf(std::span<const TrainingFace> faces, const LbfTrainOptions& options, const std::filesystem::path& out);

class LbfPredictor {
public:
    // Throws facesynth::Error naming the file when it is missing or not an LBF model.
    explicit LbfPredictor(const std::filesystem::path& path);
    ~LbfPredictor();
    LbfPredictor(LbfPredictor&&) noexcept;
    LbfPredictor& operator=(LbfPredictor&&) noexcept;
    // Landmarks (canonical crop coordinates) of the face in a canonical crop.
    [[nodiscard]] Eigen::Matrix2Xd predict(const cv::Mat& crop) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace facesynth::train
