// Face profiling on renders of the built-in model used as photographs (their landmarks are exact), and
// the dataset driver's handling of folders, resumption, shards and bad photographs.
#include "core/atomic_file.h"
#include "core/error.h"
#include "frontal/evaluate.h"
#include "morph/builtin.h"
#include "morph/landmarks.h"
#include "profile/dataset.h"
#include "profile/scene.h"
#include "synth/tar.h"
#include "render/landmarks.h"
#include "common/test_data.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>

namespace facesynth::profile {
namespace {

namespace fs = std::filesystem;

class ProfileTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        model_ = std::make_unique<morph::MorphableModel>(morph::builtin_model());
        frontaliser_ = std::make_unique<frontal::Frontaliser>(*model_);
        face_ = std::make_unique<frontal::TexturedFace>(frontal::make_textured_face(*model_, *frontaliser_, 5, 1, 256));
        profiler_ = std::make_unique<Profiler>(*model_);
    }
    static void TearDownTestSuite() {
        profiler_.reset();
        face_.reset();
        frontaliser_.reset();
        model_.reset();
    }
    // A "photograph": the textured face at `yaw` over a grey background, with its exact contour-mode landmarks.
    static frontal::SyntheticView photo(double yaw) {
        frontal::ViewOptions options;
        options.framing = 3.0;  // the whole head and some background, as photographs show it
        const morph::JawContourRegion region = morph::jaw_contour_region(*model_);
        return frontal::render_view(frontaliser_->renderer(), *model_, *face_, yaw, options, &region);
    }
    // The photograph resampled into a scene's view (its crop and scale).
    static cv::Mat photo_in_view(const cv::Mat& photo_bgr, const PhotoScene& scene, int size) {
        // view = (photo + 0.5) * scale - 0.5 - (roi_origin * scale + view_origin)
        const Eigen::Vector2d offset = scene.roi_origin.cwiseProduct(scene.scale) + scene.view_origin;
        cv::Mat map = (cv::Mat_<double>(2, 3) << scene.scale.x(), 0, 0.5 * scene.scale.x() - 0.5 - offset.x(), 0, scene.scale.y(),
                       0.5 * scene.scale.y() - 0.5 - offset.y());
        cv::Mat out;
        cv::warpAffine(photo_bgr, out, map, cv::Size(size, size), cv::INTER_AREA, cv::BORDER_REPLICATE);
        return out;
    }
    static Eigen::Matrix2Xd view_to_photo(const Eigen::Matrix2Xd& view_points, const PhotoScene& scene) {
        const Eigen::Vector2d offset = scene.roi_origin.cwiseProduct(scene.scale) + scene.view_origin;
        Eigen::Matrix2Xd out(2, view_points.cols());
        for (Eigen::Index k = 0; k < view_points.cols(); ++k)
            out.col(k) = ((view_points.col(k) + offset).array() + 0.5).matrix().cwiseQuotient(scene.scale) - Eigen::Vector2d::Constant(0.5);
        return out;
    }
    static inline std::unique_ptr<morph::MorphableModel> model_;
    static inline std::unique_ptr<frontal::Frontaliser> frontaliser_;
    static inline std::unique_ptr<frontal::TexturedFace> face_;
    static inline std::unique_ptr<Profiler> profiler_;
};

double psnr_inside(const cv::Mat& a_bgr, const cv::Mat& b_bgr, const cv::Mat& mask) {
    double sum = 0;
    std::int64_t n = 0;
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            if (!mask.at<std::uint8_t>(y, x)) continue;
            for (int c = 0; c < 3; ++c) {
                const double d = a_bgr.at<cv::Vec3b>(y, x)[c] - b_bgr.at<cv::Vec3b>(y, x)[c];
                sum += d * d;
            }
            n += 3;
        }
    EXPECT_GT(n, 3000);
    return 10 * std::log10(255.0 * 255.0 / std::max(sum / static_cast<double>(std::max<std::int64_t>(n, 1)), 1e-9));
}

TEST_F(ProfileTest, SourcePoseReproducesThePhotographInsideTheFaceAndItsAnnotations) {
    const frontal::SyntheticView p = photo(20);
    ProfileOptions options;
    options.isomap_size = 512;
    const PhotoScene scene = profiler_->prepare(p.image, p.landmarks, options);
    const ProfiledView view = profiler_->render_view(scene, Profiler::source_pose(scene), options);
    ASSERT_EQ(view.image.rows, options.size);
    cv::Mat expected = photo_in_view(p.image, scene, options.size), got;
    cv::cvtColor(view.image, got, cv::COLOR_RGB2BGR);
    cv::Mat inside;
    cv::erode(view.face_mask == 255, inside, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));
    // Measured 43.9 dB (the texture is the photograph resampled twice: isomap, render).
    EXPECT_GT(psnr_inside(expected, got, inside), 38.0);
    // With the residual, the labels at the source pose are the annotations.
    const Eigen::Matrix2Xd annotated = view_to_photo(view.landmarks_contour, scene);
    EXPECT_LT((annotated - p.landmarks).colwise().norm().maxCoeff(), 1e-6);
    EXPECT_LT((view.residual_px - scene.residual_px).cwiseAbs().maxCoeff(), 1e-9);
    // Without it, they are the fitted model's, within the fit's error of the annotations.
    ProfileOptions plain = options;
    plain.apply_residual = false;
    const ProfiledView model_only = profiler_->render_view(scene, Profiler::source_pose(scene), plain);
    const double iod = morph::inter_ocular_distance(p.landmarks);
    EXPECT_LT((view_to_photo(model_only.landmarks_contour, scene) - p.landmarks).colwise().norm().mean(), 0.03 * iod);
    EXPECT_NEAR(scene.camera.angles.yaw, 20, 5);
}

TEST_F(ProfileTest, LandmarksAtANewPoseEqualADirectRenderOfTheFittedMesh) {
    const frontal::SyntheticView p = photo(-10);
    ProfileOptions options;
    options.apply_residual = false;
    const PhotoScene scene = profiler_->prepare(p.image, p.landmarks, options);
    const ViewPose pose{55, scene.camera.angles.pitch + 5, scene.camera.angles.roll};
    const ProfiledView view = profiler_->render_view(scene, pose, options);

    render::Renderer renderer;
    const render::Camera camera = Profiler::view_camera(scene, pose, options.size);
    morph::Mesh mesh;
    mesh.vertices = scene.vertices;
    mesh.triangles = model_->triangles;
    const render::Frame frame = renderer.render(mesh, camera);
    const morph::JawContourRegion region = morph::jaw_contour_region(*model_);
    const render::ProjectedLandmarks direct = render::project_landmarks(model_->landmarks, mesh, camera, frame, {}, &region);
    EXPECT_LT((view.landmarks_fixed - direct.pixels).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((view.landmarks_contour - direct.contour_pixels).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_EQ(view.visible_fixed, direct.visible);
    EXPECT_EQ(view.visible_contour, direct.contour_visible);
    // The nose turned toward the image's right: the jaw points on that side (iBUG 12-17) are hidden.
    int hidden = 0;
    for (int k = 11; k < 17; ++k) hidden += view.visible_fixed[static_cast<std::size_t>(k)] == 0;
    EXPECT_GE(hidden, 4);
}

TEST_F(ProfileTest, TurningByThetaAndBackReturnsToTheSourceLandmarks) {
    const frontal::SyntheticView p = photo(10);
    ProfileOptions options;
    const PhotoScene scene = profiler_->prepare(p.image, p.landmarks, options);
    ViewPose turned = Profiler::source_pose(scene);
    turned.yaw += 25;
    const ProfiledView there = profiler_->render_view(scene, turned, options);
    cv::Mat there_bgr;
    cv::cvtColor(there.image, there_bgr, cv::COLOR_RGB2BGR);

    const PhotoScene back_scene = profiler_->prepare(there_bgr, there.landmarks_contour, options);
    ViewPose back = Profiler::source_pose(back_scene);
    back.yaw -= 25;
    const ProfiledView returned = profiler_->render_view(back_scene, back, options);
    const Eigen::Matrix2Xd in_photo = view_to_photo(view_to_photo(returned.landmarks_contour, back_scene), scene);
    const double iod = morph::inter_ocular_distance(p.landmarks);
    const Eigen::VectorXd error = (in_photo - p.landmarks).colwise().norm().transpose();
    // Measured: mean 0.0017, largest 0.0079 inter-ocular distances (the second fit's residual goes
    // back along with it).
    EXPECT_LT(error.mean(), 0.01 * iod);
    EXPECT_LT(error.maxCoeff(), 0.03 * iod);
}

TEST_F(ProfileTest, TurnedViewsShowLessOfThePhotographAndSayHowMuchWasFilled) {
    const frontal::SyntheticView p = photo(0);
    ProfileOptions options;
    const PhotoScene scene = profiler_->prepare(p.image, p.landmarks, options);
    const ProfiledView front = profiler_->render_view(scene, Profiler::source_pose(scene), options);
    const ProfiledView side = profiler_->render_view(scene, {75, 0, 0}, options);
    // Measured: filled 0.008 frontal, 0.081 at 75°; stretched 0 and 0.54 (the side of the head, seen
    // edge-on in the photograph, fills half the view).
    EXPECT_LT(front.filled_share, 0.03);
    EXPECT_GT(side.filled_share, front.filled_share + 0.04);
    EXPECT_GT(front.face_share, 0.05);
    EXPECT_LT(front.stretched_share, 0.01);
    EXPECT_GT(side.stretched_share, 0.3);
}

TEST_F(ProfileTest, ALightFromOneSideBrightensThatSideOfTheFaceAndLeavesTheBackground) {
    const frontal::SyntheticView p = photo(0);
    ProfileOptions options;
    const PhotoScene scene = profiler_->prepare(p.image, p.landmarks, options);
    const ViewPose pose = Profiler::source_pose(scene);
    const ProfiledView plain = profiler_->render_view(scene, pose, options);
    ViewLight from_right;
    from_right.strength = 0.8;
    from_right.azimuth = 60;
    const ProfiledView lit = profiler_->render_view(scene, pose, options, from_right);
    // Mean grey of the face's pixels left and right of the nose tip (landmark 31), as the view shows them.
    const double nose_x = plain.landmarks_contour(0, 30);
    const auto side_means = [&](const ProfiledView& view) {
        cv::Mat grey;
        cv::cvtColor(view.image, grey, cv::COLOR_RGB2GRAY);
        double sums[2] = {0, 0}, counts[2] = {0, 0};
        for (int y = 0; y < grey.rows; ++y)
            for (int x = 0; x < grey.cols; ++x)
                if (plain.face_mask.at<std::uint8_t>(y, x) == 255) {
                    const int side = x > nose_x ? 1 : 0;
                    sums[side] += grey.at<std::uint8_t>(y, x);
                    counts[side] += 1;
                }
        return std::pair{sums[0] / counts[0], sums[1] / counts[1]};
    };
    const auto [plain_left, plain_right] = side_means(plain);
    const auto [lit_left, lit_right] = side_means(lit);
    // Measured: left 80.8 -> 54.4, right 80.8 -> 94.4; the corner 70 -> 67.
    EXPECT_GT(lit_right - plain_right, 5) << plain_right << " -> " << lit_right;
    EXPECT_LT(lit_left - plain_left, lit_right - plain_right - 5) << plain_left << " -> " << lit_left;
    // The picture away from the head (whose depth is a guess) changes far less; the landmarks do not move.
    const cv::Vec3b corner_plain = plain.image.at<cv::Vec3b>(2, 2), corner_lit = lit.image.at<cv::Vec3b>(2, 2);
    for (int c = 0; c < 3; ++c) EXPECT_LT(std::abs(corner_lit[c] - corner_plain[c]), 0.25 * (plain_left - lit_left)) << c;
    EXPECT_TRUE(lit.landmarks_contour.isApprox(plain.landmarks_contour));
    // Strength 0 is the plain view; out of range is an error.
    EXPECT_EQ(cv::norm(profiler_->render_view(scene, pose, options, ViewLight{}).image, plain.image, cv::NORM_INF), 0);
    ViewLight too_strong;
    too_strong.strength = 1.5;
    EXPECT_NE(testkit::error_message_of([&] { (void)profiler_->render_view(scene, pose, options, too_strong); }).find("strength"), std::string::npos);
}

TEST(ProfileLights, PlannedLightsStayInRangeAndDependOnSeedAndIndexOnly) {
    ViewPlan plan;
    EXPECT_FALSE(plan_light(plan, 1, 0).changes());
    plan.relight = 0.5;
    bool some_left = false, some_right = false;
    for (int i = 0; i < 100; ++i) {
        const ViewLight light = plan_light(plan, 3, i);
        EXPECT_GE(light.strength, 0);
        EXPECT_LE(light.strength, 0.5);
        EXPECT_GE(light.azimuth, -75);
        EXPECT_LE(light.azimuth, 75);
        EXPECT_GE(light.elevation, -20);
        EXPECT_LE(light.elevation, 50);
        some_left |= light.azimuth < -30;
        some_right |= light.azimuth > 30;
        EXPECT_EQ(plan_light(plan, 3, i).azimuth, light.azimuth);
    }
    EXPECT_TRUE(some_left && some_right);
    EXPECT_NE(plan_light(plan, 4, 0).azimuth, plan_light(plan, 3, 0).azimuth);
}

TEST(ProfileYaws, ParsesRangesAndListsAndRefusesNonsense) {
    EXPECT_EQ(parse_yaws("-90:90:45"), (std::vector<double>{-90, -45, 0, 45, 90}));
    EXPECT_EQ(parse_yaws("10,-20"), (std::vector<double>{10, -20}));
    EXPECT_NE(testkit::error_message_of([] { (void)parse_yaws("0:10:0"); }).find("step"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([] { (void)parse_yaws("a,b"); }).find("'a' is not a number"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([] { (void)parse_yaws("200"); }).find("outside"), std::string::npos);
    ViewPlan plan;
    plan.yaws = {-60, 0, 60};
    plan.max_turn = 45;
    EXPECT_FALSE(plan_view(plan, {10, 0, 0}, 1, 0).has_value());  // -60 is 70 from 10
    EXPECT_DOUBLE_EQ(plan_view(plan, {10, 0, 0}, 1, 1)->yaw, 0);
    ViewPlan random;
    random.views_per_photo = 4;
    random.max_turn = 30;
    random.toward_profile = false;
    double lowest = 90;
    for (int i = 0; i < 50; ++i) {
        const auto pose = plan_view(random, {80, 3, 1}, 7, i);
        ASSERT_TRUE(pose.has_value());
        EXPECT_GE(pose->yaw, 50);
        EXPECT_LE(pose->yaw, 90);
        EXPECT_EQ(pose->pitch, 3);
        EXPECT_EQ(plan_view(random, {80, 3, 1}, 7, i)->yaw, pose->yaw);
        lowest = std::min(lowest, pose->yaw);
    }
    EXPECT_LT(lowest, 70);
    // Toward profile: from the photograph's yaw outward on its side; either side from near frontal.
    random.toward_profile = true;
    random.max_turn = 90;
    int right = 0;
    for (int i = 0; i < 200; ++i) {
        const auto turned = plan_view(random, {-30, 0, 0}, 7, i);
        EXPECT_LE(turned->yaw, -30);
        EXPECT_GE(turned->yaw, -90);
        right += plan_view(random, {2, 0, 0}, 7, i)->yaw > 2;
    }
    EXPECT_GT(right, 70);
    EXPECT_LT(right, 130);
}

// A folder of rendered "photographs" with .pts, and broken ones.
class ProfileRunTest : public ProfileTest {
protected:
    static void write_photo(const fs::path& folder, const std::string& stem, double yaw) {
        const frontal::SyntheticView p = photo(yaw);
        ASSERT_TRUE(cv::imwrite((folder / (stem + ".png")).string(), p.image));
        morph::write_pts(folder / (stem + ".pts"), p.landmarks);
    }
    static ProfileRunOptions options_for(const fs::path& photos, const fs::path& out) {
        ProfileRunOptions o;
        o.photos = photos;
        o.out = out;
        o.plan.yaws = {-60, 0, 60};
        o.plan.max_turn = 180;
        o.profile.size = 128;
        return o;
    }
    static std::vector<std::string> files_in(const fs::path& folder) {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(folder)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }
};

TEST_F(ProfileRunTest, BadPhotographsFailAloneWithoutPartialFiles) {
    const fs::path dir = testkit::fresh_temp_dir("profile_bad");
    const fs::path photos = dir / "photos";
    fs::create_directories(photos);
    write_photo(photos, "a_good", 15);
    {
        std::ofstream(photos / "b_corrupt.png") << "not a png";
        std::ofstream(photos / "b_corrupt.pts") << "version: 1\nn_points: 68\n{\n}\n";
    }
    write_photo(photos, "c_broken_pts", 0);
    std::ofstream(photos / "c_broken_pts.pts", std::ios::trunc) << "version: 1\nn_points: 68\n{\n1 2\n";
    write_photo(photos, "d_mismatched_pts", 0);
    {
        Eigen::Matrix2Xd far = Eigen::Matrix2Xd::Constant(2, 68, 5000);
        morph::write_pts(photos / "d_mismatched_pts.pts", far);
    }
    write_photo(photos, "e_no_face", 0);
    fs::remove(photos / "e_no_face.pts");

    ProfileRunOptions o = options_for(photos, dir / "out");
    o.landmarks = [](const fs::path& path, const cv::Mat&) -> FoundLandmarks {
        fs::path pts = path;
        pts.replace_extension(".pts");
        if (!fs::exists(pts)) throw core::file_error(path.string(), "no face found (and no .pts beside it)");
        return {morph::read_pts(pts), "pts"};
    };
    const ProfileRunResult r = run_profile(o, *model_);
    ASSERT_EQ(r.failures.size(), 4u);
    EXPECT_NE(r.failures[0].message.find("b_corrupt.png"), std::string::npos) << r.failures[0].message;
    EXPECT_NE(r.failures[1].message.find("c_broken_pts.pts"), std::string::npos) << r.failures[1].message;
    EXPECT_NE(r.failures[2].message.find("d_mismatched_pts.png"), std::string::npos) << r.failures[2].message;
    EXPECT_NE(r.failures[2].message.find("far outside"), std::string::npos) << r.failures[2].message;
    EXPECT_NE(r.failures[3].message.find("no face found"), std::string::npos) << r.failures[3].message;
    EXPECT_EQ(r.views_written, 3u);
    EXPECT_EQ(files_in(dir / "out" / "images"), (std::vector<std::string>{"s00000000.png", "s00000001.png", "s00000002.png"}));
    EXPECT_EQ(files_in(dir / "out" / "meta").size(), 3u);
    EXPECT_EQ(files_in(dir / "out" / "photos"), (std::vector<std::string>{"p00000000.json"}));
}

TEST_F(ProfileRunTest, ResumesAndGivesTheSameBytesWhateverThreadsAndShards) {
    const fs::path dir = testkit::fresh_temp_dir("profile_resume");
    const fs::path photos = dir / "photos";
    fs::create_directories(photos);
    write_photo(photos, "a", -20);
    write_photo(photos, "b", 30);
    write_photo(photos, "c", 5);

    ProfileRunOptions whole = options_for(photos, dir / "whole");
    whole.threads = 2;
    whole.plan.pitch_jitter = 4;
    const ProfileRunResult first = run_profile(whole, *model_);
    EXPECT_EQ(first.views_written, 9u);
    EXPECT_TRUE(first.failures.empty());
    const ProfileRunResult again = run_profile(whole, *model_);
    EXPECT_EQ(again.views_written, 0u);
    EXPECT_EQ(again.photos_done_before, 3u);

    // An interrupted run: a photograph's record and one of its views missing.
    const std::string key_bytes = core::read_file(dir / "whole" / "images" / "s00000004.png");
    fs::remove(dir / "whole" / "photos" / "p00000001.json");
    fs::remove(dir / "whole" / "meta" / "s00000004.json");
    fs::remove(dir / "whole" / "images" / "s00000004.png");
    const ProfileRunResult resumed = run_profile(whole, *model_);
    EXPECT_EQ(resumed.views_written, 1u);
    EXPECT_EQ(core::read_file(dir / "whole" / "images" / "s00000004.png"), key_bytes);

    ProfileRunOptions sharded = options_for(photos, dir / "sharded");
    sharded.plan.pitch_jitter = 4;
    for (int k = 0; k < 2; ++k) {
        sharded.shard = {k, 2};
        (void)run_profile(sharded, *model_);
    }
    ASSERT_EQ(files_in(dir / "sharded" / "images"), files_in(dir / "whole" / "images"));
    for (const auto& name : files_in(dir / "whole" / "images"))
        EXPECT_EQ(core::read_file(dir / "sharded" / "images" / name), core::read_file(dir / "whole" / "images" / name)) << name;
    for (const auto& name : files_in(dir / "whole" / "meta"))
        EXPECT_EQ(core::read_file(dir / "sharded" / "meta" / name), core::read_file(dir / "whole" / "meta" / name)) << name;

    // Other settings into the same folder: refused, naming the setting, unless asked to overwrite.
    ProfileRunOptions other = whole;
    other.profile.size = 96;
    const std::string message = testkit::error_message_of([&] { (void)run_profile(other, *model_); });
    EXPECT_NE(message.find("size"), std::string::npos) << message;
    other.overwrite = true;
    EXPECT_EQ(run_profile(other, *model_).views_written, 9u);
    EXPECT_EQ(cv::imread((dir / "whole" / "images" / "s00000000.png").string()).cols, 96);
}

TEST_F(ProfileRunTest, WritesWebDatasetTarsOfWholePhotographsAndCocoKeypoints) {
    const fs::path dir = testkit::fresh_temp_dir("profile_wds");
    const fs::path photos = dir / "photos";
    fs::create_directories(photos);
    write_photo(photos, "a", -20);
    write_photo(photos, "b", 30);
    write_photo(photos, "c", 5);
    ProfileRunOptions o = options_for(photos, dir / "out");
    o.output.formats = "folder,wds,coco";
    o.output.wds_shard_size = 7;  // 3 views per photograph: two photographs per tar
    EXPECT_EQ(photos_per_tar(o), 2u);
    const ProfileRunResult r = run_profile(o, *model_);
    EXPECT_EQ(r.tars_written, 2u);
    const auto first = synth::list_tar(dir / "out" / "shard-000000.tar");
    const auto second = synth::list_tar(dir / "out" / "shard-000001.tar");
    ASSERT_EQ(first.size(), 18u);
    ASSERT_EQ(second.size(), 9u);
    EXPECT_EQ(first[0].name, "s00000000.png");
    EXPECT_EQ(first[1].name, "s00000000.pts");
    EXPECT_EQ(first[2].name, "s00000000.json");
    EXPECT_EQ(second[0].name, "s00000006.png");

    const nlohmann::json coco = testkit::read_json(dir / "out" / "coco.json");
    ASSERT_EQ(coco["images"].size(), 9u);
    EXPECT_EQ(coco["images"][4]["file_name"], "images/s00000004.png");
    EXPECT_EQ(coco["images"][4]["width"], 128);
    const nlohmann::json meta = testkit::read_json(dir / "out" / "meta" / "s00000004.json");
    EXPECT_EQ(meta["photo_record"], "photos/p00000001.json");
    EXPECT_TRUE(fs::exists(dir / "out" / meta["photo_record"].get<std::string>()));
    const auto& keypoints = coco["annotations"][4]["keypoints"];
    ASSERT_EQ(keypoints.size(), 3u * 68u);
    EXPECT_DOUBLE_EQ(keypoints[0].get<double>(), meta["landmarks"][0][0].get<double>());
    EXPECT_EQ(coco["annotations"][4]["bbox"], meta["bbox"]);

    // Nothing new: no tar rewritten. A lost tar is made again, byte for byte.
    EXPECT_EQ(run_profile(o, *model_).tars_written, 0u);
    const std::string bytes = core::read_file(dir / "out" / "shard-000001.tar");
    fs::remove(dir / "out" / "shard-000001.tar");
    EXPECT_EQ(run_profile(o, *model_).tars_written, 1u);
    EXPECT_EQ(core::read_file(dir / "out" / "shard-000001.tar"), bytes);

    // Shards take whole tars' photographs, and each writes its own COCO file.
    ProfileRunOptions sharded = o;
    sharded.out = dir / "sharded";
    for (int k = 0; k < 2; ++k) {
        sharded.shard = {k, 2};
        EXPECT_EQ(run_profile(sharded, *model_).tars_written, 1u);
    }
    EXPECT_EQ(core::read_file(dir / "sharded" / "shard-000000.tar"), core::read_file(dir / "out" / "shard-000000.tar"));
    EXPECT_EQ(core::read_file(dir / "sharded" / "shard-000001.tar"), bytes);
    EXPECT_EQ(testkit::read_json(dir / "sharded" / "coco-0-of-2.json")["images"].size(), 6u);
    EXPECT_EQ(testkit::read_json(dir / "sharded" / "coco-1-of-2.json")["images"].size(), 3u);
}

TEST(ProfileConfig, ConfigFileSetsTheRunsSettingsAndNamesBadKeys) {
    const fs::path dir = testkit::fresh_temp_dir("profile_config");
    const auto write = [&](const std::string& name, const std::string& text) {
        std::ofstream(dir / name) << text;
        return dir / name;
    };
    ProfileRunOptions o;
    apply_config_file(o, write("good.toml", "seed = 9\njaw = \"fixed\"\n[views]\nper_photo = 6\npitch_jitter = 3.5\n"
                                            "[scene]\nsize = 192\napply_residual = false\n[fit]\nlambda = 12\n"
                                            "[output]\nformats = \"folder,coco\"\nimage_format = \"jpg\"\n"));
    EXPECT_EQ(o.seed, 9u);
    EXPECT_EQ(o.jaw, "fixed");
    EXPECT_TRUE(o.plan.random_yaws());
    EXPECT_EQ(o.plan.views(), 6);
    EXPECT_DOUBLE_EQ(o.plan.pitch_jitter, 3.5);
    EXPECT_EQ(o.profile.size, 192);
    EXPECT_FALSE(o.profile.apply_residual);
    EXPECT_DOUBLE_EQ(o.profile.fit.lambda, 12);
    EXPECT_EQ(o.output.formats, "folder,coco");
    EXPECT_EQ(o.output.image_format, "jpg");
    EXPECT_NO_THROW(validate(o));

    ProfileRunOptions listed;
    apply_config_file(listed, write("yaws.toml", "[views]\nyaws = \"-30:30:30\"\n"));
    EXPECT_EQ(listed.plan.yaws, (std::vector<double>{-30, 0, 30}));

    for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
             {"[scene]\nsise = 3\n", "scene.sise"},
             {"[scene]\nsize = \"big\"\n", "scene.size"},
             {"[views]\nyaws = \"0:10:0\"\nper_photo = 2\n", "not both"},
             {"[views]\nyaws = \"0:10:0\"\n", "step"}}) {
        ProfileRunOptions bad;
        const std::string message = testkit::error_message_of([&] { apply_config_file(bad, write("bad.toml", text)); });
        EXPECT_NE(message.find("bad.toml"), std::string::npos) << message;
        EXPECT_NE(message.find(expected), std::string::npos) << message;
    }
    ProfileRunOptions out_of_range;
    out_of_range.profile.size = 8;
    EXPECT_NE(testkit::error_message_of([&] { validate(out_of_range); }).find("scene.size"), std::string::npos);
    ProfileRunOptions unknown_format;
    unknown_format.output.formats = "folder,tiff";
    EXPECT_NE(testkit::error_message_of([&] { validate(unknown_format); }).find("tiff"), std::string::npos);
}

}  // namespace
}  // namespace facesynth::profile
