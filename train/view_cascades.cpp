#include "train/view_cascades.h"

#include "core/error.h"

#include <cmath>
#include <string>
#include <vector>

namespace facesynth::train {

namespace {

// With `copy_faces` false only the counts are filled.
ViewFaceSets split_faces(std::span<const TrainingFace> faces, const ViewSplit& split, bool copy_faces) {
    ViewFaceSets out;
    ViewCascadeCounts& c = out.counts;
    // Nose-left orientation of a profile-cascade face: nose-right faces are mirrored; a frontal-view face
    // in the overlap band by where its nose points (the sign of its true yaw).
    const auto add_profile = [&](const TrainingFace& face, bool nose_right) {
        ++c.profile_faces;
        c.profile_mirrored += nose_right ? 1 : 0;
        if (!copy_faces) return;
        out.profile.push_back(nose_right ? mirror_training_face(face) : face);
        out.profile.back().view = FaceView::kNoseLeft;
    };
    const auto add_frontal = [&](const TrainingFace& face) {
        ++c.frontal_faces;
        if (!copy_faces) return;
        out.frontal.push_back(face);
        out.frontal.back().view = FaceView::kFrontal;
    };
    for (const auto& face : faces) {
        const double abs_yaw = face.yaw_deg ? std::abs(*face.yaw_deg) : std::nan("");
        if (face.view == FaceView::kFrontal) {
            add_frontal(face);
            if (abs_yaw >= split.profile_min_yaw_deg) {
                // Negative yaw turns the nose to the image's left (the nose-left view's side).
                add_profile(face, *face.yaw_deg > 0);
                ++c.profile_from_frontal;
            }
        } else {
            add_profile(face, face.view == FaceView::kNoseRight);
            if (abs_yaw <= split.frontal_max_yaw_deg) {
                add_frontal(face);
                ++c.frontal_from_profile;
            }
        }
    }
    return out;
}

using StageObserver = std::function<void(const char* cascade, const SdmStageReport&)>;

// `train(options)` for one view's cascade: `options` with its mirroring and its stage reports named
// `name`, and errors that name the cascade.
template <typename Train>
auto train_view_cascade(const char* name, const std::vector<TrainingFace>& set, SdmTrainOptions options, bool mirror,
                        const StageObserver& on_stage, const Train& train) {
    options.mirror = mirror;
    if (on_stage) options.on_stage = [&on_stage, name](const SdmStageReport& r) { on_stage(name, r); };
    try {
        return train(options);
    } catch (const core::Error& e) {
        throw core::Error(std::string("view-specific cascades: the ") + name + " cascade (" + std::to_string(set.size()) +
                          " faces): " + e.what());
    }
}

}  // namespace

ViewCascadeCounts count_view_split(std::span<const TrainingFace> faces, const ViewSplit& split) {
    return split_faces(faces, split, false).counts;
}

ViewFaceSets split_view_faces(std::span<const TrainingFace> faces, const ViewSplit& split) {
    return split_faces(faces, split, true);
}

SdmModel train_view_cascades(std::span<const TrainingFace> faces, const BoxStatistics& boxes, const SdmTrainOptions& options,
                             const ViewSplit& split, ViewCascadeCounts* counts,
                             const std::function<void(const char* cascade, const SdmStageReport&)>& on_stage) {
    const ViewFaceSets sets = split_view_faces(faces, split);
    const ViewCascadeCounts& c = sets.counts;
    if (counts) *counts = c;

    const auto train_one = [&](const char* name, const std::vector<TrainingFace>& set, bool mirror, double fixed_unit_length = 0) {
        SdmTrainOptions o = options;
        if (fixed_unit_length > 0) o.fixed_unit_length = fixed_unit_length;
        return train_view_cascade(name, set, o, mirror, on_stage,
                                  [&](const SdmTrainOptions& view_options) { return train_sdm(set, boxes, view_options); });
    };
    SdmModel model = train_one("frontal", sets.frontal, options.mirror);
    // Both cascades measure shapes in the same unit (with a fixed one, the frontal faces').
    // The profile cascade learns nose-left faces only (a mirror image would be nose-right): never mirrored.
    const SdmModel profile_model = train_one("profile", sets.profile, false, model.unit.fixed_length);

    ProfileCascade cascade;
    cascade.mean_shape = profile_model.mean_shape;
    cascade.stages = profile_model.stages;
    cascade.faces = c.profile_faces;
    cascade.init_translation_std = profile_model.boxes.init_translation_std;
    cascade.init_scale_std = profile_model.boxes.init_scale_std;
    cascade.init_rotation_std_deg = profile_model.boxes.init_rotation_std_deg;
    model.view_mean_shapes[static_cast<std::size_t>(FaceView::kFrontal)] = model.mean_shape;
    model.view_mean_shapes[static_cast<std::size_t>(FaceView::kNoseLeft)] = cascade.mean_shape;
    model.view_mean_shapes[static_cast<std::size_t>(FaceView::kNoseRight)] = mirror_canonical_shape(cascade.mean_shape);
    model.profile = std::move(cascade);
    // Training faces per view as the detector (or the fallback) assigned them, before any mirroring.
    model.view_faces = {};
    for (const auto& face : faces) ++model.view_faces[static_cast<std::size_t>(face.view)];
    model.training_faces = static_cast<std::uint32_t>(faces.size());
    return model;
}

ViewRealignResiduals train_realigned_view_cascades(std::span<const TrainingFace> faces, const SdmTrainOptions& options,
                                                   const ViewSplit& split, SdmModel& model,
                                                   const std::function<void(const char* cascade, const SdmStageReport&)>& on_stage) {
    if (!model.profile) throw core::Error("realigned view cascades: the model has no profile cascade");
    const ViewFaceSets sets = split_view_faces(faces, split);
    const auto train_one = [&](const char* name, const std::vector<TrainingFace>& set, bool mirror, SdmModel& cascade) {
        return train_view_cascade(name, set, options, mirror, on_stage,
                                  [&](const SdmTrainOptions& view_options) { return train_realigned_cascade(set, view_options, cascade); });
    };
    ViewRealignResiduals residuals;
    residuals.frontal = train_one("frontal_realigned", sets.frontal, options.mirror, model);
    // The profile cascade as the model train_view_cascades made it from (its faces are all nose-left).
    ProfileCascade& profile = *model.profile;
    SdmModel profile_model;
    profile_model.hog = model.hog;
    profile_model.unit = model.unit;
    profile_model.mean_shape = profile.mean_shape;
    profile_model.stages = profile.stages;
    profile_model.boxes.init_translation_std = profile.init_translation_std;
    profile_model.boxes.init_scale_std = profile.init_scale_std;
    profile_model.boxes.init_rotation_std_deg = profile.init_rotation_std_deg;
    residuals.profile = train_one("profile_realigned", sets.profile, false, profile_model);
    profile.realigned_stages = std::move(profile_model.realigned_stages);
    return residuals;
}

}  // namespace facesynth::train
