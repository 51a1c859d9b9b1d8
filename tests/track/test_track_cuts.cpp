// Scene cuts and re-identification: a face that leaves at a cut and comes back keeps its id by its
// appearance; `eval track --cuts` counts the cuts seen and the returns, on clips cut together.
#include "common/test_data.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace facesynth::track {
namespace {

namespace fs = std::filesystem;

// Two rendered 12-frame clips, two faces in the same place of different scenes.
fs::path two_clips(const fs::path& dir) {
    std::string log;
    fs::path clips = dir / "clips";
    EXPECT_EQ(testkit::run_command(testkit::cli_path().string() + " synth -q -o " + clips.string() +
                                       " -n 24 --sequence 12 --size 256 --seed 3 --set pose.yaw.min=-20 --set pose.yaw.max=20 --set degrade.blur_probability=0",
                                   &log),
              0)
        << log;
    return clips;
}

std::string frame_name(int i) {
    char name[32];
    std::snprintf(name, sizeof name, "s%08d.png", i);
    return name;
}

// The id of the one face of each line of faces.jsonl, -1 where there is none.
std::vector<int> ids_per_frame(const fs::path& out) {
    std::vector<int> ids;
    std::ifstream lines(out / "faces.jsonl");
    std::string line;
    while (std::getline(lines, line)) {
        const auto faces = nlohmann::json::parse(line)["faces"];
        ids.push_back(faces.size() == 1 ? faces[0]["id"].get<int>() : -1);
    }
    return ids;
}

TEST(TrackCli, AFaceBackAfterACutKeepsItsIdByAppearance) {
    const fs::path dir = testkit::fresh_temp_dir("track_cuts");
    const fs::path clips = two_clips(dir);
    // Shots: the first face (clip 0, frames 0-5), the second (clip 1, 0-5), the first again (clip 0, 6-11).
    fs::create_directories(dir / "frames");
    int n = 0;
    for (const auto& [first, count] : {std::pair{0, 6}, std::pair{12, 6}, std::pair{6, 6}})
        for (int i = first; i < first + count; ++i) fs::copy_file(clips / "images" / frame_name(i), dir / "frames" / frame_name(n++));
    const auto track = [&](const std::string& name, const std::string& options) {
        std::string log;
        EXPECT_EQ(testkit::run_command(testkit::cli_path().string() + " track -q " + (dir / "frames").string() + " -o " + (dir / name).string() +
                                           " --detector dlib " + options + " --json " + (dir / (name + ".json")).string(),
                                       &log),
                  0)
            << log;
        return nlohmann::json::parse(std::ifstream(dir / (name + ".json")));
    };
    const std::vector<int> shots_of_ids{0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1};

    const auto recognised = track("reid", "--max-reid-distance 70");
    EXPECT_EQ(recognised["cuts"], 2);
    EXPECT_EQ(recognised["faces"], 2);
    EXPECT_EQ(recognised["reidentified"], 1);
    std::vector<int> expected = shots_of_ids;
    expected.insert(expected.end(), 6, 0);
    EXPECT_EQ(ids_per_frame(dir / "reid"), expected);
    std::ifstream lines(dir / "reid" / "faces.jsonl");
    std::string line;
    for (int frame = 0; std::getline(lines, line); ++frame) {
        const auto record = nlohmann::json::parse(line);
        EXPECT_EQ(record["cut"], frame == 6 || frame == 12) << frame;
        EXPECT_EQ(record["scene_change"].get<double>() > 18, frame == 6 || frame == 12) << frame;
    }

    // Without re-identification the face that comes back is a new face.
    const auto unrecognised = track("no_reid", "--max-reid-distance 0");
    EXPECT_EQ(unrecognised["cuts"], 2);
    EXPECT_EQ(unrecognised["faces"], 3);
    EXPECT_EQ(unrecognised["reidentified"], 0);
    expected = shots_of_ids;
    expected.insert(expected.end(), 6, 2);
    EXPECT_EQ(ids_per_frame(dir / "no_reid"), expected);

    // Without cut detection the cuts are not seen.
    EXPECT_EQ(track("no_cuts", "--cut-threshold 0")["cuts"], 0);
}

TEST(EvalTrack, CountsCutsReturnsAndMergesOnClipsCutTogether) {
    const fs::path dir = testkit::fresh_temp_dir("eval_track_cuts");
    const fs::path clips = two_clips(dir);
    const auto eval = [&](const std::string& name, const std::string& options) {
        std::string log;
        EXPECT_EQ(testkit::run_command(testkit::cli_path().string() + " eval track -q --data " + clips.string() + " --detector dlib " + options +
                                           " --json " + (dir / (name + ".json")).string(),
                                       &log),
                  0)
            << log;
        return nlohmann::json::parse(std::ifstream(dir / (name + ".json")));
    };
    // A tracker per clip: no cuts to count.
    const auto plain = eval("plain", "--nme-csv " + (dir / "frames.csv").string());
    EXPECT_EQ(plain["clips"], 2);
    EXPECT_EQ(plain["frames"], 24);
    EXPECT_FALSE(plain.contains("cuts"));
    EXPECT_GT(plain["tracked_found_rate"].get<double>(), 0.9);
    // Every frame's NME, clip, frame and yaw error per variant: the pose error over time.
    std::ifstream csv(dir / "frames.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line, "key,yaw_deg,detected,view,regressor1,regressor2,clip,frame,tracked_yaw_error_deg,per_frame_yaw_error_deg");
    int rows = 0, with_errors = 0;
    while (std::getline(csv, line)) {
        std::vector<std::string> cells;
        std::stringstream row(line);
        for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
        if (cells.size() == 10 && !cells[8].empty()) {
            EXPECT_LT(std::stod(cells[8]), 20) << line;
            ++with_errors;
        }
        EXPECT_EQ(cells[7], std::to_string(rows % 12)) << line;
        ++rows;
    }
    EXPECT_EQ(rows, 24);
    EXPECT_GT(with_errors, 20);

    // One stream: clip 0's first half, clip 1's, clip 0's second half, clip 1's: three cuts, two returns.
    const auto cut = eval("cuts", "--cuts --max-reid-distance 70");
    EXPECT_EQ(cut["clips"], 1);
    EXPECT_EQ(cut["frames"], 24);
    EXPECT_EQ(cut["cuts"], 3);
    EXPECT_EQ(cut["cuts_detected"], 3);
    EXPECT_EQ(cut["false_cuts"], 0);
    EXPECT_EQ(cut["returns"], 2);
    EXPECT_EQ(cut["returns_same_id"], 2);
    EXPECT_EQ(cut["false_merges"], 0);
    EXPECT_GT(cut["tracked_found_rate"].get<double>(), 0.9);
    EXPECT_LT(cut["tracked_nme_mean"].get<double>(), 0.15);
}

}  // namespace
}  // namespace facesynth::track
