#pragma once
// `facesynth profile`: every photograph of a folder profiled to new yaws, written in synth's dataset
// folder layout (images/, landmarks/, meta/ with one key per view; docs/profile.md). Sample i is view
// i % V of photograph i / V (photographs in name order, V views each) and depends only on (seed, i);
// photographs are shared among shards and threads whole, so each is fitted once.
#include "morph/model.h"
#include "profile/scene.h"
#include "render/renderer.h"
#include "synth/dataset.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace facesynth::profile {

// The landmarks of the face in a photograph and where they came from ("pts", or a detector's label).
struct FoundLandmarks {
    Eigen::Matrix2Xd points;
    std::string source;
};
using LandmarkFinder = std::function<FoundLandmarks(const std::filesystem::path& image_path, const cv::Mat& image)>;

struct ViewPlan {
    // The views' yaws (degrees; default -90 to 90 in steps of 15), unless views_per_photo > 0: that
    // many views at random yaws.
    std::vector<double> yaws = {-90, -75, -60, -45, -30, -15, 0, 15, 30, 45, 60, 75, 90};
    int views_per_photo = 0;
    double yaw_limit = 90;     // random yaws: uniform in [-yaw_limit, yaw_limit]
    // Random yaws turn the face further toward profile only: uniform between its yaw in the
    // photograph and the limit on the side it faces (either side within 5° of frontal), as 300W-LP
    // does; turning it the other way shows what the photograph hid (the far side, the back of the
    // hair), and the mirror image of a view covers that side.
    bool toward_profile = true;
    // Views that turn the face more than this from its yaw in the photograph are not made (listed
    // yaws: skipped and counted; random yaws: drawn within reach).
    double max_turn = 90;
    double pitch_jitter = 0;   // standard deviation (degrees) of a normal change of the photograph's pitch per view
    // A lighting change per view (ViewLight): strength uniform in [0, relight], the light's azimuth
    // uniform in [-75°, 75°] and elevation in [-20°, 50°]; 0 keeps the photograph's light.
    double relight = 0;
    [[nodiscard]] bool random_yaws() const { return views_per_photo > 0; }
    [[nodiscard]] int views() const { return random_yaws() ? views_per_photo : static_cast<int>(yaws.size()); }
};

// "-90:90:15" (first:last:step, both ends included) or "a,b,c"; throws core::Error naming the text.
[[nodiscard]] std::vector<double> parse_yaws(const std::string& text);

// The pose of view v of a photograph whose fitted pose is `source`; nullopt when the plan skips it.
[[nodiscard]] std::optional<ViewPose> plan_view(const ViewPlan& plan, const ViewPose& source, std::uint64_t seed, std::int64_t index);

// What a run writes besides the folder layout (images/, landmarks/, meta/, photos/), which is always
// written: resume and the tars are made from it.
struct ProfileOutput {
    std::string formats = "folder";  // comma-separated: folder, wds, coco (synth::parse_formats)
    std::string image_format = "png";  // or "jpg"
    int jpeg_quality = 95;
    int png_compression = 1;
    // Views per WebDataset tar, rounded down to whole photographs (at least one): tar t holds every view
    // of photographs [t·P, (t+1)·P), P = max(1, wds_shard_size / views per photograph).
    int wds_shard_size = 1000;
    std::string wds_prefix = "shard";
};

// View `index`'s light (strength 0 unless plan.relight > 0); depends only on (seed, index).
[[nodiscard]] ViewLight plan_light(const ViewPlan& plan, std::uint64_t seed, std::int64_t index);

struct ProfileRunOptions {
    std::filesystem::path photos;  // folder of photographs (core::is_image_file)
    std::filesystem::path out;
    ProfileOptions profile;
    ViewPlan plan;
    std::uint64_t seed = 1;
    std::string jaw = "contour";   // which landmarks the .pts hold: "contour" (annotators' convention) or "fixed"
    ProfileOutput output;
    int threads = 1;
    synth::Shard shard;
    bool overwrite = false;        // replace a dataset made with other settings
    LandmarkFinder landmarks;      // called from one thread at a time; empty: photo.pts or an error
    render::RendererOptions renderer;
    std::function<void(std::size_t todo)> on_start;  // photographs to process in this run
    std::function<void()> on_photo;                  // after each, from worker threads (serialised)
};

// Applies a TOML file's keys to `options` (docs/profile.md lists them: seed, jaw, [views], [scene],
// [fit], [output]); unknown keys, wrong types and bad yaws throw core::Error naming the file and key.
void apply_config_file(ProfileRunOptions& options, const std::filesystem::path& path);

// Throws core::Error naming the first setting out of range (as its config key).
void validate(const ProfileRunOptions& options);

// Photographs per WebDataset tar (1 without wds). Photographs are shared among shards in these units:
// photograph p belongs to shard (p / unit) % N, so each tar is written by one process.
[[nodiscard]] std::size_t photos_per_tar(const ProfileRunOptions& options);

struct PhotoFailure {
    std::string photo;
    std::string message;
};

struct ProfileRunResult {
    std::size_t photos = 0;            // in the folder
    std::size_t photos_in_shard = 0;
    std::size_t photos_done_before = 0;  // every view already on disk
    std::size_t views_written = 0;
    std::size_t views_skipped = 0;     // beyond plan.max_turn
    std::size_t detected = 0;          // photographs without a .pts, landmarked by the finder
    std::size_t tars_written = 0;
    std::vector<PhotoFailure> failures;
    double seconds = 0;
    double prepare_seconds = 0;        // fit, textures and grid, summed over threads
    double render_seconds = 0;         // views rendered, composited and labelled
    double write_seconds = 0;          // encoded and written
};

// Throws core::Error for what stops the whole run (bad options, no photographs, an output folder made
// with other settings, an unwritable folder); a photograph that fails (unreadable, no face, broken .pts,
// failed fit) is listed in failures, its views are not written, and the others go on. With wds, the
// shard's tars that are missing or hold a photograph processed in this run are (re)written when all its
// photographs are done; with coco, coco.json (coco-K-of-N.json for a shard) lists the shard's views.
ProfileRunResult run_profile(const ProfileRunOptions& options, const morph::MorphableModel& model);

// The settings that define a profiled dataset (written to profile.json; a second run into the same
// folder must agree on them).
[[nodiscard]] nlohmann::json profile_settings(const ProfileRunOptions& options, const morph::MorphableModel& model);

}  // namespace facesynth::profile
