#include "train/training.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "train/model_file.h"
#include "train/view_baselines.h"

#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <optional>
#include <utility>

namespace facesynth::train {
namespace {

// printf-style formatting of one message line.
std::string line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string line(const char* format, ...) {
    std::va_list args;
    va_start(args, format);
    std::array<char, 1024> buffer{};
    std::vsnprintf(buffer.data(), buffer.size(), format, args);
    va_end(args);
    return buffer.data();
}

const char* method_name(TrainingMethod method) {
    switch (method) {
        case TrainingMethod::kSdm: return "sdm";
        case TrainingMethod::kErt: return "ert";
        case TrainingMethod::kLbf: return "lbf";
    }
    return "?";
}

// `base`: request.base's model, read before the faces were prepared.
void train_sdm_models(const PreparedFaces& prepared, const TrainingRequest& request, std::optional<SdmModel> base, bool views,
                      const TrainingObserver& observer, nlohmann::json& report) {
    SdmTrainOptions options = request.sdm;
    double first_nme = 0, last_nme = 0;
    // Stage reports; with view-specific cascades the profile cascade's keys are prefixed "profile_", and
    // the realigned cascades' "realign_" (after "profile_").
    const auto on_stage = [&](const std::string& cascade, const SdmStageReport& r) {
        const bool profile = cascade.starts_with("profile");
        const bool realigned = cascade.ends_with("_realigned");
        if (!profile && !realigned) {
            if (r.stage == 1) first_nme = r.nme_before;
            last_nme = r.nme_after;
        }
        if (observer.on_stage) observer.on_stage(cascade, r);
        const std::string prefix = std::string(profile ? "profile_" : "") + (realigned ? "realign_" : "");
        const std::string stage = prefix + "stage" + std::to_string(r.stage);
        if (!prefix.empty() && r.stage == 1) report[prefix + "train_nme_initial"] = r.nme_before;
        if (!prefix.empty()) report[prefix + "train_nme_final"] = r.nme_after;
        report[stage + "_nme"] = r.nme_after;
        report[stage + "_validation_nme"] = r.validation_nme_after;
        report[stage + "_lambda_factor"] = r.lambda_factor;
        report[stage + "_rank"] = r.rank;
        report[stage + "_feature_components"] = r.feature_components;
    };
    report["feature_pca"] = options.feature_components;
    report["mirror"] = options.mirror;
    report["image_copies"] = options.image_copies;
    report["augment"] = options.augment;
    report["stages"] = options.stages;
    report["hog_cells"] = options.hog.cells;
    report["hog_orientations"] = options.hog.orientations;
    const bool from_base = base.has_value();
    SdmModel model;
    if (from_base) {
        model = std::move(*base);
        if (model.training_checksum != prepared.checksum)
            throw core::file_error(request.base.string(), "was trained on other faces than --data's (training checksums differ)");
        if (model.boxes.detector != prepared.boxes.detector)
            throw core::file_error(request.base.string(), std::string("was trained with the ") + detector_name(model.boxes.detector) +
                                                              " detector, not " + detector_name(prepared.boxes.detector));
        if (model.augment != static_cast<std::uint32_t>(options.augment))
            throw core::file_error(request.base.string(), "was trained with --augment " + std::to_string(model.augment) + ", not " +
                                                              std::to_string(options.augment));
        report["stages"] = model.stages.size();
        report["view_cascades"] = model.profile.has_value();
        if (observer.on_message)
            observer.on_message(line("kept the main cascades of %s; training the realigned ones", request.base.string().c_str()));
    } else if (views) {
        ViewCascadeCounts counts;
        model = train_view_cascades(prepared.faces, prepared.boxes, options, request.split, &counts,
                                    [&](const char* cascade, const SdmStageReport& r) { on_stage(cascade, r); });
        report["view_cascade_frontal_faces"] = counts.frontal_faces;
        report["view_cascade_profile_faces"] = counts.profile_faces;
        report["view_cascade_profile_mirrored"] = counts.profile_mirrored;
        report["view_cascade_frontal_from_profile"] = counts.frontal_from_profile;
        report["view_cascade_profile_from_frontal"] = counts.profile_from_frontal;
        if (observer.on_message)
            observer.on_message(line("view-specific cascades: frontal %d faces (%d from the profile views), profile %d faces (%d "
                                     "mirrored nose-right, %d from the frontal view)",
                                     counts.frontal_faces, counts.frontal_from_profile, counts.profile_faces, counts.profile_mirrored,
                                     counts.profile_from_frontal));
    } else {
        options.on_stage = [&](const SdmStageReport& r) { on_stage("single", r); };
        model = train_sdm(prepared.faces, prepared.boxes, options);
    }
    if (options.realign_stages > 0) {
        const auto report_residual = [&](const std::string& prefix, const RealignResidual& residual) {
            report[prefix + "realign_residual_faces"] = residual.faces;
            report[prefix + "realign_residual_translation_std"] = residual.translation_std;
            report[prefix + "realign_residual_scale_std"] = residual.scale_std;
            report[prefix + "realign_residual_rotation_std_deg"] = residual.rotation_std_deg;
            if (observer.on_message)
                observer.on_message(line("%srealigned cascade: the main cascade's residual on %d faces: translation %.4f box widths, "
                                         "scale %.4f, rotation %.2f deg (training starts spread %g x that)",
                                         prefix.empty() ? "" : "profile ", residual.faces, residual.translation_std, residual.scale_std,
                                         residual.rotation_std_deg, options.realign_spread));
        };
        if (model.profile) {
            const ViewRealignResiduals residuals = train_realigned_view_cascades(
                prepared.faces, options, request.split, model, [&](const char* cascade, const SdmStageReport& r) { on_stage(cascade, r); });
            report_residual("", residuals.frontal);
            report_residual("profile_", residuals.profile);
        } else {
            options.on_stage = [&](const SdmStageReport& r) { on_stage("single_realigned", r); };
            report_residual("", train_realigned_cascade(prepared.faces, options, model));
        }
    }
    report["realign_stages"] = options.realign_stages;
    report["realign_spread"] = options.realign_spread;
    model.training_checksum = prepared.checksum;
    write_sdm_model(request.out, model);
    if (from_base) return;  // the main cascades were not trained here
    report["train_nme_initial"] = first_nme;
    report["train_nme_final"] = last_nme;
    if (observer.on_message)
        observer.on_message(line("training NME (inter-ocular, %d perturbed starts per face%s): %.4f -> %.4f", options.augment,
                                 views ? ", frontal cascade" : "", first_nme, last_nme));
}

// The baselines: one model for all views, or one per view bundled (train/view_baselines.h).
void train_baseline_models(const PreparedFaces& prepared, const TrainingRequest& request, bool views, const TrainingObserver& observer,
                           nlohmann::json& report) {
    const bool ert = request.method == TrainingMethod::kErt;
    const ErtTrainOptions& ert_options = request.ert;
    const LbfTrainOptions& lbf_options = request.lbf;
    if (observer.on_message) {
        if (ert)
            observer.on_message(line("training dlib ERT (cascade depth %d, oversampling %d)%s...", ert_options.cascade_depth,
                                     ert_options.oversampling, views ? ", one model per view" : ""));
        else
            observer.on_message(line("training OpenCV LBF (%d stages, %d trees of depth %d per landmark, %d initial shapes)%s...",
                                     lbf_options.stages, lbf_options.trees, lbf_options.depth, lbf_options.augment,
                                     views ? ", one model per view" : ""));
    }
    LbfTrainReport lbf_total;
    const auto train_one = [&](std::span<const TrainingFace> faces, const std::filesystem::path& file) {
        if (ert) {
            train_dlib_ert(faces, ert_options, file);
            return;
        }
        const LbfTrainReport r = train_lbf(faces, lbf_options, file);
        // Training NMEs of the view models, weighted by the faces each used.
        const double used = lbf_total.faces_used + r.faces_used;
        lbf_total.train_nme_initial = (lbf_total.train_nme_initial * lbf_total.faces_used + r.train_nme_initial * r.faces_used) / used;
        lbf_total.train_nme_final = (lbf_total.train_nme_final * lbf_total.faces_used + r.train_nme_final * r.faces_used) / used;
        lbf_total.faces_used += r.faces_used;
        lbf_total.faces_outside_box += r.faces_outside_box;
    };
    if (views) {
        const ViewFaceSets sets = split_view_faces(prepared.faces, request.split);
        report["view_cascade_frontal_faces"] = sets.counts.frontal_faces;
        report["view_cascade_profile_faces"] = sets.counts.profile_faces;
        report["view_cascade_profile_mirrored"] = sets.counts.profile_mirrored;
        if (observer.on_message)
            observer.on_message(line("view-specific models: frontal %d faces, profile %d faces (%d mirrored nose-right)",
                                     sets.counts.frontal_faces, sets.counts.profile_faces, sets.counts.profile_mirrored));
        write_view_baseline_bundle(request.out, train_view_baselines(ert ? BaselineMethod::kErt : BaselineMethod::kLbf,
                                                                     prepared.boxes.detector, sets, request.out, train_one));
    } else {
        train_one(prepared.faces, request.out);
    }
    if (ert) return;
    report["lbf_faces_used"] = lbf_total.faces_used;
    report["lbf_faces_outside_box"] = lbf_total.faces_outside_box;
    report["train_nme_initial"] = lbf_total.train_nme_initial;
    report["train_nme_final"] = lbf_total.train_nme_final;
    if (observer.on_message)
        observer.on_message(line("%d faces used (%d outside OpenCV's box test); training NME (mean shape -> LBF): %.4f -> %.4f",
                                 lbf_total.faces_used, lbf_total.faces_outside_box, lbf_total.train_nme_initial, lbf_total.train_nme_final));
}

}  // namespace

nlohmann::json train_regressor(const std::vector<LabelledImage>& images, const TrainingRequest& request, const TrainingObserver& observer) {
    if (request.method == TrainingMethod::kLbf) check_lbf_options(request.lbf);  // before the long preparation
    std::optional<SdmModel> base;
    if (request.method == TrainingMethod::kSdm && !request.base.empty()) base = read_sdm_model(request.base);
    const PreparedFaces prepared = prepare_training_faces(images, request.prepare);
    if (observer.on_warning)
        for (const auto& w : prepared.warnings) observer.on_warning(w);
    const BoxStatistics& boxes = prepared.boxes;
    if (observer.on_message)
        observer.on_message(line("%zu faces (%zu images skipped); %s detector matched %d (frontal %d, nose left %d, nose right %d), "
                                 "missed %d (synthesised boxes: width ratio %.3f±%.3f, offset (%.3f, %.3f))",
                                 prepared.faces.size(), prepared.warnings.size(), detector_name(boxes.detector), boxes.detector_matched,
                                 boxes.view_matched[0], boxes.view_matched[1], boxes.view_matched[2], boxes.detector_missed,
                                 boxes.width_ratio_mean, boxes.width_ratio_std, boxes.offset_mean.x(), boxes.offset_mean.y()));

    nlohmann::json report = {{"method", method_name(request.method)},
                             {"faces", prepared.faces.size()},
                             {"skipped_images", prepared.warnings.size()},
                             {"detector", detector_name(boxes.detector)},
                             {"detector_matched", boxes.detector_matched},
                             {"detector_missed", boxes.detector_missed}};
    for (std::size_t v = 0; v < kFaceViews; ++v)
        report[std::string("detector_matched_") + view_name(static_cast<FaceView>(v))] = boxes.view_matched[v];
    bool views = request.cascades == CascadeChoice::kViews;
    if (request.cascades == CascadeChoice::kAuto && detector_has_views(boxes.detector)) {
        const ViewCascadeCounts planned = count_view_split(prepared.faces, request.split);
        views = planned.frontal_faces >= kMinViewCascadeFaces && planned.profile_faces >= kMinViewCascadeFaces;
        if (!views && observer.on_message)
            observer.on_message(line("one model for all views: view-specific models need %d faces each, the split gives frontal %d, "
                                     "profile %d",
                                     kMinViewCascadeFaces, planned.frontal_faces, planned.profile_faces));
    }
    report["view_cascades"] = views;
    if (request.method == TrainingMethod::kSdm)
        train_sdm_models(prepared, request, std::move(base), views, observer, report);
    else
        train_baseline_models(prepared, request, views, observer, report);
    return report;
}

Eigen::Matrix2Xd read_label_offsets(const std::filesystem::path& path) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(core::read_file(path));
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("not valid JSON: ") + e.what());
    }
    Eigen::Matrix2Xd offsets(2, morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i)
        for (int axis = 0; axis < 2; ++axis) {
            char key[16];
            std::snprintf(key, sizeof key, "mean_%c_%02d", axis == 0 ? 'x' : 'y', i + 1);
            if (!j.is_object() || !j.contains(key) || !j[key].is_number())
                throw core::file_error(path.string(), std::string("no number '") + key + "' (expected the --json of eval conventions)");
            offsets(axis, i) = j[key].get<double>();
            if (!std::isfinite(offsets(axis, i)) || std::abs(offsets(axis, i)) > 1)
                throw core::file_error(path.string(), std::string("'") + key + "' is not a finite offset within one inter-ocular distance");
        }
    return offsets;
}

}  // namespace facesynth::train
