#include "train/dataset.h"
#include "train/dlib_baseline.h"
#include "train/dlib_face_detector.h"
#include "train/face_box.h"
#include "train/metrics.h"
#include "train/realism.h"
#include "train/training_data.h"

#include "cartoon_faces.h"
#include "common/test_data.h"
#include "core/error.h"
#include "morph/landmarks.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>
#include <limits>

namespace facesynth::train {
namespace {

TEST(Metrics, SummaryByHand) {
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<double> nmes = {0.02, 0.04, inf, 0.1};
    const NmeSummary s = summarise_nme(nmes);
    EXPECT_EQ(s.count, 4);
    EXPECT_NEAR(s.mean, (0.02 + 0.04 + 0.1) / 3, 1e-12);
    EXPECT_NEAR(s.median, 0.07, 1e-12);
    EXPECT_NEAR(s.failure_rate_008, 0.5, 1e-12);
    EXPECT_NEAR(s.auc_008, (0.06 + 0.04) / (0.08 * 4), 1e-12);
    EXPECT_NEAR(ced_at(nmes, 0.05), 0.5, 1e-12);
    const std::vector<CedCurve> curves = {{"ours", nmes}};
    const std::string png = ced_png(curves);
    ASSERT_GT(png.size(), 8u);
    EXPECT_EQ(png.substr(1, 3), "PNG");
}

// The realism measure's fine detail: blur takes it away, and the same face photographed at twice the
// size reads about the same, since it is measured at a fixed face size.
TEST(Realism, FaceDetailFallsWithBlurAndHoldsAcrossFaceSizes) {
    const testkit::CartoonFace face = testkit::make_cartoon_face(3, 1, 200);
    const double sharp = face_detail(face.gray, face.landmarks);
    cv::Mat blurred;
    cv::GaussianBlur(face.gray, blurred, cv::Size(0, 0), 2.0);
    const double soft = face_detail(blurred, face.landmarks);
    cv::Mat twice;
    cv::resize(face.gray, twice, cv::Size(), 2, 2, cv::INTER_CUBIC);
    const double large = face_detail(twice, ((face.landmarks.array() + 0.5) * 2 - 0.5).matrix());
    ASSERT_TRUE(std::isfinite(sharp) && std::isfinite(soft) && std::isfinite(large));
    EXPECT_GT(sharp, 0);
    EXPECT_LT(soft, 0.7 * sharp);
    EXPECT_NEAR(large, sharp, 0.25 * sharp);
    EXPECT_TRUE(std::isnan(face_detail(face.gray, Eigen::Matrix2Xd::Zero(2, 68))));  // degenerate label
}

TEST(Dataset, FindsSideBySideAndSynthLayouts) {
    const auto dir = testkit::fresh_temp_dir("train_dataset_layouts");
    const auto face = testkit::make_cartoon_face(9, 0);
    std::filesystem::create_directories(dir / "synth" / "images");
    std::filesystem::create_directories(dir / "synth" / "landmarks");
    std::filesystem::create_directories(dir / "flat");
    cv::imwrite((dir / "synth" / "images" / "000001.png").string(), face.gray);
    morph::write_pts(dir / "synth" / "landmarks" / "000001.pts", face.landmarks);
    cv::imwrite((dir / "synth" / "images" / "000002.png").string(), face.gray);  // no .pts: ignored
    cv::imwrite((dir / "flat" / "a.jpg").string(), face.gray);
    morph::write_pts(dir / "flat" / "a.pts", face.landmarks);
    std::ofstream(dir / "flat" / "b.png") << "not an image";
    morph::write_pts(dir / "flat" / "b.pts", face.landmarks);

    const auto found = list_labelled_images(split_folder_list((dir / "synth").string() + "," + (dir / "flat").string()));
    ASSERT_EQ(found.size(), 3u);
    EXPECT_EQ(found[0].key, "synth/000001");
    EXPECT_EQ(found[1].key, "flat/a");
    EXPECT_EQ(found[2].key, "flat/b");
    // A dataset's images are renders; an image beside its .pts is a photograph (which --image-copies copies).
    EXPECT_FALSE(found[0].photograph);
    EXPECT_TRUE(found[1].photograph);

    // The unreadable image is skipped with a warning naming it; the others become training faces.
    const PreparedFaces prepared = prepare_training_faces(found, PrepareOptions{});
    ASSERT_EQ(prepared.faces.size(), 2u);
    EXPECT_FALSE(prepared.faces[0].photograph);
    EXPECT_TRUE(prepared.faces[1].photograph);
    ASSERT_EQ(prepared.warnings.size(), 1u);
    EXPECT_NE(prepared.warnings[0].find("b.png"), std::string::npos) << prepared.warnings[0];
    EXPECT_EQ(prepared.boxes.detector_matched + prepared.boxes.detector_missed, 2);

    EXPECT_THROW((void)list_labelled_images({dir / "does_not_exist"}), core::Error);
    std::filesystem::create_directories(dir / "empty");
    EXPECT_THROW((void)list_labelled_images({dir / "empty"}), core::Error);
}

TEST(FaceBox, CanonicalFrameRoundTripsAndCropsAtTheRightPlace) {
    cv::Mat image(600, 800, CV_8UC1, cv::Scalar(0));
    cv::circle(image, cv::Point(500, 300), 5, cv::Scalar(255), cv::FILLED);
    FaceFrame frame;
    frame.box.centre = {500, 300};
    frame.box.width = 400;  // large face: crop is pyramid-reduced
    Eigen::Matrix2Xd p(2, 1);
    p << 500, 300;
    const Eigen::Matrix2Xd c = frame.to_canonical(p);
    EXPECT_NEAR(c(0, 0), (kCanonicalCropSide - 1) / 2.0, 1e-9);
    EXPECT_TRUE(frame.to_image(c).isApprox(p));
    const cv::Mat crop = canonical_crop(image, frame);
    ASSERT_EQ(crop.rows, kCanonicalCropSide);
    cv::Point max_at;
    cv::minMaxLoc(crop, nullptr, nullptr, nullptr, &max_at);
    EXPECT_NEAR(max_at.x, 127.5, 1.0);
    EXPECT_NEAR(max_at.y, 127.5, 1.0);
}

FaceBox box_at(double x, double y, double width, FaceView view) {
    FaceBox box;
    box.centre = {x, y};
    box.width = width;
    box.view = view;
    return box;
}

TEST(FaceBox, MergingKeepsOneBoxPerFaceFromTheMostConfidentCascade) {
    // Face A: frontal (3 neighbours) and nose-left profile (7) overlap: the profile box stays.
    // Face B: a frontal box with a small profile box inside it, equal neighbours: frontal wins the tie.
    // Face C: a lone nose-right profile box far away stays.
    const std::vector<ScoredBox> detections = {
        {box_at(100, 100, 80, FaceView::kFrontal), 3},
        {box_at(110, 104, 70, FaceView::kNoseLeft), 7},
        {box_at(300, 100, 100, FaceView::kFrontal), 5},
        {box_at(290, 110, 40, FaceView::kNoseRight), 5},
        {box_at(500, 300, 60, FaceView::kNoseRight), 2},
    };
    const auto merged = merge_detections(detections);
    ASSERT_EQ(merged.size(), 3u);
    // Largest first.
    EXPECT_EQ(merged[0].centre, Eigen::Vector2d(300, 100));
    EXPECT_EQ(merged[0].view, FaceView::kFrontal);
    EXPECT_EQ(merged[1].centre, Eigen::Vector2d(110, 104));
    EXPECT_EQ(merged[1].view, FaceView::kNoseLeft);
    EXPECT_EQ(merged[2].view, FaceView::kNoseRight);
    // Boxes that touch but overlap less than half of the smaller one are different faces.
    const auto apart = merge_detections({{box_at(100, 100, 80, FaceView::kFrontal), 3}, {box_at(170, 100, 80, FaceView::kNoseLeft), 3}});
    EXPECT_EQ(apart.size(), 2u);
    EXPECT_TRUE(merge_detections({}).empty());
}

TEST(FaceBox, DetectorNamesRoundTripAndUnknownOnesAreRefused) {
    for (const auto kind : {DetectorKind::kFrontal, DetectorKind::kMultiView, DetectorKind::kDlib, DetectorKind::kDlibProfile}) {
        EXPECT_EQ(parse_detector_kind(detector_name(kind)), kind);
        EXPECT_EQ(FaceDetector(kind).kind(), kind);
        EXPECT_EQ(detector_has_views(kind), kind != DetectorKind::kFrontal);
    }
    EXPECT_EQ(std::string(detector_name(DetectorKind::kDlibProfile)), "dlib+profile");
    EXPECT_THROW((void)parse_detector_kind("profile"), core::Error);
    EXPECT_EQ(FaceDetector().kind(), DetectorKind::kFrontal);
}

TEST(FaceBox, NoFaceInABlankOrNoiseImage) {
    cv::Mat blank(240, 320, CV_8UC1, cv::Scalar(128));
    cv::Mat noise(240, 320, CV_8UC1);
    cv::randu(noise, 0, 256);
    for (const auto kind : {DetectorKind::kFrontal, DetectorKind::kMultiView, DetectorKind::kDlib, DetectorKind::kDlibProfile}) {
        const FaceDetector detector(kind);
        EXPECT_TRUE(detector.detect(blank).empty()) << detector_name(kind);
        EXPECT_TRUE(detector.detect(noise).empty()) << detector_name(kind);
    }
}

TEST(FaceBox, EveryDetectorRefusesAnEmptyOrNonGreyImageWithAnError) {
    const cv::Mat colour(64, 64, CV_8UC3, cv::Scalar(10, 20, 30));
    for (const auto kind : {DetectorKind::kFrontal, DetectorKind::kMultiView, DetectorKind::kDlib, DetectorKind::kDlibProfile}) {
        const FaceDetector detector(kind);
        EXPECT_THROW((void)detector.detect(cv::Mat()), core::Error) << detector_name(kind);
        EXPECT_THROW((void)detector.detect(colour), core::Error) << detector_name(kind);
    }
}

TEST(DlibFaceDetector, FiltersMapToViews) {
    // dlib's filter order: frontal, left-looking, right-looking, frontal rotated left and right; the
    // turned-face filters' yaw sign was measured on synthetic faces of known yaw (docs/train.md).
    EXPECT_EQ(view_of_dlib_filter(0), FaceView::kFrontal);
    EXPECT_EQ(view_of_dlib_filter(1), FaceView::kNoseLeft);
    EXPECT_EQ(view_of_dlib_filter(2), FaceView::kNoseRight);
    EXPECT_EQ(view_of_dlib_filter(3), FaceView::kFrontal);
    EXPECT_EQ(view_of_dlib_filter(4), FaceView::kFrontal);
}

TEST(DlibFaceDetector, FindsTheAnnotatedFaceOnARealPhotoWithAFilterAndScore) {
    FACESYNTH_REQUIRE_SHARED_DATA(dir, "real/lfpw_superviseddescent");
    const cv::Mat gray = to_gray8(cv::imread((dir / "image_0001.png").string(), cv::IMREAD_UNCHANGED));
    const Eigen::Matrix2Xd truth = morph::read_pts(dir / "image_0001.pts");
    const DlibHogDetector dlib_detector;
    const auto detections = dlib_detector.detect(gray);
    ASSERT_FALSE(detections.empty());
    for (const auto& d : detections) {
        EXPECT_GE(d.filter, 0);
        EXPECT_LT(d.filter, 5);
        EXPECT_GE(d.confidence, kDlibAdjustThreshold);
        EXPECT_EQ(d.box.view, view_of_dlib_filter(d.filter));
    }
    const auto match = match_detection(FaceDetector(DetectorKind::kDlib).detect(gray), truth);
    ASSERT_TRUE(match.has_value());
    EXPECT_LT((match->centre - truth.rowwise().mean()).norm(), 0.3 * match->width);
}

TEST(FaceBox, DetectsTheAnnotatedFaceOnARealPhoto) {
    FACESYNTH_REQUIRE_SHARED_DATA(dir, "real/lfpw_superviseddescent");
    const FaceDetector detector;
    const cv::Mat gray = to_gray8(cv::imread((dir / "image_0001.png").string(), cv::IMREAD_UNCHANGED));
    const Eigen::Matrix2Xd truth = morph::read_pts(dir / "image_0001.pts");
    const auto match = match_detection(detector.detect(gray), truth);
    ASSERT_TRUE(match.has_value());
    EXPECT_LT((match->centre - truth.rowwise().mean()).norm(), 0.3 * match->width);
}

TEST(DlibBaseline, PretrainedPredictorOnARealPhoto) {
    FACESYNTH_REQUIRE_SHARED_DATA(dir, "real/lfpw_superviseddescent");
    if (!std::filesystem::exists(default_dlib_predictor_path())) GTEST_SKIP() << "libdlib-data not installed";
    const DlibShapePredictor predictor(default_dlib_predictor_path());
    EXPECT_EQ(predictor.num_parts(), 68);
    const FaceDetector detector;
    const cv::Mat gray = to_gray8(cv::imread((dir / "image_0001.png").string(), cv::IMREAD_UNCHANGED));
    const Eigen::Matrix2Xd truth = morph::read_pts(dir / "image_0001.pts");
    const auto box = match_detection(detector.detect(gray), truth);
    ASSERT_TRUE(box.has_value());
    const Eigen::Matrix2Xd predicted = predictor.predict(gray, *box);
    const double nme = (predicted - truth).colwise().norm().mean() / morph::inter_ocular_distance(truth);
    EXPECT_LT(nme, 0.1);
}

TEST(DlibBaseline, MissingOrForeignFileNamesIt) {
    const auto dir = testkit::fresh_temp_dir("dlib_foreign");
    std::ofstream(dir / "junk.dat") << "junk";
    try {
        DlibShapePredictor p(dir / "junk.dat");
        FAIL();
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("junk.dat"), std::string::npos);
    }
    EXPECT_THROW(DlibShapePredictor(dir / "none.dat"), core::Error);
}

}  // namespace
}  // namespace facesynth::train
