#pragma once
// Landmark evaluation on labelled images: the face detector runs once per image (timed on its own),
// the detection matching the ground truth (train/face_box.h) is given to every regressor (timed per
// face, crop included), and misses count as failures with NME = +inf.
#include "train/dataset.h"
#include "train/metrics.h"
#include "train/regressor.h"

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace facesynth::train {

struct FaceEvaluation {
    std::string key;
    bool detected = false;
    FaceView view = FaceView::kFrontal;  // the view that found it (when detected)
    std::vector<double> nme;        // per regressor; +inf when the detector missed
    std::optional<double> yaw_deg;  // from DIR/meta/<key>.json where present
};

struct RegressorEvaluation {
    std::string label;
    NmeSummary summary;
    double ms_per_face = 0;         // regressor only, faces the detector found
    std::vector<double> nmes;       // per face, in image order
};

struct Evaluation {
    std::vector<FaceEvaluation> faces;
    std::vector<RegressorEvaluation> regressors;
    DetectorKind detector = DetectorKind::kFrontal;
    int detector_misses = 0;
    double detector_ms_per_image = 0;
    std::vector<std::string> warnings;  // unreadable images or .pts files (counted as misses)
};

[[nodiscard]] Evaluation evaluate_landmarks(const std::vector<LabelledImage>& images,
                                            std::span<const LandmarkRegressor* const> regressors,
                                            DetectorKind detector, const std::function<void()>& on_image = {});

// |yaw| bins used in reports: [0,15), [15,30), [30,45), [45,60), [60,90].
[[nodiscard]] std::vector<std::pair<int, int>> yaw_bins();

}  // namespace facesynth::train
