// Appearance from photographs for synth: `facesynth textures` (a texture bank: frontal/photo_texture.h
// for one photograph, synth/texture_bank.h on disk) and `facesynth backgrounds` (the photographs with
// their annotated face cut away: synth/photo_backgrounds.h; a face detector rejects strips that show
// another face). docs/textures.md.
#include "cli_common.h"
#include "commands.h"

#include "frontal/photo_texture.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"
#include "core/atomic_file.h"
#include "morph/model_io.h"
#include "synth/photo_backgrounds.h"
#include "synth/texture_bank.h"
#include "fit/fit.h"
#include "train/dataset.h"
#include "train/realism.h"
#include "train/face_box.h"
#include "train/photo_landmarks.h"
#include "train/regressor.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>

namespace facesynth::cli {
namespace {

namespace fs = std::filesystem;

struct TexturesArgs {
    std::string photos;
    std::string model = "builtin";
    std::string out;
    std::string regressor = "dlib";
    std::string detector = "auto";
    int size = 512;
    bool keep_shading = false;
    bool align_features = false;
    bool align_jaw = false;
    bool skin_beyond_face = false;
    bool drop_occluders = false;
    double jaw_margin = 0;
    double max_yaw = 50;
    double min_coverage = 0.6;
    double max_outliers = 0.2;
    double max_fit_error = 0.08;
    double fit_lambda = fit::FitOptions{}.lambda;
    std::string json;
    bool quiet = false;
};

// The reason's first word ("pose", "coverage", ...) for the summary.
std::string reason_kind(const std::string& reason) { return reason.substr(0, reason.find(':')); }

void run_textures(const TexturesArgs& a) {
    const std::vector<fs::path> images = train::list_photos(a.photos);
    const fs::path photos(a.photos);

    const morph::MorphableModel model = morph::load_model(a.model);
    frontal::PhotoTextureOptions options;
    options.size = a.size;
    options.remove_shading = !a.keep_shading;
    options.max_abs_yaw_deg = a.max_yaw;
    options.min_face_coverage = a.min_coverage;
    options.max_skin_outliers = a.max_outliers;
    options.max_fit_error = a.max_fit_error;
    options.fit_lambda = a.fit_lambda;
    options.align_features = a.align_features;
    options.align_jaw = a.align_jaw;
    options.skin_beyond_face = a.skin_beyond_face;
    options.drop_occluders = a.drop_occluders;
    options.jaw_margin = a.jaw_margin;
    frontal::Frontaliser frontaliser(model);
    if (model.symmetry.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("textures: model '" + model.name + "' (" + a.model + ") has no symmetry map to fill the hidden side with");

    synth::TextureBankManifest header;
    header.model = model.name;
    header.model_checksum = model.checksum();
    header.vertices = model.num_vertices();
    header.size = a.size;
    header.settings = {{"photos", photos.string()},           {"remove_shading", options.remove_shading},
                       {"min_shading", options.min_shading},  {"max_abs_yaw_deg", options.max_abs_yaw_deg},
                       {"min_face_coverage", options.min_face_coverage}, {"max_skin_outliers", options.max_skin_outliers},
                       {"max_fit_error", options.max_fit_error}, {"fit_lambda", options.fit_lambda}, {"outlier_delta_e", frontal::kOutlierDeltaE},
                       {"align_features", options.align_features || options.align_jaw}, {"align_jaw", options.align_jaw},
                       {"skin_beyond_face", options.skin_beyond_face}, {"drop_occluders", options.drop_occluders},
                       {"jaw_margin", options.jaw_margin},
                       {"detector_for_photos_without_pts", a.regressor}};
    synth::TextureBankWriter bank(a.out, header);

    // Photographs without a .pts: the largest face the regressor's detector finds.
    train::PtsOrDetected landmarker(a.regressor, a.detector);
    std::map<std::string, int> reasons;
    int from_pts = 0, detected = 0;
    Progress progress("textures", images.size(), a.quiet);
    for (const fs::path& path : images) {
        try {
            const cv::Mat image = train::read_photo(path);
            const auto [landmarks, source] = landmarker.find(path, image);
            ++(source == "pts" ? from_pts : detected);
            frontal::PhotoTexture t = frontal::extract_photo_texture(frontaliser, image, landmarks, options);
            if (!t.rejection.empty()) {
                ++reasons[reason_kind(t.rejection)];
                bank.reject(path.string(), t.rejection);
            } else {
                synth::TextureBankEntry e;
                e.source = path.string();
                e.landmarks_source = source;
                e.yaw_deg = t.yaw_deg, e.pitch_deg = t.pitch_deg, e.roll_deg = t.roll_deg;
                e.face_coverage = t.face_coverage, e.seen_share = t.seen_share, e.skin_outliers = t.skin_outliers;
                e.dropped_share = t.dropped_share;
                e.fit_error = t.fit_error, e.shading_range = t.shading_range, e.skin_srgb = t.skin_srgb;
                e.shape = t.shape;
                e.expression = t.expression;
                bank.add(t.texture, std::move(e));
            }
        } catch (const core::Error& e) {
            ++reasons["unreadable"];
            bank.reject(path.string(), e.what());
            if (!a.quiet) std::fprintf(stderr, "facesynth: warning: %s (skipped)\n", e.what());
        }
        progress.advance();
    }
    progress.finish();
    const auto& m = bank.manifest();
    if (m.textures.empty()) throw core::file_error(a.photos, "no usable texture in " + std::to_string(images.size()) + " photographs; no bank written");
    const std::size_t kept = m.textures.size(), rejected = m.rejected.size();
    bank.commit();
    if (!a.quiet) {
        std::printf("%zu textures from %zu photographs -> %s (%d with .pts, %d detected); rejected %zu", kept, images.size(), a.out.c_str(),
                    from_pts, detected, rejected);
        for (const auto& [kind, count] : reasons) std::printf(", %s %d", kind.c_str(), count);
        std::printf("\n");
    }
    if (!a.json.empty()) {
        nlohmann::json j;
        j["photos"] = images.size();
        j["textures"] = kept;
        j["rejected"] = rejected;
        for (const char* kind : {"pose", "coverage", "occlusion", "fit", "shading", "unreadable"})
            j[std::string("rejected_") + kind] = reasons.count(kind) ? reasons.at(kind) : 0;
        j["with_pts"] = from_pts;
        j["detected"] = detected;
        j["model"] = model.name;
        j["size"] = a.size;
        j["out"] = a.out;
        write_json_file(a.json, j);
    }
}

struct BackgroundsArgs {
    std::string photos;
    std::string out;
    int min_side = 96;
    std::string json;
    bool quiet = false;
};

void run_backgrounds(const BackgroundsArgs& a) {
    const std::vector<fs::path> images = train::list_photos(a.photos);
    const fs::path out(a.out);
    if (fs::exists(out)) throw core::file_error(a.out, "exists already; choose a new folder");
    fs::path temporary = out;
    temporary += ".partial";
    std::error_code error;
    fs::remove_all(temporary, error);
    create_output_folder(temporary);
    // dlib's detector misses faces under about 80 px: strips are searched at twice their size.
    const train::FaceDetector detector(train::DetectorKind::kDlib);
    int written = 0, with_face = 0, skipped = 0;
    Progress progress("backgrounds", images.size(), a.quiet);
    try {
        for (const fs::path& path : images) {
            try {
                fs::path pts = path;
                pts.replace_extension(".pts");
                if (!fs::exists(pts)) throw core::file_error(path.string(), "no .pts beside it: the face to cut away is not known");
                const Eigen::Matrix2Xd landmarks = morph::read_pts(pts);
                core::check_image_not_too_large(path);
                const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
                if (image.empty()) throw core::file_error(path.string(), "cannot read the image (not an image file, or corrupt)");
                int k = 0;
                for (const cv::Rect& region : synth::background_regions(image.size(), landmarks, a.min_side)) {
                    const cv::Mat strip = image(region);
                    cv::Mat larger;
                    cv::resize(train::to_gray8(strip), larger, cv::Size(), 2, 2, cv::INTER_LINEAR);
                    if (!detector.detect(larger).empty()) {
                        ++with_face;
                        continue;
                    }
                    std::vector<unsigned char> jpeg;
                    cv::imencode(".jpg", strip, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
                    const fs::path file = temporary / (path.stem().string() + "_" + std::to_string(k++) + ".jpg");
                    core::write_file_atomically(file, std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
                    ++written;
                }
            } catch (const core::Error& e) {
                ++skipped;
                if (!a.quiet) std::fprintf(stderr, "facesynth: warning: %s (skipped)\n", e.what());
            }
            progress.advance();
        }
        progress.finish();
        if (written == 0) throw core::file_error(a.photos, "no background strip of at least " + std::to_string(a.min_side) + " px without a face");
        fs::rename(temporary, out);
    } catch (...) {
        fs::remove_all(temporary, error);
        throw;
    }
    if (!a.quiet)
        std::printf("%d backgrounds from %zu photographs -> %s (%d strips with a detected face dropped, %d photographs skipped)\n", written,
                    images.size(), a.out.c_str(), with_face, skipped);
    if (!a.json.empty())
        write_json_file(a.json, {{"photos", images.size()}, {"backgrounds", written}, {"dropped_with_face", with_face}, {"skipped", skipped},
                                 {"min_side", a.min_side}, {"out", a.out}});
}

struct RealismArgs {
    std::string data;
    std::string photos;
    std::string regressor = "dlib";
    std::string detector = "dlib";
    double max_yaw = 20;
    bool match_face_size = false;
    std::string json;
    bool quiet = false;
};

void run_realism(const RealismArgs& a) {
    const auto regressor = train::open_regressor(a.regressor);
    const train::LandmarkRegressor* const regressors[] = {regressor.get()};
    const train::DetectorKind detector = train::choose_detector(a.detector, regressors);
    std::optional<morph::MorphableModel> model;  // outlives the fitter, which keeps a reference
    std::optional<fit::Fitter> fitter;
    if (!a.photos.empty()) fitter.emplace(model.emplace(morph::load_model("builtin")));
    const train::AnnotationYaw photo_yaw = [&](const Eigen::Matrix2Xd& annotation) { return fit::annotated_yaw(*fitter, annotation); };
    std::optional<Progress> progress;
    const train::RealismReport report = train::evaluate_realism(
        {a.data, a.photos, a.max_yaw, a.match_face_size}, *regressor, detector, photo_yaw, [&](std::size_t total) { progress.emplace("realism", total, a.quiet); },
        [&] { progress->advance(); });
    progress->finish();
    for (const train::RealismSide* side : {&report.renders, &report.photos})
        for (const auto& w : side->warnings) std::fprintf(stderr, "facesynth: warning: %s\n", w.c_str());
    const bool with_photos = !a.photos.empty();
    if (!a.quiet) {
        std::printf("%s on near-frontal faces (|yaw| <= %.0f°), detector %s\n", regressor->label().c_str(), a.max_yaw, train::detector_name(detector));
        const auto side_line = [](const char* name, const train::RealismSide& side) {
            std::printf("  %-12s %4d faces, %4d found: NME mean %.4f, median %.4f, failure@0.08 %.3f; face grey level %.3f ± %.3f, "
                        "under the chin %.2f and on the neck %.2f of it; fine detail %.3f\n",
                        name, side.faces, side.detected, side.nme.mean, side.nme.median, side.nme.failure_rate_008, side.face_grey_mean,
                        side.face_grey_stddev, side.under_chin_shade, side.neck_shade, side.face_detail);
        };
        side_line("renders", report.renders);
        if (with_photos) {
            side_line("photographs", report.photos);
            std::printf("  face size (outer eye corners, median): renders %.0f px, photographs %.0f px%s\n", report.renders.iod_px_median,
                        report.photos.iod_px_median, a.match_face_size ? ", photographs scaled to the renders'" : "");
            std::printf("  NME ratio renders / photographs: %.2f\n", report.nme_ratio);
        }
        // The landmarks the predictor places most differently on renders than on photographs.
        const Eigen::Matrix2Xd gap = with_photos ? Eigen::Matrix2Xd(report.renders.bias - report.photos.bias) : report.renders.bias;
        std::printf("  largest bias gaps (renders%s, face frame, IOD):", with_photos ? " - photographs" : "");
        for (int k = 0; k < 6; ++k) {
            const int i = report.largest_gaps[static_cast<std::size_t>(k)];
            std::printf(" %d (%+.3f, %+.3f)", i + 1, gap(0, i), gap(1, i));
        }
        std::printf("\n");
    }
    if (!a.json.empty()) write_json_file(a.json, report.json);
}

}  // namespace

void register_appearance_commands(CLI::App& app) {
    auto r = std::make_shared<RealismArgs>();
    auto* realism = eval_group(app).add_subcommand("realism", "How well a real-trained landmark predictor reads near-frontal renders, against near-frontal photographs");
    realism->add_option("--data", r->data, "A facesynth synth dataset")->required();
    realism->add_option("--photos", r->photos, "Folder of photographs with .pts (their yaw from fitting the built-in model to the annotation)");
    realism->add_option("--regressor", r->regressor, "The real-trained predictor: dlib or a .sdm model")->capture_default_str();
    add_detector_option(*realism, r->detector);
    realism->add_option("--max-yaw", r->max_yaw, "Near-frontal: |yaw| at most this, degrees")->check(finite_range(0.0, 90.0))->capture_default_str();
    realism->add_flag("--match-face-size", r->match_face_size,
                      "Scale each photograph (image and annotation) so that its outer eye corners lie as far apart as the renders' median "
                      "before reading it: the faces compared at one size");
    realism->add_option("--json", r->json, "Write the figures as flat JSON (per-landmark bias as <side>_bias_<x|y>_<NN>)");
    realism->add_flag("-q,--quiet", r->quiet, "No progress or summary");
    realism->callback([r] { run_realism(*r); });

    auto b = std::make_shared<BackgroundsArgs>();
    auto* bg = app.add_subcommand("backgrounds", "Background images for synth (background.type = \"images\") from annotated photographs, their face cut away");
    bg->add_option("--photos", b->photos, "Folder of photographs, each with IMAGE.pts (68 landmarks, 1-based)")->required();
    bg->add_option("--out", b->out, "New folder for the backgrounds (JPEG)")->required();
    bg->add_option("--min-side", b->min_side, "Keep strips at least this many pixels on their shorter side")->check(CLI::Range(16, 4096))->capture_default_str();
    bg->add_option("--json", b->json, "Write a summary as flat JSON");
    bg->add_flag("-q,--quiet", b->quiet, "No progress or summary");
    bg->callback([b] { run_backgrounds(*b); });

    auto a = std::make_shared<TexturesArgs>();
    auto* cmd = app.add_subcommand("textures", "Build a texture bank for synth (albedo.texture_bank) from photographs: fit, isomap, shading removal, mirror fill");
    cmd->add_option("--photos", a->photos, "Folder of photographs; IMAGE.pts beside an image gives its 68 landmarks (1-based), else the face is detected")->required();
    cmd->add_option("--out", a->out, "The bank folder to write (replaced when it is an earlier bank)")->required();
    cmd->add_option("--model", a->model, "Model: builtin, a model file or folder")->capture_default_str();
    cmd->add_option("--regressor", a->regressor, "Landmarks for photographs without .pts: dlib or a .sdm model")->capture_default_str();
    add_detector_option(*cmd, a->detector);
    cmd->add_option("--size", a->size, "Texture side, texels")->check(CLI::Range(64, 4096))->capture_default_str();
    cmd->add_flag("--keep-shading", a->keep_shading, "Keep the photograph's shading in the texture (default: divide it out)");
    cmd->add_flag("--align-features", a->align_features, "Warp each photograph so that its annotated features land on the fitted model's landmarks before taking the texture");
    cmd->add_flag("--align-jaw", a->align_jaw, "With --align-features (implied), the annotated jaw outline too, onto the fitted model's silhouette");
    cmd->add_flag("--skin-beyond-face", a->skin_beyond_face, "Give the model's ears and neck the face's own skin colour, and fade unseen skin to it, instead of what surrounds the face in the photograph");
    cmd->add_flag("--drop-occluders", a->drop_occluders,
                  "Treat seen skin above the nose's base far from the skin's median colour (hair across the forehead, hands, frames) as unseen: filled from its mirror or its neighbours");
    cmd->add_option("--jaw-margin", a->jaw_margin,
                    "Treat the face within this share of the inter-ocular distance inside the annotated jaw line (its edge, the shadow beside it) as unseen: filled from the skin further in")
        ->check(finite_range(0.0, 0.5))
        ->capture_default_str();
    cmd->add_option("--max-yaw", a->max_yaw, "Reject faces turned further than this, degrees")->check(finite_range(0.0, 90.0))->capture_default_str();
    cmd->add_option("--min-coverage", a->min_coverage, "Reject faces with less of the face seen (with the mirror side)")->check(finite_range(0.0, 1.0))->capture_default_str();
    cmd->add_option("--max-outliers", a->max_outliers, "Reject faces with more of the seen skin far from its median colour (occlusion)")
        ->check(finite_range(0.0, 1.0))
        ->capture_default_str();
    cmd->add_option("--max-fit-error", a->max_fit_error, "Reject fits whose landmark RMS exceeds this share of the inter-ocular distance")
        ->check(finite_range(0.0, 1.0))
        ->capture_default_str();
    cmd->add_option("--fit-lambda", a->fit_lambda, "Identity prior weight of the fit (as fit's --lambda): lower follows the annotated points further from the model's mean")
        ->check(finite_range(0.0, 1e6))
        ->capture_default_str();
    cmd->add_option("--json", a->json, "Write a summary (counts per rejection reason) as flat JSON");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or summary");
    cmd->callback([a] { run_textures(*a); });
}

}  // namespace facesynth::cli
