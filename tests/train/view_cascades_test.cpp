#include "train/model_file.h"
#include "train/sdm.h"
#include "train/view_cascades.h"

#include "cartoon_faces.h"
#include "common/model_files.h"
#include "common/test_data.h"
#include "core/atomic_file.h"
#include "sdm_file_testing.h"
#include "core/error.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace facesynth::train {
namespace {

using testkit::cartoon_training_faces;

using testkit::concatenate;
using testkit::three_view_faces;

SdmTrainOptions small_options() {
    SdmTrainOptions options;
    options.augment = 3;
    options.stages = 3;
    options.hog.cells = 2;
    options.threads = 2;
    return options;
}

TEST(ViewCascades, MirroringTwiceGivesTheShapeBack) {
    const auto faces = cartoon_training_faces(21, 3, 40);
    for (const auto& face : faces) {
        const Eigen::Matrix2Xd once = mirror_canonical_shape(face.truth);
        EXPECT_FALSE(once.isApprox(face.truth));
        EXPECT_TRUE(mirror_canonical_shape(once).isApprox(face.truth, 1e-12));
        const TrainingFace twice = mirror_training_face(mirror_training_face(face));
        EXPECT_EQ(cv::norm(twice.crop, face.crop, cv::NORM_INF), 0.0);
        EXPECT_EQ(twice.view, face.view);
        EXPECT_EQ(*twice.yaw_deg, *face.yaw_deg);
    }
    EXPECT_THROW((void)mirror_canonical_shape(Eigen::Matrix2Xd::Zero(2, 5)), core::Error);
}

// `shape` moved onto `target` by the least-squares similarity (position, rotation and size removed).
Eigen::Matrix2Xd aligned(const Eigen::Matrix2Xd& shape, const Eigen::Matrix2Xd& target) {
    const Eigen::Vector2d cs = shape.rowwise().mean(), ct = target.rowwise().mean();
    const Eigen::Matrix2Xd f = shape.colwise() - cs, t = target.colwise() - ct;
    const double a = (f.array() * t.array()).sum() / f.squaredNorm();
    const double b = (f.row(0).array() * t.row(1).array() - f.row(1).array() * t.row(0).array()).sum() / f.squaredNorm();
    Eigen::Matrix2d m;
    m << a, -b, b, a;
    return (m * f).colwise() + ct;
}

TEST(ViewCascades, AMirroredFaceIsAValidTrainingFace) {
    // Points keep their meaning: the iBUG left/right order survives the flip, the eye centres still lie
    // on the dark pupils of the flipped image, and a mirrored frontal face resembles the faces it was
    // mirrored from (with the permutation; a bare flip of the coordinates does not).
    for (const auto& face : cartoon_training_faces(22, 6)) {
        const TrainingFace mirrored = mirror_training_face(face);
        const auto& p = mirrored.truth;
        EXPECT_LT(p(0, 36), p(0, 45));  // outer eye corners: iBUG 37 left of 46
        EXPECT_LT(p(0, 0), p(0, 16));   // jaw from the image left to the right
        EXPECT_LT(p(0, 48), p(0, 54));  // mouth corners
        for (int eye : {36, 42}) {
            const Eigen::Vector2d centre = p.middleCols(eye, 6).rowwise().mean();
            EXPECT_LT(mirrored.crop.at<std::uint8_t>(static_cast<int>(std::lround(centre.y())), static_cast<int>(std::lround(centre.x()))), 90)
                << "eye " << eye;
        }
        EXPECT_LT(landmark_nme(aligned(mirrored.truth, face.truth), face.truth), 0.05);
        Eigen::Matrix2Xd flipped_only = face.truth;
        flipped_only.row(0) = Eigen::RowVectorXd::Constant(68, kCanonicalCropSide - 1) - face.truth.row(0);
        EXPECT_GT(landmark_nme(aligned(flipped_only, face.truth), face.truth), 0.5);
    }
    // A turned face's mirror looks the other way.
    const auto left = cartoon_training_faces(23, 1, -45).front();
    ASSERT_EQ(left.view, FaceView::kNoseLeft);
    const TrainingFace right = mirror_training_face(left);
    EXPECT_EQ(right.view, FaceView::kNoseRight);
    EXPECT_GT(*right.yaw_deg, 0);
    const auto nose_offset = [](const Eigen::Matrix2Xd& s) { return s(0, 30) - 0.5 * (s(0, 36) + s(0, 45)); };
    EXPECT_LT(nose_offset(left.truth), 0);
    EXPECT_GT(nose_offset(right.truth), 0);
}

double cascade_mean_nme(const SdmModel& model, const std::vector<TrainingFace>& test) {
    double sum = 0;
    for (const auto& face : test) sum += landmark_nme(sdm_refine_view(model, face.crop, face.view), face.truth);
    return sum / static_cast<double>(test.size());
}

TEST(ViewCascades, BeatTheSingleCascadeOnHeldOutProfileFaces) {
    const auto train = three_view_faces(30, 30);
    const auto profile_test = concatenate({cartoon_training_faces(40, 12, -45), cartoon_training_faces(41, 12, 45)});
    const auto frontal_test = cartoon_training_faces(42, 12);
    const SdmTrainOptions options = small_options();
    BoxStatistics boxes;
    boxes.detector = DetectorKind::kMultiView;
    const SdmModel single = train_sdm(train, boxes, options);
    ViewCascadeCounts counts;
    const SdmModel views = train_view_cascades(train, boxes, options, ViewSplit{}, &counts);
    EXPECT_EQ(counts.frontal_faces, 30);
    EXPECT_EQ(counts.profile_faces, 60);
    EXPECT_EQ(counts.profile_mirrored, 30);
    ASSERT_TRUE(views.profile.has_value());
    EXPECT_EQ(views.profile->stages.size(), views.stages.size());
    EXPECT_EQ(views.view_faces, (std::array<int, kFaceViews>{30, 30, 30}));
    // The nose-right start is the mirrored profile mean.
    EXPECT_TRUE(views.initial_shape(FaceView::kNoseRight).isApprox(mirror_canonical_shape(views.profile->mean_shape)));

    const double single_profile = cascade_mean_nme(single, profile_test), views_profile = cascade_mean_nme(views, profile_test);
    const double start_profile = [&] {
        double sum = 0;
        for (const auto& face : profile_test) sum += landmark_nme(views.initial_shape(face.view), face.truth);
        return sum / static_cast<double>(profile_test.size());
    }();
    RecordProperty("start_profile_nme", std::to_string(start_profile));
    RecordProperty("single_profile_nme", std::to_string(single_profile));
    RecordProperty("views_profile_nme", std::to_string(views_profile));
    EXPECT_LT(views_profile, 0.6 * start_profile);
    EXPECT_LE(views_profile, single_profile) << "single " << single_profile << ", view-specific " << views_profile;
    // The frontal cascade, trained on a third of the faces, still works on frontal faces.
    EXPECT_LT(cascade_mean_nme(views, frontal_test), 1.5 * cascade_mean_nme(single, frontal_test));
}

TEST(ViewCascades, OverlapAddsFacesOfTheOtherViewByTrueYaw) {
    auto train = three_view_faces(50, 12);
    // Three frontal-view faces turned by 25° (to the left) and two nose-right ones at 30°.
    for (int i = 0; i < 3; ++i) train[static_cast<std::size_t>(3 * i)].yaw_deg = -25.0;
    for (int i = 0; i < 2; ++i) train[static_cast<std::size_t>(3 * i + 2)].yaw_deg = 30.0;
    SdmTrainOptions options = small_options();
    options.stages = 1;
    ViewCascadeCounts counts;
    const SdmModel model = train_view_cascades(train, BoxStatistics{}, options, ViewSplit{35, 20}, &counts);
    const ViewCascadeCounts planned = count_view_split(train, ViewSplit{35, 20});
    EXPECT_EQ(planned.frontal_faces, counts.frontal_faces);
    EXPECT_EQ(planned.profile_faces, counts.profile_faces);
    EXPECT_EQ(planned.profile_mirrored, counts.profile_mirrored);
    EXPECT_EQ(counts.profile_from_frontal, 3);
    EXPECT_EQ(counts.frontal_from_profile, 2);
    EXPECT_EQ(counts.frontal_faces, 14);
    EXPECT_EQ(counts.profile_faces, 27);
    EXPECT_EQ(counts.profile_mirrored, 12);  // the nose-right ones; the overlap faces turned left are not
    EXPECT_EQ(model.profile->faces, 27);
}

TEST(ViewCascades, MirroringAppliesToTheFrontalCascadeOnly) {
    SdmTrainOptions options = small_options();
    options.stages = 1;
    options.mirror = true;
    const SdmModel model = train_view_cascades(three_view_faces(80, 12), BoxStatistics{}, options, ViewSplit{});
    const auto asymmetry = [](const Eigen::Matrix2Xd& shape) { return (shape - mirror_canonical_shape(shape)).cwiseAbs().maxCoeff(); };
    EXPECT_LT(asymmetry(model.mean_shape), 1e-9);  // frontal faces and their mirror images
    ASSERT_TRUE(model.profile.has_value());
    // Still a nose-left start: the profile cascade's faces were not mirrored into nose-right ones.
    const Eigen::Matrix2Xd& p = model.profile->mean_shape;
    EXPECT_LT(p(0, 30) - 0.5 * (p(0, 36) + p(0, 45)), 0);
    EXPECT_GT(asymmetry(p), 1.0);
}

TEST(ViewCascades, TooFewFacesOfOneViewNameTheCascade) {
    const auto frontal_only = cartoon_training_faces(60, 12);
    try {
        (void)train_view_cascades(frontal_only, BoxStatistics{}, small_options(), ViewSplit{});
        FAIL() << "no error";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("profile cascade (0 faces)"), std::string::npos) << e.what();
    }
}

using testkit::expect_sdm_error_naming;
using testkit::rewrite_sdm_header;

SdmModel small_view_model() {
    SdmTrainOptions options = small_options();
    options.stages = 2;
    options.jaw_features_from = 2;
    BoxStatistics boxes;
    boxes.detector = DetectorKind::kMultiView;
    return train_view_cascades(three_view_faces(70, 10), boxes, options, ViewSplit{});
}

TEST(ViewCascades, FilesRoundTripBothCascades) {
    const SdmModel model = small_view_model();
    const auto dir = testkit::fresh_temp_dir("sdm_view_cascades");
    write_sdm_model(dir / "views.sdm", model);
    EXPECT_EQ(core::read_file(dir / "views.sdm")[8], 6);
    const SdmModel back = read_sdm_model(dir / "views.sdm");
    ASSERT_TRUE(back.profile.has_value());
    EXPECT_EQ(back.profile->faces, model.profile->faces);
    EXPECT_EQ(back.profile->init_scale_std, model.profile->init_scale_std);
    EXPECT_TRUE(back.profile->mean_shape == model.profile->mean_shape);
    ASSERT_EQ(back.profile->stages.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
        EXPECT_EQ(back.profile->stages[k].settings.jaw_features, model.profile->stages[k].settings.jaw_features);
        EXPECT_TRUE(back.profile->stages[k].basis == model.profile->stages[k].basis);
        EXPECT_TRUE(back.profile->stages[k].weights == model.profile->stages[k].weights);
        EXPECT_TRUE(back.profile->stages[k].bias == model.profile->stages[k].bias);
        EXPECT_TRUE(back.stages[k].weights == model.stages[k].weights);
    }
    for (std::size_t v = 0; v < kFaceViews; ++v) EXPECT_TRUE(back.view_mean_shapes[v] == model.view_mean_shapes[v]);
    // The read model predicts what the trained one does, on every view.
    const auto face = cartoon_training_faces(71, 1, 45).front();
    for (FaceView view : {FaceView::kFrontal, FaceView::kNoseLeft, FaceView::kNoseRight})
        EXPECT_TRUE(sdm_refine_view(back, face.crop, view) == sdm_refine_view(model, face.crop, view));
}

TEST(ViewCascades, RealignedCascadesAreTrainedForBothViewsAndRoundTrip) {
    SdmModel model = small_view_model();
    SdmTrainOptions options = small_options();
    options.stages = 2;
    options.jaw_features_from = 2;
    options.realign_stages = 1;
    std::vector<std::string> names;
    const ViewRealignResiduals residuals = train_realigned_view_cascades(
        three_view_faces(70, 10), options, ViewSplit{}, model, [&](const char* cascade, const SdmStageReport&) { names.emplace_back(cascade); });
    EXPECT_EQ(names, (std::vector<std::string>{"frontal_realigned", "profile_realigned"}));
    ASSERT_EQ(model.realigned_stages.size(), 1u);
    ASSERT_EQ(model.profile->realigned_stages.size(), 1u);
    EXPECT_GT(residuals.frontal.faces, 0);
    EXPECT_GT(residuals.profile.faces, 0);
    EXPECT_FALSE(model.profile->realigned_stages[0].weights == model.realigned_stages[0].weights);
    const auto dir = testkit::fresh_temp_dir("sdm_view_cascades_realigned");
    write_sdm_model(dir / "views.sdm", model);
    const SdmModel back = read_sdm_model(dir / "views.sdm");
    ASSERT_EQ(back.profile->realigned_stages.size(), 1u);
    EXPECT_TRUE(back.profile->realigned_stages[0].weights == model.profile->realigned_stages[0].weights);
    EXPECT_TRUE(back.realigned_stages[0].weights == model.realigned_stages[0].weights);
    const auto face = cartoon_training_faces(71, 1, 45).front();
    for (FaceView view : {FaceView::kFrontal, FaceView::kNoseLeft, FaceView::kNoseRight})
        EXPECT_TRUE(sdm_refine_view(back, face.crop, view, {.realign = true}) == sdm_refine_view(model, face.crop, view, {.realign = true}));
}

TEST(ViewCascades, Version3FilesAreReadAsSingleCascadeModels) {
    // A single-cascade model written as version 6 ends with the profile flag 0, the shape unit (12 bytes)
    // and the realigned cascade's stage count 0; without them and with version 3 in the header it is what
    // a version 3 build wrote.
    auto faces = three_view_faces(72, 8);
    SdmTrainOptions options = small_options();
    options.stages = 1;
    const SdmModel model = train_sdm(faces, BoxStatistics{}, options);
    const auto dir = testkit::fresh_temp_dir("sdm_view_cascades_v3");
    write_sdm_model(dir / "v6.sdm", model);
    std::string v3 = core::read_file(dir / "v6.sdm");
    v3.resize(v3.size() - 16);
    ASSERT_EQ(v3.substr(v3.size() - 4), std::string(4, '\0'));
    v3.resize(v3.size() - 4);
    rewrite_sdm_header(v3, 3);
    testkit::write_bytes(dir / "v3.sdm", v3);
    const SdmModel back = read_sdm_model(dir / "v3.sdm");
    EXPECT_FALSE(back.profile.has_value());
    EXPECT_TRUE(back.stages[0].weights == model.stages[0].weights);
    EXPECT_TRUE(back.view_mean_shapes[1] == model.view_mean_shapes[1]);
}

TEST(ViewCascades, CorruptProfileBlocksGiveErrorsNamingTheFile) {
    const SdmModel model = small_view_model();
    const auto dir = testkit::fresh_temp_dir("sdm_view_cascades_corrupt");
    write_sdm_model(dir / "good.sdm", model);
    // As version 4 (no shape unit and realigned stage counts after the profile block), so that the
    // block ends the file.
    std::string good = core::read_file(dir / "good.sdm");
    good.resize(good.size() - 20);
    rewrite_sdm_header(good, 4);
    // The profile block starts after the frontal stages: find it from the end (faces, 3 spreads, mean
    // shape, stages) by its size.
    std::size_t profile_stages = 0;
    for (const auto& s : model.profile->stages)
        profile_stages += 8 + 3 * 4 + 4 * static_cast<std::size_t>(s.basis.size() + s.weights.size() + s.bias.size());
    const std::size_t flag_at = good.size() - profile_stages - 68 * 2 * 8 - 3 * 8 - 4 - 4;
    ASSERT_EQ(good[flag_at], 1);

    std::string bad_flag = good;
    bad_flag[flag_at] = 7;
    rewrite_sdm_header(bad_flag, 4);
    testkit::write_bytes(dir / "flag.sdm", bad_flag);
    expect_sdm_error_naming(dir / "flag.sdm", "invalid profile cascade flag 7");

    std::string cut = good.substr(0, good.size() - profile_stages / 2);  // consistent header, profile stages cut short
    rewrite_sdm_header(cut, 4);
    testkit::write_bytes(dir / "cut.sdm", cut);
    expect_sdm_error_naming(dir / "cut.sdm", "profile stage");

    std::string bad_rank = good;  // rank of the first profile stage
    const std::int32_t rank = 999;
    std::memcpy(bad_rank.data() + good.size() - profile_stages + 8 + 2 * 4, &rank, 4);
    rewrite_sdm_header(bad_rank, 4);
    testkit::write_bytes(dir / "rank.sdm", bad_rank);
    expect_sdm_error_naming(dir / "rank.sdm", "profile stage 1 has invalid rank 999");

    std::string flipped = good;  // checksum still guards the profile block
    flipped[good.size() - 10] ^= 0x5a;
    testkit::write_bytes(dir / "flipped.sdm", flipped);
    expect_sdm_error_naming(dir / "flipped.sdm", "checksum");
}

}  // namespace
}  // namespace facesynth::train
