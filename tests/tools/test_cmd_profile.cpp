// `facesynth profile` and `bench profile` end to end on renders standing in for photographs.
#include "common/test_data.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::read_json;
using facesynth::testkit::run_command;

int run_profile_cli(const std::string& arguments, std::string* output) { return run_command(cli_path().string() + " " + arguments, output); }

// Renders with their .pts as "photographs", and one file that only looks like an image.
fs::path profile_photo_folder(const fs::path& dir) {
    const fs::path photos = facesynth::testkit::photo_folder_from_renders(dir, "-n 3 --seed 5");
    std::ofstream(photos / "zz_corrupt.png") << "not an image";
    fs::copy_file(photos / "s00000000.pts", photos / "zz_corrupt.pts");
    return photos;
}

TEST(CmdProfile, ProfilesAFolderReportsTheBadPhotographAndExitsOne) {
    const fs::path dir = fresh_temp_dir("cmd_profile");
    const fs::path photos = profile_photo_folder(dir);
    std::string out;
    const std::string command = "profile --photos " + photos.string() + " --out " + (dir / "out").string() + " --yaws=-40,0,40 --size 128 --max-turn 180 --quiet --json " +
                                (dir / "run.json").string();
    EXPECT_EQ(run_profile_cli(command, &out), 1) << out;
    EXPECT_NE(out.find("zz_corrupt.png"), std::string::npos) << out;
    EXPECT_NE(out.find("1 of 4 photographs failed"), std::string::npos) << out;
    const nlohmann::json run = read_json(dir / "run.json");
    EXPECT_EQ(run["photos_failed"], 1);
    EXPECT_EQ(run["views_written"], 9);
    for (const char* key : {"photos", "photos_in_shard", "photos_done_before", "photos_detected", "views_skipped", "views_per_s",
                            "prepare_ms_per_photo", "render_ms_per_view", "write_ms_per_view", "threads", "model", "seconds"})
        EXPECT_TRUE(run.contains(key)) << key;
    // synth's contact sheet reads the dataset.
    EXPECT_EQ(run_profile_cli("synth sheet " + (dir / "out").string() + " --out " + (dir / "sheet.png").string(), &out), 0) << out;
    EXPECT_TRUE(fs::exists(dir / "sheet.png"));
    // A second run finds every good photograph done.
    EXPECT_EQ(run_profile_cli(command, &out), 1) << out;
    EXPECT_EQ(read_json(dir / "run.json")["photos_done_before"], 3);
    EXPECT_EQ(read_json(dir / "run.json")["views_written"], 0);
}

TEST(CmdProfile, ConfigFileSetsWhatTheCommandLineDoesNotAndFormatsAddTarsAndCoco) {
    const fs::path dir = fresh_temp_dir("cmd_profile_config");
    const fs::path photos = profile_photo_folder(dir);
    fs::remove(photos / "zz_corrupt.png");
    std::ofstream(dir / "profile.toml") << "seed = 4\n[views]\nper_photo = 2\n[scene]\nsize = 96\n[output]\nformats = \"folder,wds,coco\"\n";
    std::string out;
    ASSERT_EQ(run_profile_cli("profile --photos " + photos.string() + " --out " + (dir / "out").string() + " --config " + (dir / "profile.toml").string() +
                                  " --size 80 --quiet --json " + (dir / "run.json").string(),
                              &out),
              0)
        << out;
    const nlohmann::json run = read_json(dir / "run.json");
    EXPECT_EQ(run["views_written"], 6);  // views.per_photo from the file
    EXPECT_EQ(run["tars_written"], 1);
    EXPECT_EQ(read_json(dir / "out" / "meta" / "s00000000.json")["image_width"], 80);  // --size wins over the file
    EXPECT_EQ(read_json(dir / "out" / "coco.json")["images"].size(), 6u);
    EXPECT_TRUE(fs::exists(dir / "out" / "shard-000000.tar"));
    // A bad key: exit 1, the file and the key named, nothing written.
    std::ofstream(dir / "bad.toml") << "[scene]\nsise = 96\n";
    EXPECT_EQ(run_profile_cli("profile --photos " + photos.string() + " --out " + (dir / "bad_out").string() + " --config " + (dir / "bad.toml").string(), &out), 1)
        << out;
    EXPECT_NE(out.find("bad.toml"), std::string::npos) << out;
    EXPECT_NE(out.find("scene.sise"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "bad_out"));
}

TEST(CmdProfile, UsageErrorsExitTwoAndEveryCommandHasHelp) {
    const fs::path dir = fresh_temp_dir("cmd_profile_usage");
    std::string out;
    EXPECT_EQ(run_profile_cli("profile --photos " + dir.string() + " --out " + (dir / "o").string() + " --yaws 0:10:0", &out), 2) << out;
    EXPECT_NE(out.find("step"), std::string::npos) << out;
    EXPECT_EQ(run_profile_cli("profile --photos " + dir.string() + " --out " + (dir / "o").string() + " --yaws 0 --views-per-photo 3", &out), 2) << out;
    EXPECT_EQ(run_profile_cli("profile --photos " + dir.string() + " --out " + (dir / "o").string() + " --jaw sideways", &out), 2) << out;
    EXPECT_EQ(run_profile_cli("profile --photos " + (dir / "missing").string() + " --out " + (dir / "o").string(), &out), 1) << out;
    EXPECT_NE(out.find("missing"), std::string::npos) << out;
    EXPECT_EQ(run_profile_cli("profile --help", &out), 0);
    EXPECT_EQ(run_profile_cli("bench profile --help", &out), 0);
}

TEST(CmdProfile, BenchReportsViewsPerSecond) {
    const fs::path dir = fresh_temp_dir("cmd_profile_bench");
    const fs::path photos = profile_photo_folder(dir);
    fs::remove(photos / "zz_corrupt.png");
    std::string out;
    ASSERT_EQ(run_profile_cli("bench profile --photos " + photos.string() + " --max-photos 2 --views-per-photo 2 --size 96 --quiet --json " +
                                  (dir / "bench.json").string(),
                              &out),
              0)
        << out;
    const nlohmann::json bench = read_json(dir / "bench.json");
    EXPECT_EQ(bench["views"], 4);
    EXPECT_GT(bench["views_per_s"].get<double>(), 0);
}

}  // namespace
