// `facesynth profile`: annotated photographs re-rendered at new head poses (profile/dataset.h), and
// `bench profile`, its speed.
#include "cli_common.h"
#include "commands.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "profile/dataset.h"
#include "train/photo_landmarks.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>

#include <unistd.h>

namespace facesynth::cli {
namespace {

namespace fs = std::filesystem;

// The command line's values; each overrides the library's default or --config's value only when given.
struct ProfileArgs {
    const CLI::App* command = nullptr;
    std::string photos;
    std::string out;
    std::string config;
    std::string model = "builtin";
    std::string yaws;
    int views_per_photo = 0;
    double yaw_limit = 0;
    double max_turn = 0;
    double pitch_jitter = 0;
    double relight = 0;
    bool both_ways = false;
    std::uint64_t seed = 0;
    int size = 0;
    double crop_margin = 0;
    int isomap_size = 0;
    std::string jaw;
    std::string image_format;
    std::string formats;
    bool no_residual = false;
    int threads = 0;
    std::string shard = "0/1";
    int shard_count = 0;
    bool overwrite = false;
    std::string regressor = "dlib";
    std::string detector = "auto";
    std::string json;
    bool quiet = false;
    [[nodiscard]] bool given(const char* option) const { return command->count(option) > 0; }
};

profile::ProfileRunOptions run_options(const ProfileArgs& a) {
    profile::ProfileRunOptions o;
    o.photos = a.photos;
    o.out = a.out;
    if (!a.config.empty()) profile::apply_config_file(o, a.config);
    if (a.given("--yaws") && a.given("--views-per-photo")) throw CLI::ValidationError("--yaws and --views-per-photo", "give one of them, not both");
    if (a.given("--yaws")) {
        try {
            o.plan.yaws = profile::parse_yaws(a.yaws);
        } catch (const core::Error& e) {
            throw CLI::ValidationError(e.what());
        }
        o.plan.views_per_photo = 0;
    } else if (a.given("--views-per-photo")) {
        o.plan.views_per_photo = a.views_per_photo;
    }
    if (a.given("--yaw-limit")) o.plan.yaw_limit = a.yaw_limit;
    if (a.given("--max-turn")) o.plan.max_turn = a.max_turn;
    if (a.given("--pitch-jitter")) o.plan.pitch_jitter = a.pitch_jitter;
    if (a.given("--relight")) o.plan.relight = a.relight;
    if (a.given("--both-ways")) o.plan.toward_profile = false;
    if (a.given("--seed")) o.seed = a.seed;
    if (a.given("--size")) o.profile.size = a.size;
    if (a.given("--crop-margin")) o.profile.crop_margin = a.crop_margin;
    if (a.given("--isomap-size")) o.profile.isomap_size = a.isomap_size;
    if (a.given("--no-residual")) o.profile.apply_residual = false;
    if (a.given("--jaw")) o.jaw = a.jaw;
    if (a.given("--image-format")) o.output.image_format = a.image_format;
    if (a.given("--formats")) o.output.formats = a.formats;
    o.threads = a.threads > 0 ? a.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    o.shard = synth::parse_shard(a.shard, a.shard_count);
    o.overwrite = a.overwrite;
    profile::validate(o);
    return o;
}

void run_profile_command(const ProfileArgs& a) {
    profile::ProfileRunOptions options = run_options(a);
    const morph::MorphableModel model = morph::load_model(a.model);
    auto landmarker = std::make_shared<train::PtsOrDetected>(a.regressor, a.detector);
    options.landmarks = [landmarker](const fs::path& path, const cv::Mat& image) {
        train::PhotoLandmarks found = landmarker->find(path, image);
        return profile::FoundLandmarks{std::move(found.points), std::move(found.source)};
    };
    std::unique_ptr<Progress> progress;
    options.on_start = [&](std::size_t todo) { progress = std::make_unique<Progress>("profile", todo, a.quiet); };
    options.on_photo = [&] { progress->advance(); };
    const profile::ProfileRunResult r = profile::run_profile(options, model);
    if (progress) progress->finish();
    for (const auto& failure : r.failures) std::fprintf(stderr, "facesynth: error: %s\n", failure.message.c_str());
    const double views = static_cast<double>(std::max<std::size_t>(r.views_written, 1));
    if (!a.quiet)
        std::printf("profile: %zu views of %zu photographs -> %s (%zu already done, %zu failed, %zu detected; %zu views beyond --max-turn skipped); "
                    "%.1f views/s, per view: render %.1f ms, write %.1f ms; per photograph: fit and scene %.1f ms\n",
                    r.views_written, r.photos_in_shard - r.photos_done_before - r.failures.size(), a.out.c_str(), r.photos_done_before,
                    r.failures.size(), r.detected, r.views_skipped, r.views_written / std::max(r.seconds, 1e-9), 1e3 * r.render_seconds / views,
                    1e3 * r.write_seconds / views,
                    1e3 * r.prepare_seconds / static_cast<double>(std::max<std::size_t>(r.photos_in_shard - r.photos_done_before, 1)));
    if (!a.json.empty()) {
        nlohmann::json j;
        j["photos"] = r.photos;
        j["photos_in_shard"] = r.photos_in_shard;
        j["photos_done_before"] = r.photos_done_before;
        j["photos_failed"] = r.failures.size();
        j["photos_detected"] = r.detected;
        j["views_written"] = r.views_written;
        j["views_skipped"] = r.views_skipped;
        j["tars_written"] = r.tars_written;
        j["seconds"] = r.seconds;
        j["views_per_s"] = r.views_written / std::max(r.seconds, 1e-9);
        j["prepare_ms_per_photo"] = 1e3 * r.prepare_seconds / static_cast<double>(std::max<std::size_t>(r.photos_in_shard - r.photos_done_before, 1));
        j["render_ms_per_view"] = 1e3 * r.render_seconds / views;
        j["write_ms_per_view"] = 1e3 * r.write_seconds / views;
        j["threads"] = options.threads;
        j["model"] = model.name;
        write_json_file(a.json, j);
    }
    if (!r.failures.empty())
        throw core::Error(std::to_string(r.failures.size()) + " of " + std::to_string(r.photos_in_shard) +
                          " photographs failed (listed above); the others' views are written");
}

struct ProfileBenchArgs {
    std::string photos;
    std::size_t max_photos = 40;
    int views_per_photo = 13;
    int size = 256;
    int threads = 0;
    std::string work;
    std::string json;
    bool quiet = false;
};

// Views per second end to end (read, fit, scene, render, label, encode, write), one fit per photograph.
void run_profile_bench(const ProfileBenchArgs& b) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const fs::path work = b.work.empty() ? fs::temp_directory_path() / ("facesynth-bench-profile-" + std::to_string(::getpid())) : fs::path(b.work);
    const fs::path photos = work / "photos";
    fs::remove_all(work);
    fs::create_directories(photos);
    std::size_t copied = 0;
    for (const fs::path& photo : train::list_photos(b.photos)) {
        const fs::path pts = fs::path(photo).replace_extension(".pts");
        if (!fs::exists(pts)) continue;
        fs::copy_file(photo, photos / photo.filename());
        fs::copy_file(pts, photos / pts.filename());
        if (++copied == b.max_photos) break;
    }
    if (copied == 0) throw core::file_error(b.photos, "no photograph with a .pts beside it");
    profile::ProfileRunOptions options;
    options.photos = photos;
    options.out = work / "out";
    options.plan.views_per_photo = b.views_per_photo;
    options.profile.size = b.size;
    options.threads = b.threads > 0 ? b.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    const profile::ProfileRunResult r = profile::run_profile(options, model);
    if (b.work.empty()) fs::remove_all(work);
    if (!r.failures.empty()) throw core::Error("bench profile: " + r.failures.front().message);
    const double views = static_cast<double>(std::max<std::size_t>(r.views_written, 1));
    nlohmann::json j = {{"photos", copied},
                        {"views", r.views_written},
                        {"size", b.size},
                        {"threads", options.threads},
                        {"seconds", r.seconds},
                        {"views_per_s", static_cast<double>(r.views_written) / std::max(r.seconds, 1e-9)},
                        {"prepare_ms_per_photo", 1e3 * r.prepare_seconds / static_cast<double>(copied)},
                        {"render_ms_per_view", 1e3 * r.render_seconds / views},
                        {"write_ms_per_view", 1e3 * r.write_seconds / views}};
    if (!b.quiet)
        std::printf("bench profile: %zu views of %zu photographs at %d² on %d thread(s): %.1f views/s; per photograph fit and scene %.1f ms, "
                    "per view render and labels %.1f ms, encode and write %.1f ms (thread times)\n",
                    r.views_written, copied, b.size, options.threads, j["views_per_s"].get<double>(), j["prepare_ms_per_photo"].get<double>(),
                    j["render_ms_per_view"].get<double>(), j["write_ms_per_view"].get<double>());
    if (!b.json.empty()) write_json_file(b.json, j);
}

}  // namespace

void register_profile_commands(CLI::App& app) {
    auto a = std::make_shared<ProfileArgs>();
    CLI::App* cmd = app.add_subcommand("profile", "Re-render annotated photographs at new head poses with exact landmarks (face profiling, 300W-LP style)");
    cmd->add_option("--photos", a->photos, "folder of photographs, each with its 68-point .pts (photographs without one are detected)")->required();
    cmd->add_option("--out,-o", a->out, "output dataset folder (synth's folder layout)")->required();
    cmd->add_option("--config,-c", a->config, "TOML file of settings (docs/profile.md lists the keys); options given here override it")
        ->check(CLI::ExistingFile);
    cmd->add_option("--model,-m", a->model, "model: builtin, a model file or a model folder");
    cmd->add_option("--yaws", a->yaws, "the views' yaws, first:last:step or a,b,c (degrees; default -90:90:15)");
    cmd->add_option("--views-per-photo", a->views_per_photo, "instead of --yaws: this many views per photograph at random yaws")->check(CLI::Range(1, 1000));
    cmd->add_option("--yaw-limit", a->yaw_limit, "random yaws lie in [-limit, limit]")->check(finite_range(0, 180));
    cmd->add_flag("--both-ways", a->both_ways, "random yaws on both sides of the photograph's (default: only further toward profile, as 300W-LP)");
    cmd->add_option("--max-turn", a->max_turn, "no view turns the face more than this from its yaw in the photograph (degrees)")->check(finite_range(0, 360));
    cmd->add_option("--pitch-jitter", a->pitch_jitter, "standard deviation of a random change of pitch per view (degrees)")->check(finite_range(0, 45));
    cmd->add_option("--relight", a->relight, "a lighting change per view: a directional light of strength up to this (0-0.9; 0 keeps the photograph's)")
        ->check(finite_range(0, 0.9));
    cmd->add_option("--seed", a->seed, "seed of the random yaws and pitches (view i depends on seed and i only)");
    cmd->add_option("--size", a->size, "view side, px")->check(CLI::Range(16, 4096));
    cmd->add_option("--crop-margin", a->crop_margin, "the view shows this many times the landmarks' box")->check(finite_range(1, 8));
    cmd->add_option("--isomap-size", a->isomap_size, "face texture side, texels")->check(CLI::Range(64, 4096));
    cmd->add_option("--jaw", a->jaw, "jaw landmarks in the .pts: contour (on the silhouette, as annotated) or fixed")->check(CLI::IsMember({"contour", "fixed"}));
    cmd->add_option("--image-format", a->image_format, "png or jpg")->check(CLI::IsMember({"png", "jpg"}));
    cmd->add_option("--formats", a->formats, "also write: wds (WebDataset tars of whole photographs' views), coco (coco.json); the folder is always written");
    cmd->add_flag("--no-residual", a->no_residual, "landmarks of the fitted model only, without the annotation's residual to the fit");
    cmd->add_option("--threads,-j", a->threads, "worker threads (default: all cores)")->check(CLI::Range(1, 256));
    cmd->add_option("--shard", a->shard, "K/N (0-based; photographs are shared out whole) or auto");
    cmd->add_option("--shard-count", a->shard_count, "total shards for --shard auto");
    cmd->add_flag("--overwrite", a->overwrite, "replace a profiled dataset made with other settings in --out");
    cmd->add_option("--regressor", a->regressor, "landmarks for photographs without a .pts: dlib or a regressor file");
    add_detector_option(*cmd, a->detector);
    cmd->add_option("--json", a->json, "write the run's figures as flat JSON to this file");
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
    a->command = cmd;
    cmd->callback([a] { run_profile_command(*a); });

    auto b = std::make_shared<ProfileBenchArgs>();
    CLI::App* bench = bench_group(app).add_subcommand("profile", "Face profiling speed: views per second end to end, one fit per photograph");
    bench->add_option("--photos", b->photos, "folder of photographs with .pts (the first --max-photos are used)")->required()->check(CLI::ExistingDirectory);
    bench->add_option("--max-photos", b->max_photos, "photographs to profile")->check(CLI::Range(1, 100000));
    bench->add_option("--views-per-photo", b->views_per_photo, "views per photograph")->check(CLI::Range(1, 1000));
    bench->add_option("--size", b->size, "view side, px")->check(CLI::Range(16, 4096));
    bench->add_option("--threads,-j", b->threads, "worker threads (default: all cores)")->check(CLI::Range(1, 256));
    bench->add_option("--work", b->work, "folder for the copied photographs and the views (default: a temporary folder, removed)");
    bench->add_option("--json", b->json, "write the figures as flat JSON to this file");
    bench->add_flag("-q,--quiet", b->quiet, "no summary line");
    bench->callback([b] { run_profile_bench(*b); });
}

}  // namespace facesynth::cli
