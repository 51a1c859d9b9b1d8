#pragma once
// The realism measure (docs/textures.md, "Realism"): a landmark predictor trained on real photographs
// (dlib's) run on near-frontal renders and on near-frontal photographs. A render that a real-trained
// predictor cannot read is not realistic yet: the ratio of its NMEs, the failure rates and the
// per-landmark bias (where the predictor puts each point against our label) say how far off it is.
#include "train/dataset.h"
#include "train/face_box.h"
#include "train/metrics.h"
#include "train/regressor.h"

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace facesynth::train {

struct RealismSide {
    int faces = 0;      // images evaluated
    int detected = 0;   // the detector found the labelled face
    NmeSummary nme;     // misses count as failures (NmeSummary's convention)
    std::vector<double> nmes;  // per image, +inf for a miss
    // Mean of (prediction - label) over the detected faces in the label's face frame, in inter-ocular
    // distances (morph/landmarks.h face_frame_offsets): 2 x 68.
    Eigen::Matrix2Xd bias;
    std::vector<std::string> warnings;  // unreadable images or .pts files (counted as misses)
};

// Runs `regressor` on the faces `detector` finds in `images` (the detection matching each label).
[[nodiscard]] RealismSide measure_realism(const std::vector<LabelledImage>& images, const LandmarkRegressor& regressor,
                                          DetectorKind detector, const std::function<void()>& on_image = {});

}  // namespace facesynth::train
