// `facesynth train`, `detect` and `eval landmarks` end to end on a small rendered dataset: the
// trained cascade must beat its own mean-shape start on held-out faces, the JSON keys are the
// documented stable ones, and bad inputs give one-line errors with the right exit codes.
#include "common/test_data.h"
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::run_command;

using facesynth::testkit::read_json;

// Near-frontal faces, large in the image, so the Haar detector finds most of them.
fs::path make_train_dataset(const fs::path& dir, const std::string& name, int count, int seed) {
    const fs::path data = dir / name;
    std::string out;
    const std::string cmd = cli_path().string() + " synth --model builtin --out " + data.string() + " -n " +
                            std::to_string(count) + " --size 160 --seed " + std::to_string(seed) +
                            " --set pose.yaw.min=-20 --set pose.yaw.max=20 --set pose.pitch.min=-10"
                            " --set pose.pitch.max=10 --set pose.roll.min=-5 --set pose.roll.max=5"
                            " --quiet";
    EXPECT_EQ(run_command(cmd, &out), 0) << cmd << "\n" << out;
    return data;
}

TEST(CmdTrain, TrainDetectEvalEndToEnd) {
    const auto dir = fresh_temp_dir("cmd_train");
    const auto train = make_train_dataset(dir, "train", 80, 1);
    const auto test = make_train_dataset(dir, "test", 30, 2);
    const auto model = dir / "regressor.sdm";
    std::string out;
    const std::string train_cmd = cli_path().string() + " train --data " + train.string() + " --out " + model.string() +
                                  " --stages 3 --augment 3 --hog-cells 2 --quiet --json " + (dir / "train.json").string();
    ASSERT_EQ(run_command(train_cmd, &out), 0) << out;
    ASSERT_TRUE(fs::exists(model));
    const auto train_report = read_json(dir / "train.json");
    for (const char* key : {"stage1_nme", "stage1_validation_nme", "stage1_lambda_factor", "stage1_rank", "stage3_rank",
                            "feature_pca", "stage1_feature_components", "mirror",
                            "detector_matched_frontal", "detector_matched_nose_left", "detector_matched_nose_right"})
        EXPECT_TRUE(train_report.contains(key)) << key;
    EXPECT_EQ(train_report["detector"], "dlib");  // the default
    EXPECT_EQ(train_report["mirror"], false);
    EXPECT_EQ(train_report["image_copies"], 0);
    EXPECT_EQ(train_report["augment"], 3);
    EXPECT_EQ(train_report["stages"], 3);
    EXPECT_EQ(train_report["hog_cells"], 2);
    EXPECT_EQ(train_report["hog_orientations"], 4);  // the default
    // --cascades auto: these near-frontal faces give the profile cascade too few faces, so one cascade.
    EXPECT_EQ(train_report["view_cascades"], false);

    // A realigned cascade added to the model (--base keeps its cascades): trained on the same data only.
    const auto realigned = dir / "realigned.sdm";
    const std::string base_cmd = cli_path().string() + " train --data " + train.string() + " --stages 3 --augment 3 --hog-cells 2 --quiet" +
                                 " --base " + model.string() + " --realign-stages 2 --out ";
    ASSERT_EQ(run_command(base_cmd + realigned.string() + " --json " + (dir / "realigned.json").string(), &out), 0) << out;
    const auto realigned_report = read_json(dir / "realigned.json");
    for (const char* key : {"realign_stage1_nme", "realign_stage2_validation_nme", "realign_residual_translation_std",
                            "realign_residual_rotation_std_deg", "realign_stages", "realign_spread"})
        EXPECT_TRUE(realigned_report.contains(key)) << key;
    EXPECT_EQ(realigned_report["realign_stages"], 2);
    EXPECT_FALSE(realigned_report.contains("stage1_nme"));  // the main cascade was kept, not trained
    // Trained in one go, the model is the same file byte for byte.
    const auto at_once = dir / "at_once.sdm";
    ASSERT_EQ(run_command(cli_path().string() + " train --data " + train.string() + " --stages 3 --augment 3 --hog-cells 2 --quiet" +
                              " --realign-stages 2 --out " + at_once.string(),
                          &out),
              0)
        << out;
    EXPECT_EQ(facesynth::core::read_file(at_once), facesynth::core::read_file(realigned));
    EXPECT_EQ(run_command(cli_path().string() + " train --data " + test.string() + " --stages 3 --augment 3 --hog-cells 2 --quiet --base " +
                              model.string() + " --realign-stages 2 --out " + (dir / "other.sdm").string(),
                          &out),
              1);
    EXPECT_NE(out.find("training checksums differ"), std::string::npos) << out;
    EXPECT_NE(out.find(model.string()), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "other.sdm"));
    EXPECT_EQ(run_command(cli_path().string() + " train --data " + train.string() + " --base " + model.string() + " --out " +
                              (dir / "other.sdm").string(),
                          &out),
              2);
    EXPECT_NE(out.find("--realign-stages"), std::string::npos) << out;
    // A missing base is named before the faces are prepared.
    EXPECT_EQ(run_command(base_cmd.substr(0, base_cmd.find(" --base ")) + " --base " + (dir / "missing.sdm").string() +
                              " --realign-stages 2 --out " + (dir / "other.sdm").string(),
                          &out),
              1);
    EXPECT_NE(out.find("missing.sdm: model file not found"), std::string::npos) << out;

    const auto eval_json = dir / "eval.json";
    const std::string eval_cmd = cli_path().string() + " eval landmarks --regressor " + model.string() +
                                 " --regressor mean:" + model.string() + " --regressor sdm@1:" + model.string() +
                                 " --regressor mirror:" + model.string() + " --regressor realign:mirror:" + model.string() +
                                 " --regressor realign:" + realigned.string() +
                                 " --data " + test.string() +
                                 " --quiet --json " + eval_json.string() + " --ced " + (dir / "ced.svg").string() +
                                 " --nme-csv " + (dir / "nme.csv").string();
    ASSERT_EQ(run_command(eval_cmd, &out), 0) << out;
    const auto j = read_json(eval_json);
    for (const char* key : {"nme_mean", "nme_median", "auc_008", "failure_rate_008", "ms_per_face", "detector_misses",
                            "count", "regressor1", "regressor2", "regressor2_nme_mean", "regressor3_nme_mean",
                            "detector_view_frontal", "detector_view_nose_left", "detector_view_nose_right",
                            "detector_misses_yaw_00_10", "faces_yaw_00_10"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["detector"], "dlib");  // auto: the one recorded in the model
    EXPECT_EQ(j["count"].get<int>(), 30);
    EXPECT_LT(j["detector_misses"].get<int>(), 30);
    // The cascade must improve on its own starting point (the mean shape in the same boxes).
    EXPECT_LT(j["nme_mean"].get<double>(), j["regressor2_nme_mean"].get<double>());
    // So must the cascade averaged with its run on the mirror image.
    EXPECT_EQ(j["regressor4"], "mirror:" + model.string());
    EXPECT_LT(j["regressor4_nme_mean"].get<double>(), j["regressor2_nme_mean"].get<double>());
    // And the realigned second pass with mirroring: a spec whose modifiers stack.
    EXPECT_EQ(j["regressor5"], "realign:mirror:" + model.string());
    EXPECT_LT(j["regressor5_nme_mean"].get<double>(), j["regressor2_nme_mean"].get<double>());
    // And the second pass with its own trained cascade.
    EXPECT_LT(j["regressor6_nme_mean"].get<double>(), j["regressor2_nme_mean"].get<double>());
    EXPECT_TRUE(fs::exists(dir / "ced.svg"));
    // --nme-csv: a header naming the regressors by position, then one row per face.
    std::ifstream nme_csv(dir / "nme.csv");
    std::string line;
    ASSERT_TRUE(std::getline(nme_csv, line));
    EXPECT_EQ(line, "key,yaw_deg,detected,view,regressor1,regressor2,regressor3,regressor4,regressor5,regressor6");
    int rows = 0;
    while (std::getline(nme_csv, line)) ++rows;
    EXPECT_EQ(rows, 30);

    // Models joined into an ensemble (`train merge`) are one regressor to every command.
    const auto ensemble = dir / "ensemble.sdm";
    const std::string merge_cmd = cli_path().string() + " train merge " + model.string() + " ";
    ASSERT_EQ(run_command(merge_cmd + realigned.string() + " --out " + ensemble.string() + " --quiet", &out), 0) << out;
    ASSERT_EQ(run_command(cli_path().string() + " eval landmarks --regressor realign:" + ensemble.string() + " --data " + test.string() +
                              " --quiet --json " + (dir / "ensemble.json").string(),
                          &out),
              0)
        << out;
    EXPECT_LT(read_json(dir / "ensemble.json")["nme_mean"].get<double>(), j["regressor2_nme_mean"].get<double>());
    const auto other = dir / "other.sdm";
    EXPECT_EQ(run_command(merge_cmd + "--out " + other.string(), &out), 2);
    EXPECT_NE(out.find("at least two"), std::string::npos) << out;
    EXPECT_EQ(run_command(merge_cmd + (dir / "nme.csv").string() + " --out " + other.string(), &out), 1);
    EXPECT_NE(out.find("nme.csv: not a facesynth SDM model"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(other));
    EXPECT_EQ(run_command(cli_path().string() + " train --out " + other.string(), &out), 2);
    EXPECT_NE(out.find("--data is required"), std::string::npos) << out;

    // Photographs (image and .pts side by side, no meta): their yaw comes from fitting the built-in
    // model to the annotations, close to the renders' true yaw.
    const fs::path photos = dir / "photos";
    fs::create_directories(photos);
    std::map<std::string, double> true_yaw;
    for (const auto& e : fs::directory_iterator(test / "images")) {
        const std::string stem = e.path().stem().string();
        fs::copy_file(e.path(), photos / e.path().filename());
        fs::copy_file(test / "landmarks" / (stem + ".pts"), photos / (stem + ".pts"));
        true_yaw["photos/" + stem] = read_json(test / "meta" / (stem + ".json"))["yaw"].get<double>();
    }
    ASSERT_EQ(run_command(cli_path().string() + " eval landmarks --regressor " + model.string() + " --data " + photos.string() +
                              " --nme-csv " + (dir / "photos.csv").string(),
                          &out),
              0)
        << out;
    EXPECT_NE(out.find("30 faces without meta: yaw from fitting the built-in model to their annotations"), std::string::npos) << out;
    std::ifstream photo_csv(dir / "photos.csv");
    ASSERT_TRUE(std::getline(photo_csv, line));
    int fitted = 0;
    while (std::getline(photo_csv, line)) {
        const std::string key = line.substr(0, line.find(','));
        const double yaw = std::stod(line.substr(key.size() + 1));
        ASSERT_TRUE(true_yaw.count(key)) << key;
        EXPECT_NEAR(yaw, true_yaw[key], 8.0) << key;
        ++fitted;
    }
    EXPECT_EQ(fitted, 30);

    // detect: one unreadable file in the batch gives a per-image error, the rest continue, exit 1.
    const auto images = test / "images";
    const fs::path first = fs::directory_iterator(images)->path();
    std::ofstream(dir / "broken.png") << "not an image";
    const std::string detect_cmd = cli_path().string() + " detect --regressor " + model.string() + " " + first.string() +
                                   " " + (dir / "broken.png").string() + " --out " + (dir / "detect").string() + " --quiet";
    EXPECT_EQ(run_command(detect_cmd, &out), 1) << out;
    EXPECT_NE(out.find("broken.png"), std::string::npos) << out;
    bool wrote_pts = false;
    for (const auto& e : fs::directory_iterator(dir / "detect")) wrote_pts |= e.path().extension() == ".pts";
    EXPECT_TRUE(wrote_pts);
}

// The baselines train on the same faces and boxes as our cascade (the multi-view detector's, with the
// same synthesised boxes where it misses) and are evaluated on the same detections in one run.
TEST(CmdTrain, ErtAndLbfBaselinesTrainAndEvaluateOnTheSameBoxesAsTheCascade) {
    const auto dir = fresh_temp_dir("cmd_train_baselines");
    const auto train = make_train_dataset(dir, "train", 60, 3);
    const auto test = make_train_dataset(dir, "test", 20, 4);
    std::string out;
    const auto train_with = [&](const std::string& name, const std::string& options) {
        const std::string cmd = cli_path().string() + " train --data " + train.string() + " --out " + (dir / name).string() +
                                " --augment 2 --threads 2 --quiet --json " + (dir / (name + ".json")).string() + " " + options;
        EXPECT_EQ(run_command(cmd, &out), 0) << cmd << "\n" << out;
        return read_json(dir / (name + ".json"));
    };
    const auto sdm = train_with("sdm.sdm", "--stages 2 --hog-cells 2");
    const auto ert = train_with("ert.dat", "--method ert");
    const auto lbf = train_with("lbf.yaml", "--method lbf --lbf-stages 2 --lbf-trees 3 --lbf-depth 3 --lbf-features 50,50 "
                                            "--lbf-radii 0.3,0.2");
    EXPECT_EQ(ert["method"], "ert");
    EXPECT_EQ(lbf["method"], "lbf");
    for (const auto* report : {&ert, &lbf}) {
        for (const char* key : {"detector", "faces", "detector_matched", "detector_missed", "detector_matched_frontal",
                                "detector_matched_nose_left", "detector_matched_nose_right"})
            EXPECT_EQ((*report)[key], sdm[key]) << key;
        EXPECT_GT((*report)["cpu_seconds"].get<double>(), 0.0);
    }
    EXPECT_EQ(ert["detector"], "dlib");  // the default
    EXPECT_GT(ert["detector_matched"].get<int>(), 0);
    // --cascades auto: near-frontal faces give the profile views too few faces, so one model each.
    EXPECT_EQ(ert["view_cascades"], false);
    EXPECT_EQ(lbf["view_cascades"], false);
    EXPECT_EQ(lbf["lbf_faces_used"].get<int>() + lbf["lbf_faces_outside_box"].get<int>(), lbf["faces"].get<int>());

    // The baselines first: --detector auto still takes the detector recorded in the SDM model.
    const auto eval_json = dir / "eval.json";
    const std::string eval_cmd = cli_path().string() + " eval landmarks --regressor ert:" + (dir / "ert.dat").string() +
                                 " --regressor lbf:" + (dir / "lbf.yaml").string() + " --regressor " +
                                 (dir / "sdm.sdm").string() + " --regressor mean:" + (dir / "sdm.sdm").string() +
                                 " --data " + test.string() + " --quiet --json " + eval_json.string() + " --nme-csv " +
                                 (dir / "nme.csv").string();
    ASSERT_EQ(run_command(eval_cmd, &out), 0) << out;
    const auto j = read_json(eval_json);
    EXPECT_EQ(j["detector"], "dlib");
    EXPECT_EQ(j["count"].get<int>(), 20);
    ASSERT_LT(j["detector_misses"].get<int>(), 20);
    for (const char* key : {"nme_mean", "regressor2_nme_mean", "regressor3_nme_mean", "regressor4_nme_mean"})
        EXPECT_GT(j[key].get<double>(), 0.0) << key;
    // ERT learned something: better than the cascade's mean shape in the same boxes.
    EXPECT_LT(j["nme_mean"].get<double>(), j["regressor4_nme_mean"].get<double>());
    std::ifstream nme_csv(dir / "nme.csv");
    std::string header;
    ASSERT_TRUE(std::getline(nme_csv, header));
    EXPECT_EQ(header, "key,yaw_deg,detected,view,regressor1,regressor2,regressor3,regressor4");
}

TEST(CmdTrain, BadRegressorFileAndUsageErrors) {
    const auto dir = fresh_temp_dir("cmd_train_errors");
    std::ofstream(dir / "bad.sdm") << "garbage that is not a regressor";
    std::string out;
    EXPECT_EQ(run_command(cli_path().string() + " detect --regressor " + (dir / "bad.sdm").string() + " x.png --out " +
                              (dir / "o").string(),
                          &out),
              1)
        << out;
    EXPECT_NE(out.find("bad.sdm"), std::string::npos) << out;
    EXPECT_EQ(run_command(cli_path().string() + " train --out " + (dir / "m.sdm").string(), &out), 2) << out;
    // View-specific cascades need the multi-view detector's views; the overlap needs the cascades.
    const std::string train_here = cli_path().string() + " train --data " + dir.string() + " --out " + (dir / "m.sdm").string();
    EXPECT_EQ(run_command(train_here + " --cascades views --detector frontal", &out), 2) << out;
    EXPECT_NE(out.find("--cascades"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --cascades single --view-overlap 35,20", &out), 2) << out;
    EXPECT_EQ(run_command(train_here + " --view-overlap 35", &out), 2) << out;
    EXPECT_EQ(run_command(train_here + " --cascades both", &out), 2) << out;
    EXPECT_EQ(run_command(train_here + " --method ert --cascades views --detector frontal", &out), 2) << out;
    EXPECT_EQ(run_command(train_here + " --method lbf --view-overlap 35,20", &out), 2) << out;
    EXPECT_NE(out.find("--view-overlap"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --feature-pca -1", &out), 2) << out;
    EXPECT_NE(out.find("--feature-pca"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --hog-cells 2 --feature-pca 4353", &out), 2) << out;  // D = 68 * 4 * 16 = 4352
    EXPECT_NE(out.find("--feature-pca"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --method ert --mirror", &out), 2) << out;  // the SDM's option
    EXPECT_NE(out.find("--mirror"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --method lbf --image-copies 2", &out), 2) << out;  // the SDM's option
    EXPECT_NE(out.find("--image-copies"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --image-copies 33", &out), 2) << out;
    EXPECT_NE(out.find("--image-copies"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --hog-orientations 0", &out), 2) << out;
    EXPECT_NE(out.find("--hog-orientations"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --hog-orientations 17", &out), 2) << out;
    EXPECT_EQ(run_command(train_here + " --method lbf --hog-orientations 9", &out), 2) << out;  // the SDM's option
    EXPECT_NE(out.find("--hog-orientations"), std::string::npos) << out;
    EXPECT_EQ(run_command(train_here + " --hog-cells 2 --hog-orientations 9 --feature-pca 8433", &out), 2) << out;  // 68 * 4 * 31 = 8432
    EXPECT_NE(out.find("--feature-pca"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "m.sdm"));
    EXPECT_EQ(run_command(cli_path().string() + " eval landmarks --regressor sdm@x:" + (dir / "bad.sdm").string() +
                              " --data " + dir.string(),
                          &out),
              1)
        << out;
    EXPECT_NE(out.find("sdm@x"), std::string::npos) << out;
    EXPECT_EQ(run_command(cli_path().string() + " eval landmarks --data " + dir.string(), &out), 2) << out;
}

}  // namespace
