#pragma once
// `facesynth train` as one library call: prepare the labelled faces (detector boxes, label
// adaptation), decide between one model and view-specific ones, train the SDM cascade or a
// baseline (dlib ERT, OpenCV LBF), write the model file, and report in flat keys.
#include "train/dataset.h"
#include "train/dlib_baseline.h"
#include "train/lbf_baseline.h"
#include "train/sdm.h"
#include "train/training_data.h"
#include "train/view_cascades.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace facesynth::train {

enum class TrainingMethod { kSdm, kErt, kLbf };
// auto: view-specific models when the detector has views and gives each view kMinViewCascadeFaces.
enum class CascadeChoice { kAuto, kSingle, kViews };

struct TrainingRequest {
    TrainingMethod method = TrainingMethod::kSdm;
    CascadeChoice cascades = CascadeChoice::kAuto;
    ViewSplit split;  // which faces train which view's model
    PrepareOptions prepare;  // detector, threads, seed, label adaptation, progress
    SdmTrainOptions sdm;     // with kSdm (its on_stage is set by train_regressor)
    ErtTrainOptions ert;     // with kErt
    LbfTrainOptions lbf;     // with kLbf
    std::filesystem::path out;
    // kSdm with sdm.realign_stages: keep this model's main cascades (and starts, and its choice of view
    // cascades) instead of training them, and train only the realigned ones. It must have been trained on
    // the same faces (its training checksum) with the same seed, augment, validation share, mirroring, image
    // copies and view split.
    std::filesystem::path base;
};

struct TrainingObserver {
    std::function<void(const std::string&)> on_message;  // one line for a person, no newline
    std::function<void(const std::string&)> on_warning;   // an image skipped, and why
    // SDM stage reports; `cascade` is "single", "frontal" or "profile", or one of them followed by
    // "_realigned" for the realigned cascades.
    std::function<void(const std::string& cascade, const SdmStageReport&)> on_stage;
};

// Throws core::Error (naming the file or option) on bad data or options; writes `request.out`
// atomically. Returns the report: method, faces, skipped_images, detector*, label_offsets,
// view_cascades, stageK_*, train_nme_initial/final and the method's own keys.
[[nodiscard]] nlohmann::json train_regressor(const std::vector<LabelledImage>& images, const TrainingRequest& request,
                                             const TrainingObserver& observer = {});

// The mean_x_NN / mean_y_NN keys of an `eval conventions --json` file as 2 x 68 face-frame offsets.
[[nodiscard]] Eigen::Matrix2Xd read_label_offsets(const std::filesystem::path& path);

}  // namespace facesynth::train
