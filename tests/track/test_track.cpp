// Video: frame sources and their bad inputs, the 1-euro smoothing, identity fusion over views, and
// the tracker on a rendered clip (one face kept, the detector only on schedule).
#include "common/test_data.h"
#include "core/error.h"
#include "core/random.h"
#include "fit/fit.h"
#include "morph/camera.h"
#include "morph/model_io.h"
#include "morph/pose.h"
#include "track/frame_source.h"
#include "track/isomap_fusion.h"
#include "track/smoothing.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace facesynth::track {
namespace {

namespace fs = std::filesystem;

void write_frames_video(const fs::path& path, int frames) {
    cv::VideoWriter writer(path.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < frames; ++i) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar(i * 4, 100, 200)));
}

TEST(FrameSource, ReadsFoldersAndVideosAndRefusesBadInputsByName) {
    const fs::path dir = testkit::fresh_temp_dir("track_sources");
    fs::create_directories(dir / "frames");
    for (int i = 0; i < 3; ++i) cv::imwrite((dir / "frames" / ("f" + std::to_string(i) + ".png")).string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar(i, i, i)));
    FrameSource folder((dir / "frames").string(), 12.5);
    cv::Mat frame;
    int read = 0;
    while (folder.next(frame)) {
        EXPECT_EQ(frame.at<cv::Vec3b>(0, 0)[0], read);  // name order
        ++read;
    }
    EXPECT_EQ(read, 3);
    EXPECT_EQ(folder.fps(), 12.5);

    write_frames_video(dir / "clip.avi", 30);
    FrameSource video((dir / "clip.avi").string());
    read = 0;
    while (video.next(frame)) ++read;
    EXPECT_EQ(read, 30);
    EXPECT_NEAR(video.fps(), 25, 1e-6);

    // Cut off: the container announces 30 frames, the stream stops early (or cannot be opened).
    const auto size = fs::file_size(dir / "clip.avi");
    fs::copy_file(dir / "clip.avi", dir / "cut.avi");
    fs::resize_file(dir / "cut.avi", size / 2);
    const std::string cut = testkit::error_message_of([&] {
        FrameSource source((dir / "cut.avi").string());
        while (source.next(frame)) {
        }
    });
    EXPECT_NE(cut.find("cut.avi"), std::string::npos) << cut;

    // A video without frames: refused when opened or at its first frame, naming the file.
    {
        cv::VideoWriter empty((dir / "empty.avi").string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25, cv::Size(64, 48));
    }
    const std::string zero = testkit::error_message_of([&] {
        FrameSource source((dir / "empty.avi").string());
        while (source.next(frame)) {
        }
    });
    EXPECT_NE(zero.find("empty.avi"), std::string::npos) << zero;
    std::ofstream(dir / "garbage.mp4") << "not a video at all";
    EXPECT_NE(testkit::error_message_of([&] { FrameSource source((dir / "garbage.mp4").string()); }).find("garbage.mp4"), std::string::npos);
    fs::create_directories(dir / "empty");
    EXPECT_NE(testkit::error_message_of([&] { FrameSource source((dir / "empty").string()); }).find("no images"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([&] { FrameSource source((dir / "missing.mp4").string()); }).find("not found"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([&] { FrameSource source("57"); }).find("camera 57"), std::string::npos);
    cv::imwrite((dir / "frames" / "f3.png").string(), cv::Mat(8, 8, CV_8UC3));
    std::ofstream(dir / "frames" / "f4.png") << "broken";
    const std::string broken = testkit::error_message_of([&] {
        FrameSource source((dir / "frames").string());
        while (source.next(frame)) {
        }
    });
    EXPECT_NE(broken.find("f4.png"), std::string::npos) << broken;
}

TEST(LandmarkSmoother, RemovesJitterOnStillFacesAndFollowsMotion) {
    LandmarkSmoother smoother;
    core::Rng rng(1, 0, 0);
    Eigen::Matrix2Xd still = Eigen::Matrix2Xd::Constant(2, 68, 100.0);
    double raw_jitter = 0, smoothed_jitter = 0;
    Eigen::Matrix2Xd previous_raw = still, previous_out = still;
    for (int f = 0; f < 120; ++f) {
        Eigen::Matrix2Xd noisy = still;
        for (Eigen::Index i = 0; i < noisy.size(); ++i) noisy.data()[i] += rng.normal(0, 0.5);  // half a pixel on a 100-pixel face
        const Eigen::Matrix2Xd out = smoother.filter(noisy, 1.0 / 30, 100);
        if (f > 30) {
            raw_jitter += (noisy - previous_raw).colwise().norm().mean();
            smoothed_jitter += (out - previous_out).colwise().norm().mean();
        }
        previous_raw = noisy;
        previous_out = out;
    }
    EXPECT_LT(smoothed_jitter, 0.3 * raw_jitter);
    // A face moving at 2 widths per second: the output stays within 2 % of the width of it.
    smoother.reset();
    for (int f = 0; f < 60; ++f) {
        const Eigen::Matrix2Xd moving = Eigen::Matrix2Xd::Constant(2, 68, 100.0 + 200.0 * 2.0 * f / 30.0);
        const Eigen::Matrix2Xd out = smoother.filter(moving, 1.0 / 30, 100);
        if (f > 10) { EXPECT_LT((out - moving).cwiseAbs().maxCoeff(), 2.0) << "frame " << f; }
    }
}

TEST(IsomapFusion, TheMostFrontalViewOfATexelWins) {
    IsomapFusion fusion;
    cv::Mat left(4, 4, CV_8UC4, cv::Scalar(10, 10, 10, 0)), right(4, 4, CV_8UC4, cv::Scalar(20, 20, 20, 0));
    left.colRange(0, 2).setTo(cv::Scalar(10, 10, 10, 200));
    left.colRange(2, 4).setTo(cv::Scalar(11, 11, 11, 40));
    right.colRange(1, 4).setTo(cv::Scalar(20, 20, 20, 150));
    fusion.add(left);
    fusion.add(right);
    EXPECT_EQ(fusion.frames(), 2);
    EXPECT_EQ(fusion.fused().at<cv::Vec4b>(0, 0), cv::Vec4b(10, 10, 10, 200));  // seen by the first only
    EXPECT_EQ(fusion.fused().at<cv::Vec4b>(0, 1), cv::Vec4b(10, 10, 10, 200));  // both: the first more frontally
    EXPECT_EQ(fusion.fused().at<cv::Vec4b>(0, 3), cv::Vec4b(20, 20, 20, 150));  // both: the second more frontally
    cv::Mat layout(4, 4, CV_8UC1, cv::Scalar(255));
    EXPECT_DOUBLE_EQ(fusion.coverage(layout), 1.0);
    EXPECT_THROW(fusion.add(cv::Mat(8, 8, CV_8UC4, cv::Scalar::all(0))), core::Error);
    EXPECT_THROW(fusion.add(cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(0))), core::Error);
}

// The identity evidence of several views of one face: the fused estimate gets closer to the true
// shape as views accumulate, and closer than the single views' own fits.
TEST(IdentityFusion, ConvergesTowardTheTrueShapeAsViewsAccumulate) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const fit::Fitter fitter(model);
    core::Rng rng(7, 0, 0);
    std::vector<float> alpha(static_cast<std::size_t>(model.num_shape_components()));
    for (float& a : alpha) a = static_cast<float>(rng.normal(0, 1.0));
    const Eigen::Matrix3Xf truth = model.shape_instance(alpha, {});
    const auto rmse = [&](const std::vector<float>& a) {
        return std::sqrt((model.shape_instance(a, {}) - truth).colwise().squaredNorm().mean());
    };
    fit::FitOptions options;
    fit::FitOptions identity_options;
    for (int i = 17; i < 68; ++i) identity_options.subset.push_back(i);
    const morph::Intrinsics k = morph::intrinsics_from_fov(10, 512, 512);
    fit::IdentityEvidence evidence;
    std::vector<double> fused_error, single_error;
    for (int view = 0; view < 12; ++view) {
        morph::CameraPose pose;
        pose.rotation = morph::rotation_from_euler({-40.0 + 80.0 * view / 11, rng.uniform(-10, 10), rng.uniform(-5, 5)});
        pose.translation = Eigen::Vector3d(0, 0, 1500);
        Eigen::Matrix2Xd landmarks = morph::project(k, pose, model.landmark_positions(truth));
        for (Eigen::Index i = 0; i < landmarks.size(); ++i) landmarks.data()[i] += rng.normal(0, 1.0);
        const fit::FitResult fitted = fitter.fit(landmarks, options);
        single_error.push_back(rmse(fitted.alpha));
        evidence += fit::identity_evidence(model, fitted.camera, landmarks, identity_options, fitted.psi);
        fused_error.push_back(rmse(fit::solve_identity(evidence, options.lambda, model.num_shape_components())));
    }
    EXPECT_LT(fused_error.back(), 0.8 * fused_error.front());
    EXPECT_LT(fused_error.back(), *std::min_element(single_error.begin(), single_error.end()));
    EXPECT_THROW((void)fit::solve_identity(evidence, 30, 3), core::Error);
}

// A rendered clip through the CLI: one face from start to end, the detector only every
// --detect-every frames, identity fused over every frame; bad inputs leave no output folder.
TEST(TrackCli, FollowsARenderedClipWithOneFaceAndScheduledDetection) {
    const fs::path dir = testkit::fresh_temp_dir("track_cli");
    const std::string cli = testkit::cli_path().string();
    std::string log;
    ASSERT_EQ(testkit::run_command(cli + " synth -q -o " + (dir / "clip").string() +
                                       " -n 40 --sequence 40 --size 256 --seed 3 --set pose.yaw.min=-20 --set pose.yaw.max=20 --set degrade.blur_probability=0",
                                   &log),
              0)
        << log;
    ASSERT_EQ(testkit::run_command(cli + " track -q " + (dir / "clip" / "images").string() + " -o " + (dir / "out").string() +
                                       " --detector dlib --detect-every 10 --outputs landmarks,pose,isomap,frontal --isomap-size 128 --frontal-size 96 --json " +
                                       (dir / "summary.json").string(),
                                   &log),
              0)
        << log;
    const auto summary = nlohmann::json::parse(std::ifstream(dir / "summary.json"));
    EXPECT_EQ(summary["frames"], 40);
    EXPECT_EQ(summary["frames_with_face"], 40);
    EXPECT_EQ(summary["faces"], 1);
    EXPECT_EQ(summary["losses"], 0);
    EXPECT_EQ(summary["detector_runs"], 4);
    EXPECT_EQ(summary["fallback_detector_runs"], 0);  // dlib finds the face every time: no multi-view fallback
    for (const char* key : {"fps", "ms_per_frame", "decode_ms_per_frame", "texture_ms_per_frame"}) EXPECT_GT(summary[key].get<double>(), 0) << key;
    EXPECT_GT(summary["isomap_coverage"].get<double>(), 0.3);
    for (const auto& [video, side] : {std::pair{"isomap.avi", 128}, std::pair{"frontal.avi", 96}}) {
        cv::VideoCapture capture((dir / "out" / video).string());
        ASSERT_TRUE(capture.isOpened()) << video;
        EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_COUNT), 40) << video;
        EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_WIDTH), side) << video;
    }
    std::ifstream lines(dir / "out" / "faces.jsonl");
    std::string line;
    int frames = 0;
    while (std::getline(lines, line)) {
        const auto j = nlohmann::json::parse(line);
        EXPECT_EQ(j["frame"], frames);
        ASSERT_EQ(j["faces"].size(), 1u);
        EXPECT_EQ(j["faces"][0]["id"], 0);
        EXPECT_EQ(j["faces"][0]["identity_frames"], frames + 1);
        EXPECT_EQ(j["faces"][0]["landmarks"].size(), 68u);
        EXPECT_EQ(j["faces"][0]["detected"], frames % 10 == 0);
        ++frames;
    }
    EXPECT_EQ(frames, 40);

    // Bad inputs: a clear error naming the input, exit 1, and no output folder.
    std::ofstream(dir / "broken.mp4") << "no video here";
    for (const std::string& input : {(dir / "broken.mp4").string(), (dir / "missing.mp4").string(), std::string("57")}) {
        EXPECT_EQ(testkit::run_command(cli + " track -q " + input + " -o " + (dir / "bad").string(), &log), 1) << input;
        EXPECT_NE(log.find(input == "57" ? "camera 57" : input), std::string::npos) << log;
        EXPECT_FALSE(fs::exists(dir / "bad"));
    }
    EXPECT_EQ(testkit::run_command(cli + " track -q " + (dir / "clip" / "images").string() + " -o " + (dir / "out").string(), &log), 1);
    EXPECT_NE(log.find("exists already"), std::string::npos) << log;
    EXPECT_EQ(testkit::run_command(cli + " track " + (dir / "clip" / "images").string() + " -o " + (dir / "o2").string() + " --outputs landmarks,depth", &log), 1);
    EXPECT_NE(log.find("depth"), std::string::npos) << log;
    for (const auto& entry : fs::directory_iterator(dir)) EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}


// Two faces side by side: both followed with their own ids, and the isomap and frontal videos give
// each its own tile (--max-faces tiles wide).
TEST(TrackCli, TwoFacesEachGetATileOfTheTextureVideos) {
    const fs::path dir = testkit::fresh_temp_dir("track_two");
    const std::string cli = testkit::cli_path().string();
    std::string log;
    for (const char* seed : {"3", "4"})
        ASSERT_EQ(testkit::run_command(cli + " synth -q -o " + (dir / (std::string("clip") + seed)).string() + " -n 12 --sequence 12 --size 256 --seed " +
                                           seed + " --set pose.yaw.min=-15 --set pose.yaw.max=15 --set degrade.blur_probability=0",
                                       &log),
                  0)
            << log;
    fs::create_directories(dir / "frames");
    for (const auto& entry : fs::directory_iterator(dir / "clip3" / "images")) {
        cv::Mat both;
        cv::hconcat(cv::imread(entry.path().string()), cv::imread((dir / "clip4" / "images" / entry.path().filename()).string()), both);
        ASSERT_TRUE(cv::imwrite((dir / "frames" / entry.path().filename()).string(), both));
    }
    ASSERT_EQ(testkit::run_command(cli + " track -q " + (dir / "frames").string() + " -o " + (dir / "out").string() +
                                       " --detector dlib --max-faces 2 --outputs landmarks,isomap,frontal --isomap-size 64 --frontal-size 48 --json " +
                                       (dir / "summary.json").string(),
                                   &log),
              0)
        << log;
    const auto summary = nlohmann::json::parse(std::ifstream(dir / "summary.json"));
    EXPECT_EQ(summary["faces"], 2);
    EXPECT_EQ(summary["frames_with_face"], 12);
    std::ifstream lines(dir / "out" / "faces.jsonl");
    std::string line;
    while (std::getline(lines, line)) EXPECT_EQ(nlohmann::json::parse(line)["faces"].size(), 2u) << line;
    for (const auto& [video, side] : {std::pair{"isomap.avi", 64}, std::pair{"frontal.avi", 48}}) {
        cv::VideoCapture capture((dir / "out" / video).string());
        ASSERT_TRUE(capture.isOpened()) << video;
        EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_WIDTH), 2 * side) << video;
        cv::Mat frame;
        int frames = 0;
        while (capture.read(frame)) {
            for (int tile = 0; tile < 2; ++tile)
                EXPECT_GT(cv::countNonZero(cv::Mat(frame(cv::Rect(tile * side, 0, side, side)).reshape(1) > 40)), side * side / 10)
                    << video << " frame " << frames << " tile " << tile;
            ++frames;
        }
        EXPECT_EQ(frames, 12) << video;
    }
}

}  // namespace
}  // namespace facesynth::track
