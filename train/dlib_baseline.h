#pragma once
// dlib's ensemble-of-regression-trees shape predictor (Kazemi & Sullivan 2014) as a baseline: the
// pretrained 68-point model from Debian's libdlib-data (trained by dlib on real 300-W photographs), and
// dlib's trainer run on our own training faces. dlib's headers are confined to dlib_baseline.cpp.
#include "train/face_box.h"
#include "train/sdm.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>

namespace facesynth::train {

[[nodiscard]] std::filesystem::path default_dlib_predictor_path();

class DlibShapePredictor {
public:
    // Throws core::Error naming the file when it is missing or not a dlib shape predictor.
    explicit DlibShapePredictor(const std::filesystem::path& path);
    ~DlibShapePredictor();
    DlibShapePredictor(DlibShapePredictor&&) noexcept;
    DlibShapePredictor& operator=(DlibShapePredictor&&) noexcept;

    // Landmarks (0-based pixels) of the face in `box` of an 8-bit grey image.
    [[nodiscard]] Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const;
    [[nodiscard]] int num_parts() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

struct ErtTrainOptions {
    int threads = 1;
    int oversampling = 10;   // perturbed initialisations per face
    int cascade_depth = 10;
    int tree_depth = 4;
    int trees_per_level = 500;
    std::uint64_t seed = 1;
};

// Trains dlib's ERT on canonical training crops (box = the canonical face box, so the box convention
// matches ours exactly) and writes the model with dlib::serialize (atomically).
void train_dlib_ert(std::span<const TrainingFace> faces, const ErtTrainOptions& options,
                    const std::filesystem::path& out);

}  // namespace facesynth::train
