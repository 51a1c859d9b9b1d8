// `facesynth frontalise` end to end on rendered faces: every output per face, per-image errors that
// let the batch go on (unreadable file, no face found, bad landmarks), and usage errors.
#include "common/test_data.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::read_json;
using facesynth::testkit::run_command;

fs::path make_renders(const fs::path& dir) {
    const fs::path data = dir / "data";
    std::string out;
    const std::string cmd = cli_path().string() + " synth --model builtin --out " + data.string() +
                            " -n 2 --size 192 --seed 3 --set pose.yaw.min=-40 --set pose.yaw.max=40 --quiet";
    EXPECT_EQ(run_command(cmd, &out), 0) << cmd << "\n" << out;
    return data;
}

TEST(CmdFrontalise, BatchWritesEveryOutputAndCarriesOnPastBadImages) {
    const auto dir = fresh_temp_dir("cmd_frontalise_batch");
    const fs::path data = make_renders(dir);
    // A corrupt "PNG" between the two good images, and a file that does not exist.
    {
        std::ofstream bad(data / "images" / "s00000000b.png");
        bad << "not a png";
    }
    const fs::path out = dir / "out";
    std::string log;
    const std::string cmd = cli_path().string() + " frontalise --landmarks pts " + (data / "images").string() + " " +
                            (dir / "missing.png").string() + " --out " + out.string() +
                            " --isomap-size 128 --size 96 --mirror-fill --background 128,128,128 --json " + (dir / "summary.json").string();
    EXPECT_EQ(run_command(cmd, &log), 1) << log;
    EXPECT_NE(log.find("s00000000b.png: cannot read the image"), std::string::npos) << log;
    EXPECT_NE(log.find("missing.png: file not found"), std::string::npos) << log;
    EXPECT_NE(log.find("2 of 4 images failed"), std::string::npos) << log;
    for (const char* stem : {"s00000000", "s00000001"})
        for (const char* suffix : {".isomap.png", ".frontal.png", ".glb", ".json"})
            EXPECT_TRUE(fs::exists(out / (std::string(stem) + suffix))) << stem << suffix;
    EXPECT_FALSE(fs::exists(out / "s00000000b.json"));
    for (const auto& entry : fs::directory_iterator(out)) EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();

    const cv::Mat isomap = cv::imread((out / "s00000001.isomap.png").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(isomap.type(), CV_8UC4);
    EXPECT_EQ(isomap.cols, 128);
    EXPECT_GT(cv::countNonZero(isomap.reshape(1, static_cast<int>(isomap.total())).col(3)), 128 * 128 / 5);
    const cv::Mat frontal = cv::imread((out / "s00000001.frontal.png").string(), cv::IMREAD_COLOR);
    EXPECT_EQ(frontal.cols, 96);
    EXPECT_EQ(frontal.at<cv::Vec3b>(0, 0), cv::Vec3b(128, 128, 128)) << "the corner shows the background";

    const auto face = read_json(out / "s00000001.json");
    for (const char* key : {"yaw_deg", "pitch_deg", "roll_deg", "rotation", "alpha", "psi", "landmarks", "fit_ms", "isomap_ms", "frontal_ms",
                            "fit_cpu_ms", "mirror_filled_texels"})
        EXPECT_TRUE(face.contains(key)) << key;
    EXPECT_EQ(face["landmarks"].size(), 68u);
    const auto summary = read_json(dir / "summary.json");
    EXPECT_EQ(summary["faces"], 2);
    EXPECT_EQ(summary["failed"], 2);
}

TEST(CmdFrontalise, ImageWithoutAFaceIsAnErrorLineNamingIt) {
    const auto dir = fresh_temp_dir("cmd_frontalise_noface");
    const fs::path blank = dir / "blank.png";
    cv::imwrite(blank.string(), cv::Mat(120, 160, CV_8UC3, cv::Scalar(90, 120, 150)));
    std::string log;
    const int status = run_command(cli_path().string() + " frontalise --landmarks dlib " + blank.string() + " --out " + (dir / "out").string(), &log);
    EXPECT_EQ(status, 1) << log;
    EXPECT_NE(log.find("blank.png: no face found"), std::string::npos) << log;
    EXPECT_FALSE(fs::exists(dir / "out" / "blank.json"));
}

TEST(CmdFrontalise, BadLandmarksAndUsageErrors) {
    const auto dir = fresh_temp_dir("cmd_frontalise_usage");
    const fs::path image = dir / "face.png";
    cv::imwrite(image.string(), cv::Mat(64, 64, CV_8UC3, cv::Scalar::all(100)));
    {
        std::ofstream pts(dir / "three.pts");
        pts << "version: 1\nn_points: 3\n{\n1 1\n2 2\n3 3\n}\n";
    }
    std::string log;
    EXPECT_EQ(run_command(cli_path().string() + " frontalise --pts " + (dir / "three.pts").string() + " " + image.string() + " --out " +
                              (dir / "out").string(),
                          &log),
              1)
        << log;
    EXPECT_NE(log.find("three.pts: has 3 points, expected 68"), std::string::npos) << log;
    // No landmark source, two sources, or no images: usage errors.
    EXPECT_EQ(run_command(cli_path().string() + " frontalise " + image.string() + " --out " + (dir / "out").string(), &log), 2) << log;
    EXPECT_EQ(run_command(cli_path().string() + " frontalise --landmarks dlib --pts " + (dir / "three.pts").string() + " " + image.string() +
                              " --out " + (dir / "out").string(),
                          &log),
              2)
        << log;
    EXPECT_EQ(run_command(cli_path().string() + " frontalise --landmarks pts --out " + (dir / "out").string(), &log), 2) << log;
    EXPECT_EQ(run_command(cli_path().string() + " frontalise --help", &log), 0) << log;
}

TEST(CmdFrontalise, RealPhotographWithTheSurreyModel) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    FACESYNTH_REQUIRE_SHARED_DATA(photos, "real/lfpw_superviseddescent");
    const auto dir = fresh_temp_dir("cmd_frontalise_real");
    std::string log;
    const std::string cmd = cli_path().string() + " frontalise --model " + sfm.string() + " --pts " + (photos / "image_0001.pts").string() + " " +
                            (photos / "image_0001.png").string() + " --out " + dir.string() + " --mirror-fill --quiet";
    ASSERT_EQ(run_command(cmd, &log), 0) << log;
    const auto face = read_json(dir / "image_0001.json");
    EXPECT_LT(face["reprojection_rms_px"].get<double>(), 10.0);
    // The Surrey layout is the face only: most of it is seen in a near-frontal photograph.
    EXPECT_GT(face["visible_texels"].get<double>(), 0.5 * face["covered_texels"].get<double>());
    const cv::Mat frontal = cv::imread((dir / "image_0001.frontal.png").string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(frontal.empty());
    EXPECT_GT(cv::mean(frontal(cv::Rect(96, 96, 64, 64)))[2], 60) << "skin in the middle of the frontal view";
}

TEST(CmdFrontalise, EvalWritesFlatKeysAndMirrorFillHelpsAtLargeYaw) {
    const auto dir = fresh_temp_dir("cmd_frontalise_eval");
    std::string log;
    const std::string cmd = cli_path().string() + " eval frontalise --count 1 --isomap-size 256 --size 128 --image-size 256 --quiet --json " +
                            (dir / "eval.json").string() + " --plot " + (dir / "plot.svg").string();
    ASSERT_EQ(run_command(cmd, &log), 0) << log;
    const auto j = read_json(dir / "eval.json");
    for (const char* key : {"yaw_0_10_psnr", "yaw_0_10_ssim", "yaw_0_10_l1", "yaw_0_10_psnr_mirror", "yaw_60_70_psnr", "yaw_60_70_psnr_mirror",
                            "yaw_30_40_isomap_l1", "yaw_30_40_isomap_coverage", "all_psnr", "all_cpu_ms_per_face", "texture"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["all_count"], 7);
    // At 60-70° half the face is hidden: black without filling, the mirror side with it.
    EXPECT_GT(j["yaw_60_70_psnr_mirror"].get<double>(), j["yaw_60_70_psnr"].get<double>() + 5);
    EXPECT_GT(j["yaw_0_10_ssim_mirror"].get<double>(), 0.7);
    EXPECT_LT(j["yaw_0_10_isomap_l1"].get<double>(), 6.0);
    EXPECT_TRUE(fs::exists(dir / "plot.svg"));
}

// The detected-landmark run sees each view with more around the face (the same camera, a larger
// image): at the default framing the multi-view detector then finds most faces, where on the tight
// standard views it found about one in six; every view is either scored or counted as a miss.
TEST(CmdFrontalise, EvalWithARegressorDetectsOnViewsWithContext) {
    const auto dir = fresh_temp_dir("cmd_frontalise_eval_detected");
    std::string log;
    const std::string cmd = cli_path().string() + " eval frontalise --count 1 --isomap-size 256 --size 128 --image-size 192 --quiet" +
                            " --regressor dlib --detector multiview --json " + (dir / "eval.json").string();
    ASSERT_EQ(run_command(cmd, &log), 0) << log;
    const auto j = read_json(dir / "eval.json");
    EXPECT_EQ(j.at("framing").get<double>(), 1.5);
    EXPECT_EQ(j.at("detection_framing").get<double>(), 2.5);
    EXPECT_EQ(j.at("detection_image_size").get<int>(), 320);  // 192 · 2.5 / 1.5
    EXPECT_EQ(j.at("detected_all_count").get<int>() + j.at("detector_misses").get<int>(), 7);
    // More than half (one face: 5 of 7 before the brows were lengthened, 4 since).
    EXPECT_GE(j.at("detected_all_count").get<int>(), 4) << log;
    int misses = 0;
    for (int b = 0; b < 7; ++b) misses += j.at("detector_misses_yaw_" + std::to_string(10 * b) + "_" + std::to_string(10 * b + 10)).get<int>();
    EXPECT_EQ(misses, j.at("detector_misses").get<int>());
    // A detection framing tighter than the standard view is a usage error.
    EXPECT_NE(run_command(cli_path().string() + " eval frontalise --count 1 --quiet --regressor dlib --framing 2 --detection-framing 1.5", &log), 0);
}

}  // namespace
