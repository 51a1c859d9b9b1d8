// `facesynth eval recognition` end to end on a tiny synthetic set: the documented keys, rates in
// [0, 1], a DET file the report draws; and clear errors for unusable inputs.
#include "common/test_data.h"
#include "core/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::read_json;
using facesynth::testkit::run_command;

TEST(CmdRecognition, TinySetWritesRatesDetCurvesAndFeedsTheReport) {
    const fs::path dir = fresh_temp_dir("cmd_recognition");
    const fs::path evals = dir / "evals";
    fs::create_directories(evals);
    std::string out;
    const std::string cmd = cli_path().string() + " eval recognition -n 4 --gallery 0 --probe-max-yaw 20 --size 128 --crop 48 --quiet --json " +
                            (evals / "eval_recognition.json").string() + " --det-csv " + (evals / "eval_recognition.det.csv").string() +
                            " --examples " + (dir / "examples.png").string();
    ASSERT_EQ(run_command(cmd, &out), 0) << out;
    const auto j = read_json(evals / "eval_recognition.json");
    for (const char* key : {"identities", "seed", "images", "failed_frontalisations", "far", "matcher", "crop_size", "landmarks", "cpu_s"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["matcher"], "lbph");
    EXPECT_EQ(j["images"].get<int>(), 4 * 3);
    for (const char* bin : {"gallery0_yaw_0_10_", "gallery0_yaw_10_20_"}) {
        for (const char* metric : {"frr_org", "frr_lm", "auc_org", "auc_lm"}) {
            const double v = j.at(std::string(bin) + metric).get<double>();
            EXPECT_GE(v, 0.0) << bin << metric;
            EXPECT_LE(v, 1.0) << bin << metric;
        }
        EXPECT_NEAR(j.at(std::string(bin) + "frr_improvement").get<double>(),
                    j.at(std::string(bin) + "frr_org").get<double>() - j.at(std::string(bin) + "frr_lm").get<double>(), 1e-12);
        EXPECT_EQ(j.at(std::string(bin) + "genuine").get<int>(), 4);
        EXPECT_EQ(j.at(std::string(bin) + "impostor").get<int>(), 12);
    }
    const std::string det = facesynth::core::read_file(evals / "eval_recognition.det.csv");
    EXPECT_EQ(det.rfind("gallery_deg,probe_yaw_low,probe_yaw_high,method,far,frr\n", 0), 0u);
    EXPECT_NE(det.find("\n0,10,20,lm,"), std::string::npos);
    EXPECT_TRUE(fs::exists(dir / "examples.png"));

    ASSERT_EQ(run_command(cli_path().string() + " report --quiet --out " + (dir / "r.html").string() + " --evals " + evals.string(), &out), 0) << out;
    const std::string html = facesynth::core::read_file(dir / "r.html");
    EXPECT_NE(html.find("DET, gallery at 0"), std::string::npos);
    EXPECT_NE(html.find("FRR at FAR = 0.01, gallery at 0"), std::string::npos);
}

// With --regressor the probes are also frontalised from found landmarks (dlib's predictor on
// multi-view boxes): per bin FRR and AUC of that column, its misses, and a DET curve.
TEST(CmdRecognition, RegressorAddsADetectedLandmarkColumnWithItsMisses) {
    const fs::path dir = fresh_temp_dir("cmd_recognition_detected");
    std::string out;
    const std::string cmd = cli_path().string() + " eval recognition -n 3 --gallery 0 --probe-max-yaw 20 --size 128 --crop 48 --quiet --regressor dlib" +
                            " --detector multiview --json " + (dir / "r.json").string() + " --det-csv " + (dir / "det.csv").string();
    ASSERT_EQ(run_command(cmd, &out), 0) << out;
    const auto j = read_json(dir / "r.json");
    EXPECT_EQ(j.at("detector"), "multiview");
    EXPECT_EQ(j.at("detection_framing").get<double>(), 2.5);
    int misses = 0;
    for (const char* bin : {"gallery0_yaw_0_10_", "gallery0_yaw_10_20_"}) {
        for (const char* metric : {"frr_lm_detected", "auc_lm_detected"}) {
            const double v = j.at(std::string(bin) + metric).get<double>();
            EXPECT_GE(v, 0.0) << bin << metric;
            EXPECT_LE(v, 1.0) << bin << metric;
        }
        misses += j.at(std::string(bin) + "detector_misses").get<int>();
    }
    EXPECT_EQ(j.at("detector_misses").get<int>(), misses);
    EXPECT_NE(facesynth::core::read_file(dir / "det.csv").find(",lm_detected,"), std::string::npos);
}

TEST(CmdRecognition, UnusableInputsAreClearErrors) {
    const fs::path dir = fresh_temp_dir("cmd_recognition_errors");
    fs::create_directories(dir / "photos" / "alice");
    std::ofstream(dir / "photos" / "alice" / "broken.jpg") << "not an image";
    std::string out;
    EXPECT_EQ(run_command(cli_path().string() + " eval recognition --quiet --photos " + (dir / "photos").string(), &out), 1) << out;
    EXPECT_NE(out.find("broken.jpg"), std::string::npos) << out;
    EXPECT_EQ(run_command(cli_path().string() + " eval recognition -n 1", &out), 2) << out;
    EXPECT_EQ(run_command(cli_path().string() + " eval recognition --probe-bin 0", &out), 2) << out;
}

}  // namespace
