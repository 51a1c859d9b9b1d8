// `facesynth track`: follow faces through a video, a folder of frames or a camera (docs/track.md).
// The work is track::run_track.
#include "cli_common.h"
#include "commands.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "track/evaluate.h"
#include "track/session.h"

#include <cstdio>
#include <memory>
#include <optional>

namespace facesynth::cli {
namespace {

constexpr const char* kTrackDetectorHelp =
    "Face detector: frontal, multiview, dlib or dlib+profile (as `detect` has them), or auto: the one the regressor was trained with "
    "(.sdm), else dlib's (the boxes dlib's predictor was trained on)";

void add_smoothing_options(CLI::App& cmd, track::SmoothingSettings& smoothing) {
    cmd.add_option("--smooth-cutoff", smoothing.min_cutoff_hz, "1-euro filter: cutoff at rest, Hz (lower: less jitter)")->capture_default_str()->check(CLI::Range(0.01, 1000.0));
    cmd.add_option("--smooth-speed", smoothing.speed_coefficient, "1-euro filter: cutoff rise per face width per second of speed (higher: less lag)")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1e6));
}

void add_scene_options(CLI::App& cmd, track::TrackerSettings& tracker) {
    cmd.add_option("--cut-threshold", tracker.cut_threshold,
                   "Scene cut when a frame's grey 32x32 thumbnail differs from the previous one's by more than this mean absolute difference (grey levels); 0: off")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 255.0));
    cmd.add_option("--max-reid-distance", tracker.max_reid_distance,
                   "Re-identification: a new face this close (LBPH distance) to a lost face's appearance takes its id; 0: off")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1e9));
}

struct TrackArgs {
    track::TrackJob job;
    std::string outputs = "landmarks,pose";
    std::string json;
    bool no_smoothing = false;
    bool quiet = false;
};

void run_track_command(TrackArgs& a) {
    const track::TrackOutputs sizes = a.job.outputs;
    a.job.outputs = track::parse_track_outputs(a.outputs);
    a.job.outputs.isomap_size = sizes.isomap_size;
    a.job.outputs.frontal_size = sizes.frontal_size;
    a.job.tracker.smooth = !a.no_smoothing;
    std::optional<Progress> progress;
    const track::TrackSummary summary = track::run_track(a.job, [&](std::int64_t, std::optional<std::int64_t> total) {
        if (!progress) progress.emplace("track", total ? static_cast<std::size_t>(*total) : 0, a.quiet);
        progress->advance();
    });
    if (progress) progress->finish();
    if (!a.quiet) {
        const auto j = summary.json();
        std::printf("%lld frames, %lld with a face, %d faces, %d detector runs, %d losses (%d found again): %.1f fps tracking (%.2f ms per frame), "
                    "decoding %.2f ms per frame, %d scene cuts, %d faces recognised -> %s\n",
                    static_cast<long long>(summary.frames), static_cast<long long>(summary.frames_with_face), summary.faces, summary.detector_runs,
                    summary.losses, summary.reacquired, j["fps"].get<double>(), j["ms_per_frame"].get<double>(), j["decode_ms_per_frame"].get<double>(),
                    summary.cuts, summary.reidentified, a.job.out.string().c_str());
    }
    if (!a.json.empty()) write_json_file(a.json, summary.json());
}

struct TrackEvalArgs {
    track::TrackEvalSettings settings;
    std::string model = "builtin";
    std::string regressor = "dlib";
    std::string detector = "auto";
    std::string json;
    std::string nme_csv;
    bool quiet = false;
};

void run_eval_track(TrackEvalArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    const fit::Fitter fitter(model);
    const auto regressor = train::open_regressor(a.regressor);
    const train::DetectorKind detector = track::tracking_detector(a.detector, *regressor);
    std::optional<Progress> progress;
    const track::TrackEvaluation e = track::evaluate_tracking(*regressor, detector, fitter, a.settings, [&](std::int64_t, std::int64_t total) {
        if (!progress) progress.emplace("eval track", static_cast<std::size_t>(total), a.quiet);
        progress->advance();
    });
    if (progress) progress->finish();
    const nlohmann::json j = e.json(a.settings.failure_threshold);
    if (!a.quiet) {
        std::printf("%d clips, %lld frames (%lld still), regressor %s, detector %s\n", e.clips, static_cast<long long>(e.frames),
                    static_cast<long long>(e.static_frames), regressor->label().c_str(), train::detector_name(detector));
        std::printf("%-10s %8s %8s %8s %9s %9s %8s %9s %8s\n", "variant", "NME", "fail", "found", "jitter", "reacq_fr", "yaw_err", "detector", "fps");
        for (const char* variant : {"tracked", "per_frame"}) {
            const std::string p = std::string(variant) + "_";
            std::printf("%-10s %8.4f %8.3f %8.3f %9.5f %9.1f %8.2f %9d %8.1f\n", variant, j[p + "nme_mean"].get<double>(), j[p + "failure_rate"].get<double>(),
                        j[p + "found_rate"].get<double>(), j[p + "jitter_static"].get<double>(), j[p + "reacquire_frames_mean"].get<double>(),
                        j[p + "yaw_error_deg"].get<double>(), j[p + "detector_runs"].get<int>(), j[p + "fps"].get<double>());
        }
        if (e.with_cuts)
            std::printf("cuts: %d of %d seen, %d elsewhere; returns with their first id: %d of %d; ids shared by two faces: %d\n", e.cut.cuts_detected,
                        e.cut.cuts, e.cut.false_cuts, e.cut.returns_same_id, e.cut.returns, e.cut.false_merges);
    }
    if (!a.nme_csv.empty()) {
        // The layout of `eval landmarks --nme-csv` (regressor1 tracked, regressor2 per frame; detected:
        // both found the face), for tools/nme_bootstrap.py. Frames of a clip are not independent: the
        // intervals it gives are narrower than a bootstrap over clips would be.
        // Beside them, the pose error over time: each frame's clip, frame and |yaw error| per variant
        // (empty where the face was missed).
        std::string csv = "key,yaw_deg,detected,view,regressor1,regressor2,clip,frame,tracked_yaw_error_deg,per_frame_yaw_error_deg\n";
        const auto error_text = [](double error) {
            char text[32] = "";
            if (std::isfinite(error)) std::snprintf(text, sizeof text, "%.4g", error);
            return std::string(text);
        };
        for (std::size_t i = 0; i < e.keys.size(); ++i) {
            const double t = e.tracked.nmes[i], p = e.per_frame.nmes[i];
            const bool both = std::isfinite(t) && std::isfinite(p);
            char row[200];
            std::snprintf(row, sizeof row, "%s,%.3f,%d,frame,%.7g,%.7g,%lld,%lld,", e.keys[i].c_str(), e.yaws[i], both ? 1 : 0, both ? t : 0.0, both ? p : 0.0,
                          static_cast<long long>(e.clip_of[i]), static_cast<long long>(e.frame_of[i]));
            csv += row + error_text(e.tracked.yaw_errors[i]) + "," + error_text(e.per_frame.yaw_errors[i]) + "\n";
        }
        core::write_file_atomically(a.nme_csv, csv);
    }
    if (!a.json.empty()) write_json_file(a.json, j);
}

}  // namespace

void register_track_commands(CLI::App& app) {
    auto a = std::make_shared<TrackArgs>();
    auto* cmd = app.add_subcommand("track", "Follow faces through a video, a folder of frames or a camera: landmarks, pose and identity per frame");
    cmd->add_option("input", a->job.input, "A video file (OpenCV's FFmpeg backend), a folder of frames (name order) or a camera index")->required();
    cmd->add_option("--out,-o", a->job.out, "Output folder (must not exist): faces.jsonl, summary.json, overlay.avi")->required();
    cmd->add_option("--model", a->job.model, "Model fitted per frame: builtin, a model file or folder")->capture_default_str();
    cmd->add_option("--regressor", a->job.regressor, "Landmark regressor: dlib or a .sdm from `facesynth train`")->capture_default_str();
    add_detector_option(*cmd, a->job.detector)->description(kTrackDetectorHelp);
    cmd->add_option("--outputs", a->outputs,
                    "Comma-separated: landmarks (always), pose (pose, expression, fused identity), overlay (overlay.avi), isomap (isomap.avi: the first "
                    "face's texture fused over the frames), frontal (frontal.avi: that face rendered frontally with it)")
        ->capture_default_str();
    cmd->add_option("--isomap-size", a->job.outputs.isomap_size, "Isomap side in texels")->capture_default_str()->check(CLI::Range(16, 4096));
    cmd->add_option("--frontal-size", a->job.outputs.frontal_size, "Frontal render side in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
    cmd->add_option("--max-faces", a->job.tracker.max_faces, "Faces followed at once")->capture_default_str()->check(CLI::Range(1, 64));
    cmd->add_option("--detect-every", a->job.tracker.detect_every, "Frames between face detector runs while faces are tracked")
        ->capture_default_str()
        ->check(CLI::Range(1, 100000));
    cmd->add_option("--max-fit-error", a->job.tracker.max_fit_error, "A face is lost when its fit's RMS exceeds this share of the inter-ocular distance")
        ->capture_default_str()
        ->check(CLI::Range(1e-6, 10.0));
    cmd->add_flag("--no-smoothing", a->no_smoothing, "Landmarks as the regressor gives them (no 1-euro filter)");
    add_smoothing_options(*cmd, a->job.tracker.smoothing);
    add_scene_options(*cmd, a->job.tracker);
    cmd->add_flag("--per-frame", [a](std::int64_t) { a->job.tracker.track = false; }, "The baseline: detect every frame, no tracking, no smoothing");
    cmd->add_option("--max-frames", a->job.max_frames, "Stop after this many frames (0: the whole input)")->capture_default_str()->check(CLI::NonNegativeNumber);
    cmd->add_option("--fps", a->job.folder_fps, "Frame rate of a folder of frames")->capture_default_str()->check(CLI::Range(0.01, 1000.0));
    cmd->add_option("--json", a->json, "Write the summary as flat JSON (frames, frames_with_face, detector_runs, fps, ms_per_frame, decode_ms_per_frame, ...)");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or summary line");
    cmd->callback([a] { run_track_command(*a); });

    auto e = std::make_shared<TrackEvalArgs>();
    auto* ev = eval_group(app).add_subcommand("track", "Tracking against ground truth on a synth dataset of clips: the tracker and per-frame detection on the same frames");
    ev->add_option("--data", e->settings.data, "A `facesynth synth --sequence F` dataset")->required()->check(CLI::ExistingDirectory);
    ev->add_option("--model", e->model, "Model fitted per frame")->capture_default_str();
    ev->add_option("--regressor", e->regressor, "Landmark regressor: dlib or a .sdm")->capture_default_str();
    add_detector_option(*ev, e->detector)->description(kTrackDetectorHelp);
    ev->add_option("--detect-every", e->settings.tracker.detect_every, "Frames between detector runs while tracking")->capture_default_str()->check(CLI::Range(1, 100000));
    ev->add_option("--max-fit-error", e->settings.tracker.max_fit_error, "Fit RMS / inter-ocular distance above which a face is lost")
        ->capture_default_str()
        ->check(CLI::Range(1e-6, 10.0));
    ev->add_option("--failure-threshold", e->settings.failure_threshold, "A frame fails when its face is missed or its NME exceeds this")
        ->capture_default_str()
        ->check(CLI::Range(1e-6, 10.0));
    ev->add_flag("--no-smoothing", [e](std::int64_t) { e->settings.tracker.smooth = false; }, "Track without the 1-euro filter");
    add_smoothing_options(*ev, e->settings.tracker.smoothing);
    add_scene_options(*ev, e->settings.tracker);
    ev->add_flag("--cuts", e->settings.cuts,
                 "One stream through every clip's first half, then every clip's second half: faces leave at cuts and come back (cuts, returns_same_id, false_merges)");
    ev->add_option("--json", e->json, "Write the flat figures (tracked_* and per_frame_*)");
    ev->add_option("--nme-csv", e->nme_csv, "Write every frame's NME per variant (eval landmarks' layout, for tools/nme_bootstrap.py) with its clip, frame and yaw error per variant");
    ev->add_flag("-q,--quiet", e->quiet, "Only the files, no table or progress");
    ev->callback([e] { run_eval_track(*e); });
}

}  // namespace facesynth::cli
