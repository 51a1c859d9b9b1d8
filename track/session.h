#pragma once
// `facesynth track` as a function: frames from a FrameSource through a Tracker into an output folder
// (docs/track.md): faces.jsonl (a line per frame) and, on request, an overlay video.
#include "track/tracker.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace facesynth::track {

struct TrackOutputs {
    bool pose = true;      // pose, expression and fused identity in faces.jsonl (landmarks always)
    bool overlay = false;  // overlay.avi: the frames with landmarks, boxes and ids drawn (MJPEG)
    // One tile per face followed at once (max_faces tiles side by side; a face keeps its tile while followed):
    bool isomap = false;   // isomap.avi: each face's texture fused over its frames so far
    bool frontal = false;  // frontal.avi: each face rendered frontally with that texture
    int isomap_size = 256;
    int frontal_size = 256;
};
// "landmarks,pose,overlay,isomap,frontal" -> TrackOutputs; throws core::Error naming an unknown entry.
[[nodiscard]] TrackOutputs parse_track_outputs(const std::string& list);

struct TrackJob {
    std::string input;             // video file, folder of frames, or camera index
    std::filesystem::path out;     // must not exist; written under a temporary name, renamed at the end
    std::string model = "builtin";
    std::string regressor = "dlib";
    std::string detector = "auto";
    TrackOutputs outputs;
    TrackerSettings tracker;
    std::int64_t max_frames = 0;   // 0: the whole input (a camera runs until this is reached)
    double folder_fps = 30;        // frame rate of a folder of frames
};

struct TrackSummary {
    std::int64_t frames = 0, frames_with_face = 0;
    int detector_runs = 0, fallback_runs = 0, losses = 0, reacquired = 0, faces = 0;  // faces: distinct ids
    int cuts = 0, reidentified = 0;  // scene cuts seen; faces recognised by appearance (of reacquired)
    double track_seconds = 0;   // tracking, fitting and writing, decoding excluded
    double decode_seconds = 0;
    double texture_seconds = 0;   // isomap extraction, fusion and the frontal render (within track_seconds)
    double isomap_coverage = 0;   // share of the uv layout the longest-followed face's fused isomap covers
    // frames, frames_with_face, detector_runs, fps, ms_per_frame, decode_ms_per_frame, texture_ms_per_frame, isomap_coverage, ...
    [[nodiscard]] nlohmann::json json() const;
};

// Throws core::Error (naming the input, the file or the setting) and leaves no output folder behind.
// `on_frame(done, total)` after every frame (total: nullopt for cameras).
[[nodiscard]] TrackSummary run_track(const TrackJob& job, const std::function<void(std::int64_t, std::optional<std::int64_t>)>& on_frame = {});

// The detector for tracking with `regressor`: a detector_name, or "auto": the one the regressor was
// trained with (an .sdm records it), else dlib's, whose boxes dlib's predictor was trained on (and
// which is three times faster than the multi-view cascades at 640x360).
[[nodiscard]] train::DetectorKind tracking_detector(const std::string& option, const train::LandmarkRegressor& regressor);

// One line of faces.jsonl; `tracker` gives the frame's scene change and cut.
[[nodiscard]] std::string frame_record(std::int64_t frame, double time_s, const std::vector<FaceState>& faces, const Tracker& tracker, bool pose);

}  // namespace facesynth::track
