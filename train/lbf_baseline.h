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
#include <vector>

namespace facesynth::train {

// cv::face::FacemarkLBF::Params that set the training cost; defaults are OpenCV's. Training rows =
// 2 (OpenCV adds mirrored faces) x faces x augment; the forest costs about rows x stages x trees x
// (depth - 1) x features, the global regression (liblinear) about rows x trees x iterations.
struct LbfTrainOptions {
    int augment = 10;    // initial shapes per face (initShape_n)
    int stages = 5;      // stages_n
    int trees = 6;       // tree_n, per landmark
    int depth = 5;       // tree_depth: 2^(depth-1) leaves, depth-1 pixel tests per tree
    std::vector<int> features = {500, 500, 500, 300, 300, 300, 200, 200, 200, 100};        // feats_m, per stage
    std::vector<double> radii = {0.3, 0.2, 0.15, 0.12, 0.10, 0.10, 0.08, 0.06, 0.06, 0.05};  // radius_m, per stage
    std::uint64_t seed = 1;  // initial shapes; OpenCV seeds its trees from the clock, so models differ run to run
    bool verbose = false;    // OpenCV's own print-out: per-stage forest and regression times, liblinear iterations
};

// Throws core::Error when a count is out of range or a per-stage list is shorter than stages.
void check_lbf_options(const LbfTrainOptions& options);

struct LbfTrainReport {
    int faces_used = 0;
    // OpenCV silently drops faces whose landmarks do not fit its box test (extent over 1.5 box widths,
    // or the centre outside the box); they are counted here instead.
    int faces_outside_box = 0;
    double train_nme_initial = 0;  // mean shape in the canonical box, on the faces used
    double train_nme_final = 0;
};

// Trains and writes the OpenCV LBF model file (YAML, written atomically).
LbfTrainReport train_lbf(std::span<const TrainingFace> faces, const LbfTrainOptions& options,
                         const std::filesystem::path& out);

class LbfPredictor {
public:
    // Throws core::Error naming the file when it is missing or not an LBF model.
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
