// View-specific baselines: ERT and LBF trained per detector view like our cascades, bundled in one
// file, and run by the box's view (nose-right crops through the mirrored profile model).
#include "train/view_baselines.h"

#include "cartoon_faces.h"
#include "common/test_data.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "train/dlib_baseline.h"
#include "train/lbf_baseline.h"
#include "train/regressor.h"

#include <gtest/gtest.h>

#include <string>

namespace facesynth::train {
namespace {

using testkit::cartoon_training_faces;
using testkit::concatenate;
using testkit::three_view_faces;

ErtTrainOptions small_view_ert() {
    ErtTrainOptions options;
    options.threads = 2;
    options.oversampling = 4;
    options.cascade_depth = 4;
    options.tree_depth = 3;
    options.trees_per_level = 40;
    return options;
}

// Mean NME of a regressor on canonical crops, each in its own view's box.
double view_mean_nme(const LandmarkRegressor& regressor, const std::vector<TrainingFace>& faces) {
    double sum = 0;
    for (const auto& face : faces) sum += landmark_nme(regressor.predict(face.crop, canonical_face_box(face.view)), face.truth);
    return sum / static_cast<double>(faces.size());
}

void expect_view_error_naming(const std::string& spec, const std::string& name) {
    try {
        (void)open_regressor(spec);
        ADD_FAILURE() << spec << " accepted";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
}

TEST(ViewBaselines, NoseRightCropsAreFlippedAndTheirResultMirroredBack) {
    cv::Mat crop(kCanonicalCropSide, kCanonicalCropSide, CV_8UC1, cv::Scalar(0));
    crop.colRange(0, 10).setTo(255);  // bright on the left
    const Eigen::Matrix2Xd profile_shape = cartoon_training_faces(61, 1, -45)[0].truth;
    const Eigen::Matrix2Xd frontal_shape = cartoon_training_faces(62, 1)[0].truth;
    int left_bright = -1;
    const CanonicalPredict frontal = [&](const cv::Mat&) { return frontal_shape; };
    const CanonicalPredict profile = [&](const cv::Mat& c) {
        left_bright = c.at<unsigned char>(0, 0) == 255 ? 1 : 0;
        return profile_shape;
    };
    EXPECT_TRUE(predict_by_view(crop, FaceView::kFrontal, frontal, profile).isApprox(frontal_shape));
    EXPECT_EQ(left_bright, -1);
    EXPECT_TRUE(predict_by_view(crop, FaceView::kNoseLeft, frontal, profile).isApprox(profile_shape));
    EXPECT_EQ(left_bright, 1);
    EXPECT_TRUE(predict_by_view(crop, FaceView::kNoseRight, frontal, profile).isApprox(mirror_canonical_shape(profile_shape)));
    EXPECT_EQ(left_bright, 0);  // the profile model saw the flipped crop
}

TEST(ViewBaselines, ErtPerViewLearnsProfileFacesAndTheBundleRoundTrips) {
    const auto train = three_view_faces(63, 30);
    const auto profile_test = concatenate({cartoon_training_faces(64, 12, -45), cartoon_training_faces(65, 12, 45)});
    const auto dir = testkit::fresh_temp_dir("view_baselines_ert");
    const ViewFaceSets sets = split_view_faces(train, ViewSplit{});
    EXPECT_EQ(sets.counts.frontal_faces, 30);
    EXPECT_EQ(sets.counts.profile_faces, 60);
    EXPECT_EQ(sets.counts.profile_mirrored, 30);
    const auto train_ert = [](std::span<const TrainingFace> faces, const std::filesystem::path& file) {
        train_dlib_ert(faces, small_view_ert(), file);
    };
    const ViewBaselineBundle bundle = train_view_baselines(BaselineMethod::kErt, DetectorKind::kMultiView, sets,
                                                           dir / "views.ert", train_ert);
    write_view_baseline_bundle(dir / "views.ert", bundle);
    EXPECT_TRUE(is_view_baseline_bundle(dir / "views.ert"));
    for (const auto& entry : std::filesystem::directory_iterator(dir))  // no trainer output left behind
        EXPECT_EQ(entry.path().filename(), "views.ert");
    train_dlib_ert(train, small_view_ert(), dir / "single.ert");
    EXPECT_FALSE(is_view_baseline_bundle(dir / "single.ert"));

    const auto views = open_regressor("ert:" + (dir / "views.ert").string());
    const auto single = open_regressor("ert:" + (dir / "single.ert").string());
    EXPECT_EQ(views->trained_detector(), DetectorKind::kMultiView);  // recorded in the bundle
    EXPECT_FALSE(single->trained_detector().has_value());
    Eigen::Matrix2Xd profile_mean = Eigen::Matrix2Xd::Zero(2, 68);
    for (const auto& face : sets.profile) profile_mean += face.truth / static_cast<double>(sets.profile.size());
    double start = 0;  // the nose-left mean, mirrored for nose-right faces
    for (const auto& face : profile_test)
        start += landmark_nme(face.view == FaceView::kNoseRight ? mirror_canonical_shape(profile_mean) : profile_mean, face.truth) /
                 static_cast<double>(profile_test.size());
    const double views_nme = view_mean_nme(*views, profile_test), single_nme = view_mean_nme(*single, profile_test);
    RecordProperty("profile_start_nme", std::to_string(start));
    RecordProperty("views_profile_nme", std::to_string(views_nme));
    RecordProperty("single_profile_nme", std::to_string(single_nme));
    EXPECT_LT(views_nme, 0.6 * start) << "start " << start << ", view-specific ERT " << views_nme;
    EXPECT_LT(view_mean_nme(*views, cartoon_training_faces(66, 12)), 0.6 * start);
}

TEST(ViewBaselines, LbfBundleRoundTripsThroughTheRegressorSpec) {
    const auto train = three_view_faces(67, 12);
    const auto dir = testkit::fresh_temp_dir("view_baselines_lbf");
    LbfTrainOptions options;
    options.augment = 2;
    options.stages = 1;
    options.trees = 2;
    options.depth = 3;
    options.features = {50};
    options.radii = {0.3};
    const auto train_lbf_file = [&](std::span<const TrainingFace> faces, const std::filesystem::path& file) {
        (void)train_lbf(faces, options, file);
    };
    const ViewBaselineBundle bundle = train_view_baselines(BaselineMethod::kLbf, DetectorKind::kFrontal,
                                                           split_view_faces(train, ViewSplit{}), dir / "views.lbf", train_lbf_file);
    write_view_baseline_bundle(dir / "views.lbf", bundle);
    const auto read = read_view_baseline_bundle(dir / "views.lbf", BaselineMethod::kLbf);
    EXPECT_EQ(read.detector, DetectorKind::kFrontal);
    EXPECT_EQ(read.frontal_model, bundle.frontal_model);
    EXPECT_EQ(read.profile_model, bundle.profile_model);
    const auto regressor = open_regressor("lbf:" + (dir / "views.lbf").string());
    EXPECT_EQ(regressor->trained_detector(), DetectorKind::kFrontal);
    // The nose-left face runs the profile model as it is; the same model loaded on its own agrees.
    const ScopedTemporaryFile profile_file(bundle.profile_model, "profile");
    const LbfPredictor profile(profile_file.path());
    const TrainingFace& left = train[1];
    ASSERT_EQ(left.view, FaceView::kNoseLeft);
    EXPECT_TRUE(regressor->predict(left.crop, canonical_face_box(FaceView::kNoseLeft)).isApprox(profile.predict(left.crop)));
    // An LBF bundle is not an ERT model.
    expect_view_error_naming("ert:" + (dir / "views.lbf").string(), "views.lbf");
}

TEST(ViewBaselines, CorruptBundlesGiveErrorsNamingTheFile) {
    const auto dir = testkit::fresh_temp_dir("view_baselines_corrupt");
    ViewBaselineBundle bundle;
    bundle.frontal_model = "frontal model bytes";
    bundle.profile_model = "profile model bytes";
    write_view_baseline_bundle(dir / "good.ert", bundle);
    const auto read = read_view_baseline_bundle(dir / "good.ert", BaselineMethod::kErt);
    EXPECT_EQ(read.frontal_model, bundle.frontal_model);
    EXPECT_EQ(read.profile_model, bundle.profile_model);
    EXPECT_EQ(read.detector, DetectorKind::kMultiView);
    const std::string bytes = core::read_file(dir / "good.ert");

    core::write_file_atomically(dir / "truncated.ert", bytes.substr(0, bytes.size() - 5));
    std::string flipped = bytes;
    flipped[flipped.size() - 3] ^= 0x20;
    core::write_file_atomically(dir / "flipped.ert", flipped);
    std::string version = bytes;
    version[8] = 9;
    core::write_file_atomically(dir / "version.ert", version);
    core::write_file_atomically(dir / "header.ert", bytes.substr(0, 12));
    for (const char* name : {"truncated.ert", "flipped.ert", "version.ert", "header.ert"}) {
        EXPECT_TRUE(is_view_baseline_bundle(dir / name));
        EXPECT_THROW((void)read_view_baseline_bundle(dir / name, BaselineMethod::kErt), core::Error) << name;
        expect_view_error_naming("ert:" + (dir / name).string(), name);
    }
    EXPECT_THROW((void)read_view_baseline_bundle(dir / "good.ert", BaselineMethod::kLbf), core::Error);
    // Valid bundle, but its parts are not dlib models: the error names the bundle and the part.
    expect_view_error_naming("ert:" + (dir / "good.ert").string(), "good.ert (frontal model)");
    // A view set without faces is refused before any training, naming the view.
    ViewFaceSets empty;
    empty.frontal = cartoon_training_faces(68, 2);
    try {
        (void)train_view_baselines(BaselineMethod::kErt, DetectorKind::kMultiView, empty, dir / "x.ert",
                                   [](std::span<const TrainingFace>, const std::filesystem::path&) {});
        ADD_FAILURE() << "empty profile set accepted";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("profile"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace facesynth::train
