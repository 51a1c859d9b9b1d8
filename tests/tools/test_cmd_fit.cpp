// `facesynth fit` end to end: outputs, error messages and exit codes.
#include "common/test_data.h"
#include "morph/landmarks.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

namespace {

using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::run_command;

TEST(CmdFit, FitsAPhotoAndWritesEveryOutput) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const auto example = sfm / "examples";
    const auto dir = fresh_temp_dir("cmd_fit_ok");
    std::string out;
    const std::string cmd = cli_path().string() + " fit --model " + sfm.string() + " --landmarks " + (example / "image_0010.pts").string() +
                            " --image " + (example / "image_0010.png").string() + " --refine --quiet --out " + (dir / "fit").string();
    ASSERT_EQ(run_command(cmd, &out), 0) << out;
    for (const char* name : {"fit.json", "mesh.obj", "mesh.glb", "overlay.png"}) EXPECT_TRUE(std::filesystem::exists(dir / "fit" / name)) << name;
    std::ifstream in(dir / "fit" / "fit.json");
    const auto j = nlohmann::json::parse(in);
    for (const char* key : {"yaw_deg", "pitch_deg", "roll_deg", "rotation", "alpha", "psi", "reprojection_rms_px", "focal_px", "affine_camera"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_LT(j["reprojection_rms_px"].get<double>(), 10.0);
    for (const auto& entry : std::filesystem::directory_iterator(dir / "fit"))
        EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
}

TEST(CmdFit, WrongLandmarkCountIsAOneLineErrorNamingTheFile) {
    const auto dir = fresh_temp_dir("cmd_fit_bad");
    facesynth::write_pts(dir / "five.pts", Eigen::Matrix2Xd::Random(2, 5) * 100);
    std::string out;
    const int status = run_command(cli_path().string() + " fit --model builtin --landmarks " + (dir / "five.pts").string() +
                                       " --out " + (dir / "o").string(),
                                   &out);
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("five.pts"), std::string::npos) << out;
    EXPECT_NE(out.find("expected 68"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(dir / "o" / "fit.json"));
}

TEST(CmdFit, UsageErrorsExitTwo) {
    std::string out;
    EXPECT_EQ(run_command(cli_path().string() + " fit --landmark-set 12 --out x --landmarks /nonexistent.pts", &out), 2) << out;
    EXPECT_EQ(run_command(cli_path().string() + " fit --help", &out), 0);
    EXPECT_NE(out.find("--refine"), std::string::npos);
}

}  // namespace
