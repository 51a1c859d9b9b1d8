#pragma once
// The landmark regressors behind one interface, chosen by a spec string:
//   PATH          our SDM cascade (train/model_file.h), or an ensemble of them (`train merge`): the
//                 members' landmarks averaged; every SDM spec below applies to each member
//   dlib          dlib's pretrained 68-point predictor from libdlib-data, run on the image and box
//   dlib:PATH     any dlib shape predictor file, run the same way
//   ert:PATH      a dlib ERT model from `facesynth train --method ert` (runs on our canonical crop)
//   mean:PATH     the SDM model's mean shape placed in the box, no stages (initialisation baseline)
//   sdm@K:PATH    the SDM cascade cut after its first K stages (per-stage diagnosis)
//   mirror:PATH   the SDM cascade run on the face and on its mirror image, averaged (frontal-view
//                 boxes where the model has a profile cascade; twice the cost)
//   realign:PATH  the SDM cascade run twice, the second time on the crop resampled so that the first
//                 result sits on the start shape, the two averaged (twice the cost; train/sdm.h
//                 SdmInference). mirror: and realign: combine in either order (four times the cost).
//   lbf:PATH      an OpenCV LBF model from `facesynth train --method lbf` (runs on our canonical crop)
#include "train/face_box.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <memory>
#include <optional>
#include <span>
#include <string>

namespace facesynth::train {

class LandmarkRegressor {
public:
    virtual ~LandmarkRegressor() = default;
    // Landmarks (0-based image pixels) of the face in `box` of an 8-bit grey image.
    [[nodiscard]] virtual Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const = 0;
    [[nodiscard]] const std::string& label() const { return label_; }
    // The face detector the regressor was trained with, where its model file records one (SDM).
    [[nodiscard]] virtual std::optional<DetectorKind> trained_detector() const { return std::nullopt; }

protected:
    explicit LandmarkRegressor(std::string label) : label_(std::move(label)) {}

private:
    std::string label_;
};

// Throws core::Error naming the file for unreadable models.
[[nodiscard]] std::unique_ptr<LandmarkRegressor> open_regressor(const std::string& spec);

// The commands' --detector option: a detector_name, or "auto": the detector recorded in the
// first regressor that records one (SDM models; version 1-2 files say frontal), else multi-view.
[[nodiscard]] DetectorKind choose_detector(const std::string& option, std::span<const LandmarkRegressor* const> regressors);

}  // namespace facesynth::train
