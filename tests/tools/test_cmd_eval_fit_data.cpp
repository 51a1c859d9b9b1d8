// `facesynth eval fit --data DIR` end to end on a small rendered `facesynth synth` dataset: accuracy
// bounds against the meta ground truth, per-sample errors for corrupt meta files, and refusing a
// dataset made with another model.
#include "common/test_data.h"
#include "common/toy_model.h"
#include "morph/model_io.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::run_command;

using facesynth::testkit::read_json;

// 60 faces of the built-in model, yaw within ±60°, 128x128, no anti-aliasing (only the labels matter).
fs::path make_dataset(const fs::path& dir, const std::string& model, int count) {
    const fs::path data = dir / "data";
    std::string out;
    const std::string cmd = cli_path().string() + " synth --model " + model + " --out " + data.string() + " -n " + std::to_string(count) +
                            " --size 128 --seed 11 --set pose.yaw.min=-60 --set pose.yaw.max=60"
                            " --set background.type=solid --quiet";
    EXPECT_EQ(run_command(cmd, &out), 0) << cmd << "\n" << out;
    return data;
}

TEST(CmdEvalFitData, RefinedFitOfARenderedDatasetBeatsTheMeanShapeAndRecoversThePose) {
    const auto dir = fresh_temp_dir("cmd_eval_fit_data");
    const auto data = make_dataset(dir, "builtin", 60);
    auto eval = [&](const std::string& extra, int expected_status, std::string* log = nullptr) {
        std::string out;
        const auto json = dir / "eval.json";
        fs::remove(json);
        const std::string cmd = cli_path().string() + " eval fit --model builtin --data " + data.string() + " --refine --quiet --json " +
                                json.string() + " " + extra;
        EXPECT_EQ(run_command(cmd, &out), expected_status) << cmd << "\n" << out;
        if (log) *log = out;
        return read_json(json);
    };

    // Default: contour jaw labels, fitted with contour correspondences.
    const auto contour = eval("", 0);
    EXPECT_EQ(contour["count"].get<int>(), 60);
    EXPECT_EQ(contour["failed"].get<int>(), 0);
    EXPECT_EQ(contour["mode"].get<std::string>(), "contour");
    // synth's contour labels and the fitter's contour correspondences follow one definition
    // (morph/jaw_contour.h: far side on the face region's outline, near side fixed), so the contour fit
    // recovers the pose and beats the mean shape clearly (measured 0.47 / 0.60 / 0.22°, 0.25 px, -49%).
    for (const char* key : {"yaw_mae_deg", "pitch_mae_deg", "roll_mae_deg"}) EXPECT_LT(contour[key].get<double>(), 1.0) << key;
    // The signed mean (fitted - true) is no larger than the mean absolute error, per angle and per bin.
    for (const char* angle : {"yaw", "pitch", "roll"}) {
        const double bias = contour[std::string(angle) + "_bias_deg"].get<double>();
        EXPECT_LE(std::abs(bias), contour[std::string(angle) + "_mae_deg"].get<double>() + 1e-12) << angle;
        EXPECT_NE(bias, 0.0) << angle << ": a mean of 60 real-valued errors is not exactly 0";
    }
    EXPECT_LT(contour["reprojection_px"].get<double>(), 1.0);
    EXPECT_LT(contour["vertex_rmse_mm"].get<double>(), 0.7 * contour["vertex_rmse_mm_meanshape"].get<double>());
    // Per 15° bins over ±90° (stable keys); a ±60° dataset leaves the outer bins empty.
    int binned = 0;
    for (int low = -90; low < 90; low += 15) {
        const std::string prefix = "yaw_" + std::to_string(low) + "_" + std::to_string(low + 15) + "_";
        ASSERT_TRUE(contour.contains(prefix + "vertex_rmse_mm")) << prefix;
        binned += contour[prefix + "count"].get<int>();
        if (low < -60 || low >= 60) {
            EXPECT_EQ(contour[prefix + "count"].get<int>(), 0) << prefix;
        }
    }
    EXPECT_EQ(binned, 60);

    // Fixed jaw labels with fixed correspondences: the exact model points, so tighter.
    const auto fixed = eval("--mode fixed", 0);
    for (const char* key : {"yaw_mae_deg", "pitch_mae_deg", "roll_mae_deg"}) EXPECT_LT(fixed[key].get<double>(), 1.0) << key;
    EXPECT_LT(fixed["vertex_rmse_mm"].get<double>(), 0.7 * fixed["vertex_rmse_mm_meanshape"].get<double>());
    EXPECT_DOUBLE_EQ(fixed["vertex_rmse_mm_meanshape"].get<double>(), contour["vertex_rmse_mm_meanshape"].get<double>());

    // Noise is seeded: the same run twice gives the same numbers; noise makes the fit worse.
    const auto noisy = eval("--mode fixed --noise 2 --sigma 2", 0);
    const auto noisy_again = eval("--mode fixed --noise 2 --sigma 2", 0);
    EXPECT_DOUBLE_EQ(noisy["vertex_rmse_mm"].get<double>(), noisy_again["vertex_rmse_mm"].get<double>());
    EXPECT_GT(noisy["reprojection_px"].get<double>(), fixed["reprojection_px"].get<double>() + 0.5);
    EXPECT_GT(noisy["yaw_mae_deg"].get<double>(), fixed["yaw_mae_deg"].get<double>());

    // A corrupt and a missing meta file: one error line each, the rest still evaluated, exit 1.
    {
        std::ofstream corrupt(data / "meta" / "s00000003.json", std::ios::trunc);
        corrupt << "{\"key\": \"s00000003\", \"alpha\": [1, 2";
    }
    fs::remove(data / "meta" / "s00000007.json");
    std::string log;
    const auto partial = eval("--mode fixed", 1, &log);
    EXPECT_EQ(partial["count"].get<int>(), 58);
    EXPECT_EQ(partial["failed"].get<int>(), 2);
    EXPECT_NE(log.find("s00000003.json"), std::string::npos) << log;
    EXPECT_NE(log.find("s00000007"), std::string::npos) << log;
    EXPECT_NE(log.find("2 of 60 samples"), std::string::npos) << log;
}

TEST(CmdEvalFitData, RefusesADatasetMadeWithAnotherModel) {
    const auto dir = fresh_temp_dir("cmd_eval_fit_data_model");
    facesynth::morph::write_model(facesynth::testkit::make_toy_model(), dir / "toy.fsm");
    const auto data = make_dataset(dir, (dir / "toy.fsm").string(), 3);
    const std::string toy_checksum = read_json(data / "dataset.json")["model_checksum"].get<std::string>();
    std::string out;
    EXPECT_EQ(run_command(cli_path().string() + " eval fit --model builtin --quiet --data " + data.string(), &out), 1) << out;
    EXPECT_NE(out.find(data.string()), std::string::npos) << out;
    EXPECT_NE(out.find(toy_checksum), std::string::npos) << out;
    EXPECT_NE(out.find("checksum"), std::string::npos) << out;
    // Without dataset.json the per-sample meta checksum still catches it.
    fs::remove(data / "dataset.json");
    EXPECT_EQ(run_command(cli_path().string() + " eval fit --model builtin --quiet --data " + data.string(), &out), 1) << out;
    EXPECT_NE(out.find(toy_checksum), std::string::npos) << out;
    // The dataset's own model is accepted.
    EXPECT_EQ(run_command(cli_path().string() + " eval fit --model " + (dir / "toy.fsm").string() + " --quiet --data " + data.string(), &out), 0)
        << out;
    // Not a dataset: one clear line naming the manifest.
    EXPECT_EQ(run_command(cli_path().string() + " eval fit --model builtin --quiet --data " + dir.string(), &out), 1) << out;
    EXPECT_NE(out.find("manifest.jsonl"), std::string::npos) << out;
}

}  // namespace
