#pragma once
// `facesynth eval track` (docs/track.md): the tracker and the per-frame baseline (the detector every
// frame, landmarks from its box, no smoothing) run over the same frames of a synth dataset made with
// clips (synth --sequence), measured against every frame's ground truth.
#include "fit/fit.h"
#include "track/tracker.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace facesynth::track {

struct TrackEvalSettings {
    std::filesystem::path data;  // a synth dataset with clips (meta `sequence`)
    TrackerSettings tracker;     // the tracked variant's settings (the baseline: the same with track = false)
    double failure_threshold = 0.08;  // a frame fails when its face is missed or its NME exceeds this
    // Scene cuts: instead of a tracker per clip, one stream through every clip's first half, then every
    // clip's second half, so that each face leaves at a cut and comes back after the other clips.
    bool cuts = false;
};

// With `cuts`: how the tracked variant's ids followed the faces. A segment's id is the id most of its
// matched frames carry.
struct CutFigures {
    int cuts = 0;             // segment boundaries in the stream
    int cuts_detected = 0;    // of those, where the tracker saw a cut
    int false_cuts = 0;       // cuts the tracker saw elsewhere
    int returns = 0;          // second halves whose face had an id in both halves
    int returns_same_id = 0;  // of those, with the first half's id
    int false_merges = 0;     // segments whose id an earlier segment of another clip had
};

// One variant's figures over every frame of every clip.
struct VariantFigures {
    std::int64_t frames = 0, found = 0, failed = 0;
    double nme_sum = 0;            // over found frames
    std::vector<double> nmes;      // per frame, +inf when missed (dataset order within clips)
    std::vector<double> yaw_errors;  // per frame, |fitted - true yaw| in degrees, NaN when missed
    double jitter_sum = 0;         // over static frames with the face found in both
    std::int64_t jitter_frames = 0;
    std::int64_t reacquisitions = 0, reacquisition_frames = 0;  // failure runs after a success that ended in a success
    double yaw_error_sum = 0;      // |fitted - true yaw| over found frames, degrees
    int detector_runs = 0, losses = 0;
    double seconds = 0;            // tracking and fitting, decoding excluded
};

struct TrackEvaluation {
    int clips = 0;
    std::int64_t frames = 0, static_frames = 0;
    VariantFigures tracked, per_frame;
    CutFigures cut;  // with settings.cuts
    std::vector<std::string> keys;  // the sample of each frame, in the order of `nmes`
    std::vector<double> yaws;       // its true yaw, degrees
    std::vector<std::int64_t> clip_of, frame_of;  // its clip and frame within the clip
    // clips, frames, static_frames, and per variant (tracked_, per_frame_): nme_mean, nme_median,
    // failure_rate, found_rate, jitter_static, reacquire_frames_mean, reacquisitions, yaw_error_deg,
    // detector_runs, losses, fps, ms_per_frame; with cuts also cuts, cuts_detected, false_cuts,
    // returns, returns_same_id, false_merges.
    bool with_cuts = false;
    [[nodiscard]] nlohmann::json json(double failure_threshold) const;
};

// Throws core::Error naming the dataset, the file or the sample (a dataset without clips, an
// unreadable image or meta file). `on_frame(done, total)` after every frame.
[[nodiscard]] TrackEvaluation evaluate_tracking(const train::LandmarkRegressor& regressor, train::DetectorKind detector, const fit::Fitter& fitter,
                                                const TrackEvalSettings& settings,
                                                const std::function<void(std::int64_t, std::int64_t)>& on_frame = {});

}  // namespace facesynth::track
