// End-to-end tests of `facesynth synth`: byte-identical outputs whatever the threads and shards,
// resume after 20 SIGKILLs and after a full disk (RLIMIT_FSIZE), refusing a folder made with another
// config, WebDataset tars and COCO JSON.
// They run the real CLI on the toy model (written to a .fsm file) at 64x64.
#include "common/test_data.h"
#include "common/toy_model.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "morph/regions.h"
#include "synth/dataset.h"
#include "synth/scene.h"
#include "synth/tar.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <map>
#include <set>
#include <sys/resource.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace facesynth::synth {
namespace {

namespace fs = std::filesystem;

const fs::path& toy_model_file() {
    static const fs::path path = [] {
        // One folder per test process: ctest runs the cases of this file in parallel processes,
        // and a shared folder would be wiped by one while another reads its model.
        const auto dir = testkit::fresh_temp_dir("synth_toy_model_" + std::to_string(::getpid()));
        morph::write_model(testkit::make_toy_model(), dir / "toy.fsm");
        return dir / "toy.fsm";
    }();
    return path;
}

// The toy model with region labels: hair above y = 60 mm, the rest skin.
const fs::path& labelled_toy_model_file() {
    static const fs::path path = [] {
        const auto dir = testkit::fresh_temp_dir("synth_labelled_toy_model");
        morph::MorphableModel toy = testkit::make_toy_model();
        const auto mean = morph::as_points(toy.shape.mean);
        for (int v = 0; v < toy.num_vertices(); ++v)
            toy.vertex_labels.push_back(static_cast<std::uint8_t>(mean(1, v) > 60.0f ? morph::Region::kHair : morph::Region::kSkin));
        morph::write_model(toy, dir / "toy.fsm");
        return dir / "toy.fsm";
    }();
    return path;
}

std::string base_args(int count, int size = 64) {
    return " --model " + toy_model_file().string() + " -n " + std::to_string(count) + " --size " + std::to_string(size) +
           " --seed 5 --format folder,wds,coco --set output.wds_shard_size=5 --quiet";
}

int synth(const std::string& args, std::string* output = nullptr) {
    return testkit::run_command(testkit::cli_path().string() + " synth" + args, output);
}

// Every file under `dir` (relative path -> contents), except per-shard manifests and COCO files.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        if (!entry.is_regular_file()) continue;
        const std::string name = entry.path().filename().string();
        if (name.find("-of-") != std::string::npos) continue;
        files[fs::relative(entry.path(), dir).string()] = core::read_file(entry.path());
    }
    return files;
}

int count_files(const fs::path& dir) {
    std::error_code error;
    int n = 0;
    for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) n += it->path().extension() == ".json";
    return n;
}

void expect_same_files(const std::map<std::string, std::string>& a, const std::map<std::string, std::string>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [name, contents] : a) {
        ASSERT_TRUE(b.count(name)) << name;
        EXPECT_TRUE(b.at(name) == contents) << name << " differs";
    }
}

TEST(SynthCli, OutputsAreIdenticalWhateverThreadsAndShards) {
    const auto dir = testkit::fresh_temp_dir("synth_determinism");
    std::string log;
    const std::string args = base_args(12) + " --set output.labels=true";
    ASSERT_EQ(synth(" -o " + (dir / "one").string() + args + " --threads 1", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "two").string() + args + " --threads 2", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "sharded").string() + args + " --threads 1 --shard 1/2", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "sharded").string() + args + " --threads 2 --shard 0/2", &log), 0) << log;
    ASSERT_EQ(synth(" merge " + (dir / "sharded").string() + " --quiet", &log), 0) << log;

    const auto one = snapshot(dir / "one");
    EXPECT_EQ(one.count("images/s00000011.png"), 1u);
    EXPECT_EQ(one.count("landmarks/s00000011.pts"), 1u);
    EXPECT_EQ(one.count("meta/s00000011.json"), 1u);
    EXPECT_EQ(one.count("labels/s00000011.png"), 1u);
    EXPECT_EQ(one.count("shard-000002.tar"), 1u);
    EXPECT_EQ(one.count("manifest.jsonl"), 1u);
    EXPECT_EQ(one.count("coco.json"), 1u);
    expect_same_files(one, snapshot(dir / "two"));
    expect_same_files(one, snapshot(dir / "sharded"));
}

// background.type = "wallpapers": Debian's wallpaper photographs behind the face, the same bytes with
// one thread or two.
TEST(SynthCli, WallpaperBackgroundsAreDeterministicPhotographs) {
    const auto dir = testkit::fresh_temp_dir("synth_wallpapers");
    std::string log;
    const std::string args = base_args(6, 96) + " --set background.type=wallpapers";
    ASSERT_EQ(synth(args + " --threads 1 --out " + (dir / "a").string(), &log), 0) << log;
    ASSERT_EQ(synth(args + " --threads 2 --out " + (dir / "b").string(), &log), 0) << log;
    expect_same_files(snapshot(dir / "a" / "images"), snapshot(dir / "b" / "images"));
    const auto meta = testkit::read_json(dir / "a" / "meta" / "s00000000.json");
    EXPECT_EQ(meta["background"]["type"], "wallpapers");
    // A corner behind the face is a picture, not a flat colour.
    const cv::Mat image = cv::imread((dir / "a" / "images" / "s00000000.png").string());
    ASSERT_FALSE(image.empty());
    cv::Scalar mean, stddev;
    cv::meanStdDev(image(cv::Rect(0, 0, 24, 24)), mean, stddev);
    EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 1.0);
}

// head.body on the built-in model: the same bytes with one thread, two, or two shards; the parts worn
// recorded in the meta; the new region ids in the label maps.
TEST(SynthCli, HeadPartsAreDeterministicAndRecorded) {
    const auto dir = testkit::fresh_temp_dir("synth_head_parts");
    std::string log;
    const std::string args = " --model builtin -n 6 --size 96 --seed 4 --quiet --set head.body=true --set output.labels=true";
    ASSERT_EQ(synth(args + " --threads 1 --out " + (dir / "a").string(), &log), 0) << log;
    ASSERT_EQ(synth(args + " --threads 2 --out " + (dir / "b").string(), &log), 0) << log;
    ASSERT_EQ(synth(args + " --threads 1 --shard 1/2 --out " + (dir / "c").string(), &log), 0) << log;
    ASSERT_EQ(synth(args + " --threads 2 --shard 0/2 --out " + (dir / "c").string(), &log), 0) << log;
    ASSERT_EQ(synth(" merge " + (dir / "c").string() + " --quiet", &log), 0) << log;
    const auto a = snapshot(dir / "a");
    expect_same_files(a, snapshot(dir / "b"));
    expect_same_files(a, snapshot(dir / "c"));
    int clothing_pixels = 0;
    for (int i = 0; i < 6; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        const auto meta = testkit::read_json(dir / "a" / "meta" / (key + ".json"));
        ASSERT_TRUE(meta["head_parts"].is_object()) << key;
        EXPECT_TRUE(meta["head_parts"]["clothing"].is_string()) << key;
        EXPECT_TRUE(meta["head_parts"]["hair"].is_string() || meta["head_parts"]["hair"].is_null()) << key;
        EXPECT_EQ(meta["head_parts"]["torso"].size(), 3u) << key;
        const cv::Mat labels = cv::imread((dir / "a" / "labels" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        ASSERT_FALSE(labels.empty()) << key;
        clothing_pixels += cv::countNonZero(labels == static_cast<std::uint8_t>(morph::Region::kClothing));
    }
    EXPECT_GT(clothing_pixels, 600);
}

TEST(SynthCli, MetaCarriesGroundTruthConsistentWithPts) {
    const auto dir = testkit::fresh_temp_dir("synth_meta");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(3) + " --threads 1", &log), 0) << log;
    const auto meta = nlohmann::json::parse(core::read_file(dir / "meta" / "s00000001.json"));
    for (const char* key : {"key", "index", "seed", "model_name", "model_checksum", "alpha", "psi", "beta", "albedo_redraws", "albedo_shrink", "rotation", "yaw", "pitch", "roll",
                            "translation", "intrinsics", "image_width", "image_height", "lighting", "background", "landmark_mode",
                            "landmarks", "visibility", "landmarks_fixed", "landmarks_contour", "landmarks_3d_fixed", "bbox"})
        EXPECT_TRUE(meta.contains(key)) << key;
    EXPECT_EQ(meta["index"], 1);
    EXPECT_EQ(meta["landmarks"].size(), 68u);
    const auto pts = morph::read_pts(dir / "landmarks" / "s00000001.pts");
    ASSERT_EQ(pts.cols(), 68);
    for (int i = 0; i < 68; ++i) {
        EXPECT_NEAR(pts(0, i), meta["landmarks"][static_cast<std::size_t>(i)][0].get<double>(), 1e-3);
        EXPECT_NEAR(pts(1, i), meta["landmarks"][static_cast<std::size_t>(i)][1].get<double>(), 1e-3);
    }
    const auto manifest = core::read_file(dir / "manifest.jsonl");
    EXPECT_EQ(std::count(manifest.begin(), manifest.end(), '\n'), 3);
}

// Meta files are written as text directly (no object tree); they must stay exactly what nlohmann's
// compact dump() of their content writes: keys sorted, its number format, no spaces. Occluders and a
// texture-free toy model give every key content (occluders, skin_tone, null texture).
TEST(SynthCli, MetaFilesAreNlohmannsCompactDumpOfTheirContent) {
    const auto dir = testkit::fresh_temp_dir("synth_meta_text");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(4) + " --threads 1 --set occluders.probability=1", &log), 0) << log;
    for (int i = 0; i < 4; ++i) {
        const std::string text = core::read_file(dir / "meta" / (sample_key(i) + ".json"));
        const auto meta = nlohmann::json::parse(text);
        EXPECT_EQ(meta.dump() + "\n", text) << sample_key(i);
        EXPECT_FALSE(meta["occluders"].empty()) << sample_key(i);
        EXPECT_EQ(meta.size(), 40u) << sample_key(i);  // the keys listed in docs/synth.md (landmarks_3d_even: the default even jaw)
        EXPECT_TRUE(meta["sequence"].is_null());
    }
    // In clips, `sequence` is an object.
    const auto clips = testkit::fresh_temp_dir("synth_meta_text_clips");
    ASSERT_EQ(synth(" -o " + clips.string() + base_args(4) + " --threads 1 --sequence 3", &log), 0) << log;
    for (int i = 0; i < 4; ++i) {
        const std::string text = core::read_file(clips / "meta" / (sample_key(i) + ".json"));
        const auto meta = nlohmann::json::parse(text);
        EXPECT_EQ(meta.dump() + "\n", text) << sample_key(i);
        EXPECT_EQ(meta["sequence"]["clip"], i / 3);
        EXPECT_EQ(meta["sequence"]["frame"], i % 3);
    }
}

TEST(SynthCli, ShadowProbabilityShadowsTheSamplesWithLightsAndRecordsIt) {
    const auto plain = testkit::fresh_temp_dir("synth_shadows_off"), shadowed = testkit::fresh_temp_dir("synth_shadows_on");
    const std::string args = " --model " + toy_model_file().string() + " -n 8 --size 96 --seed 3 --threads 1 --quiet" +
                             " --set lighting.directional_max=2 --set lighting.intensity_min=0.6 --set lighting.intensity_max=0.9" +
                             " --set render.shadow_map_size=512";
    std::string log;
    ASSERT_EQ(synth(" -o " + plain.string() + args, &log), 0) << log;
    ASSERT_EQ(synth(" -o " + shadowed.string() + args + " --set lighting.shadow_probability=1", &log), 0) << log;
    const auto config = nlohmann::json::parse(core::read_file(shadowed / "dataset.json"));
    EXPECT_EQ(config["config"]["lighting"]["shadow_probability"], 1.0) << config.dump();
    int with_lights = 0, changed = 0;
    for (int i = 0; i < 8; ++i) {
        const std::string key = sample_key(i);
        const auto meta = nlohmann::json::parse(core::read_file(shadowed / "meta" / (key + ".json")));
        const auto plain_meta = nlohmann::json::parse(core::read_file(plain / "meta" / (key + ".json")));
        const bool lights = !meta["lighting"]["lights"].empty();
        EXPECT_EQ(meta["lighting"]["shadows"], lights) << key;
        EXPECT_EQ(plain_meta["lighting"]["shadows"], false) << key;
        const bool same_image = core::read_file(shadowed / "images" / (key + ".png")) == core::read_file(plain / "images" / (key + ".png"));
        if (!lights) {
            EXPECT_TRUE(same_image) << key << ": no directional light, nothing to shadow";
        }
        with_lights += lights ? 1 : 0;
        changed += same_image ? 0 : 1;
    }
    EXPECT_GT(with_lights, 0);
    EXPECT_GT(changed, 0);  // the toy's nose shadows its face under some of the lights
}

// Starts `facesynth<args>` in a child process (output discarded) and returns its pid.
pid_t spawn_cli(const std::string& args) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::execl("/bin/sh", "sh", "-c", ("exec " + testkit::cli_path().string() + args + " >/dev/null 2>&1").c_str(), nullptr);
        ::_exit(127);
    }
    return pid;
}

void expect_no_temporary_files(const fs::path& dir) {
    for (const auto& entry : fs::recursive_directory_iterator(dir))
        EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
}

TEST(SynthCli, ResumesAfterTwentySigkillsWithoutPartialOrDuplicateFiles) {
    const auto dir = testkit::fresh_temp_dir("synth_resume");
    const int count = 80;
    std::string log;
    const std::string common = base_args(count, 32) + " --threads 2";
    ASSERT_EQ(synth(" -o " + (dir / "clean").string() + common, &log), 0) << log;
    const fs::path out = dir / "killed";
    const std::string args = " synth -o " + out.string() + common;
    core::Rng rng(2024, 0, 0);
    int kills = 0, killed_mid_run = 0;
    for (int attempt = 0; attempt < 60 && kills < 20; ++attempt) {
        const pid_t pid = spawn_cli(args);
        ASSERT_GE(pid, 0);
        // Kill once 0-1 more samples exist than before (so the kill lands mid-run on any machine
        // speed, in startup, cleanup or writing), after a further random 0-4 ms.
        const int target = count_files(out / "meta") + rng.uniform_int(0, 1);
        int status = 0;
        bool exited = false;
        while (!exited && count_files(out / "meta") < target) {
            exited = ::waitpid(pid, &status, WNOHANG) == pid;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(rng.uniform_int(0, 4)));
        if (!exited && ::waitpid(pid, &status, WNOHANG) == 0) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            ++kills;
            killed_mid_run += count_files(out / "meta") < count;
        }
        if (count_files(out / "meta") >= count) break;
    }
    EXPECT_GE(kills, 20);
    EXPECT_GE(killed_mid_run, 15);
    ASSERT_EQ(testkit::run_command(testkit::cli_path().string() + args, &log), 0) << log;
    expect_no_temporary_files(out);
    expect_same_files(snapshot(dir / "clean"), snapshot(out));
}

// Runs `facesynth synth<args>` with no file allowed to grow past `limit` bytes (RLIMIT_FSIZE) and
// SIGXFSZ ignored, so that writes past it fail with EFBIG as they would on a full disk.
int synth_with_file_size_limit(const std::string& args, rlim_t limit, std::string* output) {
    const fs::path log = testkit::fresh_temp_dir("synth_fsize_log") / "log.txt";
    const pid_t pid = ::fork();
    if (pid == 0) {
        const rlimit fsize{limit, limit};
        ::setrlimit(RLIMIT_FSIZE, &fsize);
        ::signal(SIGXFSZ, SIG_IGN);
        ::execl("/bin/sh", "sh", "-c", ("exec " + testkit::cli_path().string() + " synth" + args + " >" + log.string() + " 2>&1").c_str(), nullptr);
        ::_exit(127);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    *output = core::read_file(log);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(SynthCli, DiskFullStopsWithAClearErrorKeepsFinishedSamplesAndResumes) {
    const auto dir = testkit::fresh_temp_dir("synth_disk_full");
    const int count = 24;
    // WebDataset tars of 6 samples outgrow the limit while every per-sample file fits, so the
    // first tar fails after its 6 samples are written.
    const std::string common = base_args(count, 32) + " --threads 1 --set output.wds_shard_size=6";
    std::string log;
    ASSERT_EQ(synth(" -o " + (dir / "clean").string() + common, &log), 0) << log;
    const auto clean = snapshot(dir / "clean");
    std::size_t largest_sample_file = 0;
    for (const auto& [name, contents] : clean)
        if (!name.ends_with(".tar") && name != "coco.json" && !name.starts_with("manifest"))
            largest_sample_file = std::max(largest_sample_file, contents.size());
    const std::size_t tar_size = clean.at("shard-000000.tar").size();
    const std::size_t limit = std::max(largest_sample_file + 1024, tar_size / 2);
    ASSERT_LT(limit, tar_size);

    const fs::path out = dir / "full";
    EXPECT_EQ(synth_with_file_size_limit(" -o " + out.string() + common, limit, &log), 1) << log;
    EXPECT_NE(log.find("facesynth: error: "), std::string::npos) << log;
    EXPECT_NE(log.find("shard-000000.tar"), std::string::npos) << log;
    EXPECT_EQ(log.find("internal error"), std::string::npos) << log;
    // Every sample the manifest lists is complete and identical to the clean run's.
    const auto manifest = core::read_file(out / "manifest.jsonl");
    const auto finished = std::count(manifest.begin(), manifest.end(), '\n');
    EXPECT_GT(finished, 0);
    EXPECT_LT(finished, count);
    for (const auto& [name, contents] : snapshot(out)) {
        if (name.ends_with(".tar") || name.starts_with("manifest") || name.find(".tmp.") != std::string::npos) continue;
        ASSERT_TRUE(clean.count(name)) << name;
        EXPECT_TRUE(clean.at(name) == contents) << name << " differs from the uninterrupted run";
    }
    // Space is back: the run completes, byte-identical to the uninterrupted one.
    ASSERT_EQ(synth(" -o " + out.string() + common, &log), 0) << log;
    expect_no_temporary_files(out);
    expect_same_files(clean, snapshot(out));
}

TEST(SynthCli, RefusesAFolderMadeWithAnotherConfigUnlessOverwrite) {
    const auto dir = testkit::fresh_temp_dir("synth_refuse");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(2), &log), 0) << log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(2) + " --set pose.yaw.max=10", &log), 1);
    EXPECT_NE(log.find("different config"), std::string::npos) << log;
    EXPECT_NE(log.find("pose/yaw/max"), std::string::npos) << log;
    // A larger count extends the same dataset.
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(3), &log), 0) << log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(2) + " --set pose.yaw.max=10 --overwrite", &log), 0) << log;
    EXPECT_FALSE(fs::exists(dir / "meta" / "s00000002.json"));
}

// A setting only the workers can check (a missing background folder, an unknown hair style) fails the
// run before the output folder is touched: no empty dataset, and --overwrite removes no earlier one.
TEST(SynthCli, ASettingTheWorkersRefuseLeavesNoEmptyDataset) {
    const auto dir = testkit::fresh_temp_dir("synth_worker_error");
    std::string log;
    EXPECT_EQ(synth(" -o " + (dir / "a").string() + base_args(1) + " --set background.type=images --set background.folder=" +
                        (dir / "none").string(), &log), 1);
    EXPECT_NE(log.find((dir / "none").string()), std::string::npos) << log;
    EXPECT_FALSE(std::filesystem::exists(dir / "a"));
    EXPECT_EQ(synth(" -o " + (dir / "b").string() + " -n 1 --size 64 --quiet --set head.body=true --set head.hair_styles=bob1", &log), 1);
    EXPECT_NE(log.find("head.hair_styles: no hair style 'bob1'"), std::string::npos) << log;
    EXPECT_FALSE(std::filesystem::exists(dir / "b"));
    ASSERT_EQ(synth(" -o " + (dir / "c").string() + base_args(1), &log), 0) << log;
    const auto before = std::distance(std::filesystem::recursive_directory_iterator(dir / "c"), {});
    EXPECT_EQ(synth(" -o " + (dir / "c").string() + base_args(1) + " --set background.type=images --set background.folder=" +
                        (dir / "none").string() + " --overwrite", &log), 1);
    EXPECT_EQ(std::distance(std::filesystem::recursive_directory_iterator(dir / "c"), {}), before);
}

TEST(SynthCli, UnknownConfigKeyIsAnErrorNamingIt) {
    const auto dir = testkit::fresh_temp_dir("synth_unknown_key");
    std::string log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(1) + " --set pose.yaww.max=3", &log), 1);
    EXPECT_NE(log.find("unknown config key 'pose.yaww.max'"), std::string::npos) << log;
    core::write_file_atomically(dir / "c.toml", "[lighting]\nshadowz = true\n");
    EXPECT_EQ(synth(" -o " + (dir / "out").string() + base_args(1) + " -c " + (dir / "c.toml").string(), &log), 1);
    EXPECT_NE(log.find("lighting.shadowz"), std::string::npos) << log;
    EXPECT_NE(log.find("c.toml"), std::string::npos) << log;
    EXPECT_EQ(synth(" --count 2", &log), 2) << log;  // no --out: usage error
}

TEST(SynthCli, WebDatasetTarsHoldEachSampleInOrder) {
    const auto dir = testkit::fresh_temp_dir("synth_wds");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(7) + " --format wds", &log), 0) << log;
    EXPECT_FALSE(fs::exists(dir / "images"));  // wds only: per-sample files are not kept
    const auto first = list_tar(dir / "shard-000000.tar");
    ASSERT_EQ(first.size(), 15u);
    EXPECT_EQ(first[0].name, "s00000000.png");
    EXPECT_EQ(first[1].name, "s00000000.pts");
    EXPECT_EQ(first[2].name, "s00000000.json");
    EXPECT_EQ(first[14].name, "s00000004.json");
    for (const auto& entry : first) EXPECT_GT(entry.size, 0u);
    EXPECT_EQ(list_tar(dir / "shard-000001.tar").size(), 6u);
}

TEST(SynthCli, LabelMapsHoldTheModelsRegionIds) {
    const auto dir = testkit::fresh_temp_dir("synth_labels");
    std::string log;
    const std::string args = " --model " + labelled_toy_model_file().string() +
                             " -n 4 --size 64 --seed 5 --format folder,wds --set output.labels=true --set output.mask=true"
                             " --set render.antialiasing=none --quiet";
    ASSERT_EQ(synth(" -o " + dir.string() + args, &log), 0) << log;
    for (int i = 0; i < 4; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        const cv::Mat labels = cv::imread((dir / "labels" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        const cv::Mat mask = cv::imread((dir / "mask" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        ASSERT_EQ(labels.type(), CV_8UC1) << key;
        ASSERT_EQ(labels.size(), mask.size()) << key;
        int skin = 0, hair = 0;
        for (int y = 0; y < labels.rows; ++y)
            for (int x = 0; x < labels.cols; ++x) {
                const int id = labels.at<std::uint8_t>(y, x);
                ASSERT_TRUE(id == 0 || id == static_cast<int>(morph::Region::kSkin) || id == static_cast<int>(morph::Region::kHair)) << key << " id " << id;
                EXPECT_EQ(id != 0, mask.at<std::uint8_t>(y, x) != 0) << key << " at " << x << "," << y;  // no MSAA: same coverage
                skin += id == static_cast<int>(morph::Region::kSkin);
                hair += id == static_cast<int>(morph::Region::kHair);
            }
        EXPECT_GT(skin, 100) << key;
        EXPECT_GT(hair, 0) << key;  // the top of the toy head shows at every pose
    }
    const auto members = list_tar(dir / "shard-000000.tar");
    EXPECT_TRUE(std::any_of(members.begin(), members.end(), [](const TarEntry& e) { return e.name == "s00000003.labels.png"; }));
}

TEST(SynthCli, UvTexturesComeFromTheFolderSkippingUnreadableOnes) {
    const auto dir = testkit::fresh_temp_dir("synth_textures");
    const fs::path textures = dir / "textures";
    fs::create_directories(textures);
    // Pure red, green and blue maps (BGR on disk), and a file that is no image.
    const std::map<std::string, cv::Scalar> maps = {{"red.png", {0, 0, 255}}, {"green.png", {0, 255, 0}}, {"blue.png", {255, 0, 0}}};
    for (const auto& [name, bgr] : maps) ASSERT_TRUE(cv::imwrite((textures / name).string(), cv::Mat(32, 32, CV_8UC3, bgr)));
    core::write_file_atomically(textures / "broken.png", "not a png");
    std::string log;
    const std::string args = base_args(6) + " --format folder --set output.mask=true --set albedo.texture_folder=" + textures.string();
    ASSERT_EQ(synth(" -o " + (dir / "out").string() + args, &log), 0) << log;
    EXPECT_NE(log.find("broken.png"), std::string::npos) << log;  // the warning names the skipped file
    std::set<std::string> used;
    for (int i = 0; i < 6; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        const auto meta = testkit::read_json(dir / "out" / "meta" / (key + ".json"));
        ASSERT_TRUE(meta["texture"].is_string()) << key;
        const std::string name = meta["texture"];
        ASSERT_TRUE(maps.count(name)) << key << " " << name;
        used.insert(name);
        // The face takes the map's colour: its channel dominates the covered pixels.
        const cv::Mat image = cv::imread((dir / "out" / "images" / (key + ".png")).string(), cv::IMREAD_COLOR);
        const cv::Mat mask = cv::imread((dir / "out" / "mask" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        const cv::Scalar mean = cv::mean(image, mask == 255);
        int channel = 0;
        for (int c = 1; c < 3; ++c)
            if (mean[c] > mean[channel]) channel = c;
        const int expected = name == "blue.png" ? 0 : (name == "green.png" ? 1 : 2);
        EXPECT_EQ(channel, expected) << key << " " << name << " mean BGR " << mean;
    }
    EXPECT_GE(used.size(), 2u);  // the choice varies with the index
    // The same run again picks the same maps (sample i depends only on (seed, i)).
    ASSERT_EQ(synth(" -o " + (dir / "again").string() + args, &log), 0) << log;
    for (int i = 0; i < 6; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        EXPECT_EQ(testkit::read_json(dir / "again" / "meta" / (key + ".json"))["texture"],
                  testkit::read_json(dir / "out" / "meta" / (key + ".json"))["texture"]) << key;
    }
    // A folder with no readable image is an error naming it.
    fs::create_directories(dir / "empty");
    core::write_file_atomically(dir / "empty" / "broken.png", "not a png");
    EXPECT_EQ(synth(" -o " + (dir / "none").string() + base_args(1) + " --set albedo.texture_folder=" + (dir / "empty").string(), &log), 1);
    EXPECT_NE(log.find((dir / "empty").string()), std::string::npos) << log;
    EXPECT_NE(log.find("no readable texture images"), std::string::npos) << log;
}

TEST(SynthCli, CocoKeypointsHaveTheExpectedStructure) {
    const auto dir = testkit::fresh_temp_dir("synth_coco");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(4) + " --format coco --set pose.yaw.distribution=uniform --set pose.yaw.min=60 --set pose.yaw.max=80", &log), 0) << log;
    const auto coco = nlohmann::json::parse(core::read_file(dir / "coco.json"));
    ASSERT_EQ(coco["images"].size(), 4u);
    ASSERT_EQ(coco["annotations"].size(), 4u);
    ASSERT_EQ(coco["categories"].size(), 1u);
    EXPECT_EQ(coco["categories"][0]["keypoints"].size(), 68u);
    EXPECT_GT(coco["categories"][0]["skeleton"].size(), 60u);
    int hidden = 0;
    for (const auto& annotation : coco["annotations"]) {
        ASSERT_EQ(annotation["keypoints"].size(), 3u * 68u);
        EXPECT_EQ(annotation["bbox"].size(), 4u);
        EXPECT_GT(annotation["bbox"][2].get<double>(), 5.0);
        for (std::size_t k = 2; k < annotation["keypoints"].size(); k += 3) {
            const int v = annotation["keypoints"][k];
            EXPECT_TRUE(v == 0 || v == 1 || v == 2);
            hidden += v == 1;
        }
        const std::string file = coco["images"][annotation["image_id"].get<std::size_t>() - 1]["file_name"];
        EXPECT_TRUE(fs::exists(dir / file)) << file;
    }
    EXPECT_GT(hidden, 0);  // at yaw 60-80 some landmarks are self-occluded
}

TEST(SynthCli, CocoExportNamesADamagedMetaFile) {
    const auto dir = testkit::fresh_temp_dir("synth_coco_bad_meta");
    fs::create_directories(dir / "meta");
    for (const std::string text : {"[]", R"({"image_width": 1e300, "image_height": 64})",
                                   R"({"image_width": 64, "image_height": 64, "landmarks": [[1, 2]], "visibility": [],
                                       "occluded": [], "bbox": [0, 0, 1, 1]})",
                                   R"({"image_width": 64, "image_height": 64, "landmarks": "x", "visibility": [], "occluded": [], "bbox": []})"}) {
        core::write_file_atomically(dir / "meta" / "s00000000.json", text);
        try {
            (void)coco_from_meta(dir, {0}, ".png", kSynthCocoDescription);
            ADD_FAILURE() << "accepted " << text;
        } catch (const core::Error& e) {
            EXPECT_NE(std::string(e.what()).find("s00000000.json"), std::string::npos) << e.what();
        }
    }
}

// Reading dataset folders written (and perhaps damaged) by others: `synth sheet` and `synth merge`
// answer every damaged file with one error line naming it, exit 1, and leave no output.

// A 3-sample folder+COCO dataset, made once per test process; each case damages a copy.
fs::path damaged_copy(const std::string& name) {
    static const fs::path original = [] {
        const auto dir = testkit::fresh_temp_dir("synth_damage_original_" + std::to_string(::getpid()));
        std::string log;
        EXPECT_EQ(synth(" -o " + dir.string() + " --model " + toy_model_file().string() +
                            " -n 3 --size 48 --seed 5 --format folder,coco --quiet",
                        &log),
                  0)
            << log;
        return dir;
    }();
    const auto copy = testkit::fresh_temp_dir(name);
    fs::copy(original, copy, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    return copy;
}

// Runs the command; expects exit 1 with one `facesynth: error:` line that names `file`.
void expect_error_naming(const std::string& args, const fs::path& file, const std::string& problem) {
    std::string log;
    EXPECT_EQ(synth(args, &log), 1) << args << "\n" << log;
    EXPECT_NE(log.find("facesynth: error: "), std::string::npos) << log;
    EXPECT_EQ(log.find("internal error"), std::string::npos) << log;
    EXPECT_NE(log.find(file.string()), std::string::npos) << "does not name " << file << ":\n" << log;
    EXPECT_NE(log.find(problem), std::string::npos) << "does not say '" << problem << "':\n" << log;
}

TEST(SynthDatasetFiles, SheetNamesADamagedMetaFileOrMissingImageAndWritesNothing) {
    const std::string valid = core::read_file(damaged_copy("synth_sheet_valid") / "meta" / "s00000001.json");
    auto with = [&](std::string text, const std::string& from, const std::string& to) {
        text.replace(text.find(from), from.size(), to);
        return text;
    };
    const std::vector<std::pair<std::string, std::string>> cases = {
        {valid.substr(0, valid.size() / 2), "invalid JSON"},                                  // truncated
        {std::string("\x89PNG\r\n\x1a\n\0\0garbage", 16), "invalid JSON"},                // binary garbage
        {"", "invalid JSON"},                                                                  // empty
        {"[1, 2, 3]", "not a facesynth meta file"},                                            // not an object
        {with(valid, "\"landmarks\":", "\"landmarkz\":"), "not a facesynth meta file"},       // missing key
        {with(valid, "\"visibility\":[", "\"visibility\":\"x\",\"unused\":["), "must be arrays of one length"},
        {with(valid, "\"key\":\"s00000001\"", "\"key\":\"s00000002\""), "does not match the file name"},
        {with(valid, "\"key\":\"s00000001\"", "\"key\":7"), "not a facesynth meta file"},
    };
    for (std::size_t c = 0; c < cases.size(); ++c) {
        const auto dir = damaged_copy("synth_sheet_bad_meta");
        const auto meta = dir / "meta" / "s00000001.json";
        core::write_file_atomically(meta, cases[c].first);
        SCOPED_TRACE("case " + std::to_string(c));
        expect_error_naming(" sheet " + dir.string() + " -o " + (dir / "sheet.png").string(), meta, cases[c].second);
        EXPECT_FALSE(fs::exists(dir / "sheet.png"));
    }
    // A meta file whose landmark lists differ in length (read past the end before).
    {
        const auto dir = damaged_copy("synth_sheet_short_visibility");
        auto meta = nlohmann::json::parse(valid);
        meta["visibility"] = nlohmann::json::array({1});
        core::write_file_atomically(dir / "meta" / "s00000001.json", meta.dump());
        expect_error_naming(" sheet " + dir.string() + " -o " + (dir / "sheet.png").string(), dir / "meta" / "s00000001.json",
                            "must be arrays of one length");
    }
    // The image a meta file names is missing, or is not an image.
    {
        const auto dir = damaged_copy("synth_sheet_missing_image");
        fs::remove(dir / "images" / "s00000002.png");
        expect_error_naming(" sheet " + dir.string() + " -o " + (dir / "sheet.png").string(), dir / "images" / "s00000002.png", "missing");
        core::write_file_atomically(dir / "images" / "s00000002.png", "not a PNG");
        expect_error_naming(" sheet " + dir.string() + " -o " + (dir / "sheet.png").string(), dir / "images" / "s00000002.png",
                            "cannot read image");
        EXPECT_FALSE(fs::exists(dir / "sheet.png"));
    }
    // A landmark far outside the image is drawn clamped at the tile's edge: the sheet is written.
    {
        const auto dir = damaged_copy("synth_sheet_far_landmark");
        auto meta = nlohmann::json::parse(valid);
        meta["landmarks"][0] = {1e300, -1e300};
        core::write_file_atomically(dir / "meta" / "s00000001.json", meta.dump());
        std::string log;
        EXPECT_EQ(synth(" sheet " + dir.string() + " --columns 3 -o " + (dir / "sheet.png").string(), &log), 0) << log;
        EXPECT_EQ(cv::imread((dir / "sheet.png").string()).cols, 3 * 160);
    }
}

// `synth sheet --photos`: rows of annotated photographs between the rows of renders, each tile framed on
// its face; photographs without a .pts are left out, a folder with none, or an unreadable one, is named.
TEST(SynthDatasetFiles, SheetPutsAnnotatedPhotographsBetweenTheRenders) {
    const auto dir = damaged_copy("synth_sheet_photos");
    const fs::path photos = testkit::fresh_temp_dir("synth_sheet_photos_folder");
    // A white square "face" on black, its 68 points on the square's border: the face tile shows white.
    cv::Mat photo(300, 400, CV_8UC3, cv::Scalar(0, 0, 0));
    photo(cv::Rect(150, 100, 100, 100)).setTo(cv::Scalar(255, 255, 255));
    Eigen::Matrix2Xd points(2, 68);
    for (int i = 0; i < 68; ++i) points.col(i) << 150 + 100 * (i % 2), 100 + 100.0 * i / 67;
    for (const char* name : {"a", "b"}) {
        cv::imwrite((photos / (std::string(name) + ".png")).string(), photo);
        morph::write_pts(photos / (std::string(name) + ".pts"), points);
    }
    cv::imwrite((photos / "unannotated.png").string(), photo);
    std::string log;
    ASSERT_EQ(synth(" sheet " + dir.string() + " --columns 2 --tile 64 --photos " + photos.string() + " -o " + (dir / "sheet.png").string(), &log), 0)
        << log;
    const cv::Mat sheet = cv::imread((dir / "sheet.png").string());
    // 3 renders on 2 columns: render rows 0 and 2, the 2 photographs in row 1.
    ASSERT_EQ(sheet.cols, 2 * 64);
    ASSERT_EQ(sheet.rows, 3 * 64);
    for (const int column : {0, 1}) {
        const cv::Scalar face = cv::mean(sheet(cv::Rect(column * 64 + 24, 64 + 24, 16, 16)));  // the tile's centre: the face
        const cv::Scalar corner = cv::mean(sheet(cv::Rect(column * 64, 64, 6, 6)));           // around it: black
        EXPECT_GT(face[1], 200) << column;
        EXPECT_LT(corner[1], 40) << column;
    }
    // Fewer photographs than render rows: the renders after the last photo row follow each other, with
    // no empty rows between them (one photograph, 3 renders on 1 column: render, photo, render, render).
    fs::remove(photos / "b.pts");
    ASSERT_EQ(synth(" sheet " + dir.string() + " --columns 1 --tile 64 --photos " + photos.string() + " -o " + (dir / "sheet.png").string(), &log), 0)
        << log;
    const cv::Mat one_photo = cv::imread((dir / "sheet.png").string());
    ASSERT_EQ(one_photo.rows, 4 * 64);
    for (const int row : {0, 2, 3}) {  // renders: a face tile is never the sheet's flat background
        cv::Scalar mean, stddev;
        cv::meanStdDev(one_photo(cv::Rect(0, row * 64, 64, 64)), mean, stddev);
        EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 10.0) << "row " << row;
    }
    // No annotated photograph, or an unreadable one: an error naming it, and no sheet.
    fs::remove(dir / "sheet.png");
    const fs::path empty = testkit::fresh_temp_dir("synth_sheet_photos_empty");
    expect_error_naming(" sheet " + dir.string() + " --photos " + empty.string() + " -o " + (dir / "sheet.png").string(), empty,
                        "no photograph with a .pts");
    core::write_file_atomically(photos / "a.png", "not a PNG");
    expect_error_naming(" sheet " + dir.string() + " --photos " + photos.string() + " -o " + (dir / "sheet.png").string(), photos / "a.png",
                        "cannot read image");
    EXPECT_FALSE(fs::exists(dir / "sheet.png"));
}

TEST(SynthDatasetFiles, MergeNamesABadManifestLineAndLeavesTheTargetUntouched) {
    const std::vector<std::pair<std::string, std::string>> lines = {
        {"{\"key\":\"s00000001\"}", "line 2: no integer \"index\" key"},                 // index missing
        {"{\"index\":\"1\",\"key\":\"s00000001\"}", "line 2: no integer \"index\" key"}, // index a string
        {"{\"index\":1.5}", "line 2: no integer \"index\" key"},
        {"{\"index\":3}", "line 2: index 3 is outside the dataset's 0..2"},
        {"{\"index\":-1}", "line 2: index -1 is outside"},
        {"{\"index\":1,\"key\":\"s00000002\"}", "line 2: key \"s00000002\" does not match index 1"},
        {"[1]", "line 2: not a manifest entry"},
        {"{\"index\":1", "line 2: not a manifest entry"},  // truncated
    };
    for (std::size_t c = 0; c < lines.size(); ++c) {
        const auto dir = damaged_copy("synth_merge_bad_line");
        const auto manifest = dir / "manifest.jsonl";
        core::write_file_atomically(manifest, "{\"index\":0,\"key\":\"s00000000\"}\n" + lines[c].first + "\n");
        SCOPED_TRACE("case " + std::to_string(c));
        expect_error_naming(" merge " + dir.string() + " --into " + (dir / "merged").string() + " --quiet", manifest, lines[c].second);
        EXPECT_FALSE(fs::exists(dir / "merged"));
    }
}

TEST(SynthDatasetFiles, MergeNamesAMissingSampleFileBeforeLinkingAny) {
    const auto dir = damaged_copy("synth_merge_missing_image");
    fs::remove(dir / "images" / "s00000002.png");
    expect_error_naming(" merge " + dir.string() + " --into " + (dir / "merged").string() + " --quiet", dir / "images" / "s00000002.png",
                        "listed in a manifest but missing");
    EXPECT_FALSE(fs::exists(dir / "merged"));  // samples 0 and 1 were not linked either
}

TEST(SynthDatasetFiles, MergeNamesADamagedDatasetJsonOrMetaFile) {
    const auto dir = damaged_copy("synth_merge_bad_info");
    const auto info_path = dir / "dataset.json";
    const std::string valid = core::read_file(info_path);
    auto info = nlohmann::json::parse(valid);
    const std::vector<std::pair<std::string, std::string>> cases = {
        {valid.substr(0, valid.size() / 3), "not a facesynth dataset.json"},  // truncated
        {"\x01\x02garbage", "not a facesynth dataset.json"},
        {"{}", "not a facesynth dataset.json"},  // no config
        {[&] { auto j = info; j["config"]["output"]["wds_shard_size"] = 0; return j.dump(); }(), "output.wds_shard_size"},
        {[&] { auto j = info; j["config"]["count"] = -4; return j.dump(); }(), "count"},
        {[&] { auto j = info; j["model_checksum"] = 12; return j.dump(); }(), "model_checksum must be a string"},
    };
    for (std::size_t c = 0; c < cases.size(); ++c) {
        core::write_file_atomically(info_path, cases[c].first);
        SCOPED_TRACE("case " + std::to_string(c));
        expect_error_naming(" merge " + dir.string() + " --into " + (dir / "merged").string() + " --quiet", info_path, cases[c].second);
        EXPECT_FALSE(fs::exists(dir / "merged" / "manifest.jsonl"));
    }
    // A damaged meta file stops the COCO export before the merged manifest is written.
    core::write_file_atomically(info_path, valid);
    core::write_file_atomically(dir / "meta" / "s00000001.json", "{\"image_width\": 48");
    expect_error_naming(" merge " + dir.string() + " --into " + (dir / "merged").string() + " --quiet", dir / "merged" / "meta" / "s00000001.json",
                        "invalid JSON");
    EXPECT_FALSE(fs::exists(dir / "merged" / "manifest.jsonl"));
    EXPECT_FALSE(fs::exists(dir / "merged" / "coco.json"));
}

// bench synth's JSON carries the keys docs/cli.md lists, with the anti-aliasing and lighting settings it ran.
TEST(SynthCli, BenchJsonHasTheListedKeysAndTheSettingsItRan) {
    const auto dir = testkit::fresh_temp_dir("synth_bench_json");
    const fs::path json = dir / "bench.json";
    std::string log;
    ASSERT_EQ(testkit::run_command(testkit::cli_path().string() + " bench synth --model " + toy_model_file().string() +
                                       " -n 2 --size 32 --threads 2 --set render.lights_per_vertex=false --json " + json.string() +
                                       " --quiet",
                                   &log),
              0)
        << log;
    std::ifstream in(json);
    const nlohmann::json report = nlohmann::json::parse(in);
    for (const char* key : {"samples_per_s_1_thread", "samples_per_s_all_threads", "cpu_ms_per_sample_1_thread",
                            "cpu_ms_per_sample_all_threads", "cpu_ms_render", "cpu_ms_render_all_threads", "ms_write_all_threads",
                            "antialiasing", "antialiasing_samples", "lights_per_vertex", "lp_num_threads", "renderer"})
        EXPECT_TRUE(report.contains(key)) << key;
    EXPECT_EQ(report["antialiasing"], "edges");
    EXPECT_EQ(report["lights_per_vertex"], false);
    EXPECT_EQ(report["antialiasing_samples"], 1);
    EXPECT_EQ(report["count"], 2);
    // The two workers render on Mesa's two software displays (a GPU device, where one is offered,
    // serves both instead).
    const std::string renderer = report["renderer"];
    if (renderer.find("egl-device") == std::string::npos) {
        EXPECT_EQ(renderer.rfind("egl-surfaceless | ", 0), 0u) << renderer;
        EXPECT_NE(renderer.find(" + egl-software-device | "), std::string::npos) << renderer;
    }
}

}  // namespace
}  // namespace facesynth::synth
