#pragma once
// View-specific cascades (docs/train.md, "View-specific cascades"): one SDM cascade for the faces the
// frontal detector view finds and one for the profile views, trained on nose-left faces and mirrored
// nose-right ones. Each training face belongs to the view of the detector box it got (what it will
// see at test time; faces the detector missed were given a view from their true landmarks when
// prepared, train/training_data.h). Optionally each cascade also trains on faces of the other view
// whose true yaw lies in an overlap band, for robustness to the detector choosing the wrong view.
#include "train/sdm.h"

#include <functional>
#include <span>
#include <vector>

namespace facesynth::train {

struct ViewSplit {
    // Faces of the profile views with true |yaw| at most this also train the frontal cascade, and
    // frontal-view faces with |yaw| at least `profile_min_yaw_deg` also train the profile cascade
    // (faces without a known yaw only train their own view's cascade). The defaults keep the views apart.
    double frontal_max_yaw_deg = 0;
    double profile_min_yaw_deg = 90;
};

struct ViewCascadeCounts {
    int frontal_faces = 0;            // faces training the frontal cascade (validation faces included)
    int profile_faces = 0;            // the same for the profile cascade
    int profile_mirrored = 0;         // of which mirrored (nose-right)
    int frontal_from_profile = 0;     // overlap: profile-view faces added to the frontal cascade
    int profile_from_frontal = 0;     // overlap: frontal-view faces added to the profile cascade
};

// Fewest faces per cascade for `train --cascades auto` to choose view-specific cascades.
inline constexpr int kMinViewCascadeFaces = 100;

// How `train_view_cascades` would divide the faces, without training.
[[nodiscard]] ViewCascadeCounts count_view_split(std::span<const TrainingFace> faces, const ViewSplit& split);

// The faces of each cascade, the profile ones in nose-left orientation (nose-right faces mirrored):
// what `train_view_cascades` trains on, for the baselines' view-specific models.
struct ViewFaceSets {
    std::vector<TrainingFace> frontal, profile;
    ViewCascadeCounts counts;
};
[[nodiscard]] ViewFaceSets split_view_faces(std::span<const TrainingFace> faces, const ViewSplit& split);

// Trains both cascades with `options` (the same stages, λ and rank candidates, validation share) into
// one model: `stages` is the frontal cascade, `profile` the profile one, and the view mean shapes are
// the two cascades' starts (nose-right: the mirrored profile mean). `on_stage` (optional) gets every
// stage report with the cascade's name ("frontal" or "profile"). Throws core::Error when either
// cascade gets too few faces to train, naming the view.
[[nodiscard]] SdmModel train_view_cascades(std::span<const TrainingFace> faces, const BoxStatistics& boxes,
                                           const SdmTrainOptions& options, const ViewSplit& split,
                                           ViewCascadeCounts* counts = nullptr,
                                           const std::function<void(const char* cascade, const SdmStageReport&)>& on_stage = {});

struct ViewRealignResiduals {
    RealignResidual frontal, profile;
};

// Trains the realigned cascades (train_realigned_cascade) of a model that train_view_cascades made from
// the same `faces`, `options` and `split`: one for its frontal cascade and one for its profile cascade.
// `on_stage` (optional) gets the stage reports as "frontal_realigned" and "profile_realigned".
ViewRealignResiduals train_realigned_view_cascades(std::span<const TrainingFace> faces, const SdmTrainOptions& options,
                                                   const ViewSplit& split, SdmModel& model,
                                                   const std::function<void(const char* cascade, const SdmStageReport&)>& on_stage = {});

}  // namespace facesynth::train
