#include "morph/landmarks.h"
#include "core/error.h"

#include "common/test_data.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

using namespace facesynth;

TEST(Landmarks, SubsetsHaveDocumentedSizes) {
    EXPECT_EQ(morph::landmark_subset(morph::LandmarkSubset::k7).size(), 7u);
    EXPECT_EQ(morph::landmark_subset(morph::LandmarkSubset::k13).size(), 13u);
    EXPECT_EQ(morph::landmark_subset(morph::LandmarkSubset::k49).size(), 49u);
    EXPECT_EQ(morph::landmark_subset(morph::LandmarkSubset::k68).size(), 68u);
    for (int i : morph::landmark_subset(morph::LandmarkSubset::k49)) {
        EXPECT_GE(i, 17);
        EXPECT_NE(i, 60);
        EXPECT_NE(i, 64);
    }
    EXPECT_THROW((void)morph::parse_landmark_subset("12"), core::Error);
}

TEST(Landmarks, MirrorPairsAreAnInvolution) {
    const auto m = morph::ibug_mirror_pairs();
    for (int i = 0; i < 68; ++i) EXPECT_EQ(m[static_cast<std::size_t>(m[static_cast<std::size_t>(i)])], i);
    EXPECT_EQ(m[36], 45);  // outer eye corners
    EXPECT_EQ(m[8], 8);    // chin
}

TEST(Landmarks, PtsRoundTripConvertsToOneBased) {
    const auto dir = testkit::fresh_temp_dir("pts_roundtrip");
    Eigen::Matrix2Xd points = Eigen::Matrix2Xd::Random(2, 68) * 100.0;
    morph::write_pts(dir / "a.pts", points);
    const std::string text = [&] {
        std::ifstream in(dir / "a.pts");
        return std::string(std::istreambuf_iterator<char>(in), {});
    }();
    EXPECT_NE(text.find("n_points: 68"), std::string::npos);
    const Eigen::Matrix2Xd back = morph::read_pts(dir / "a.pts");
    EXPECT_LT((back - points).cwiseAbs().maxCoeff(), 1e-6);

    std::ofstream(dir / "one.pts") << "version: 1\nn_points: 1\n{\n1 1\n}\n";
    EXPECT_EQ(morph::read_pts(dir / "one.pts").col(0), Eigen::Vector2d(0, 0));
}

TEST(Landmarks, BadPtsFilesGiveClearErrors) {
    const auto dir = testkit::fresh_temp_dir("pts_bad");
    const std::pair<const char*, const char*> cases[] = {
        {"empty.pts", ""},
        {"count.pts", "version: 1\nn_points: 3\n{\n1 2\n3 4\n}\n"},
        {"nan.pts", "version: 1\nn_points: 1\n{\nnan 2\n}\n"},
        {"text.pts", "version: 1\nn_points: 1\n{\nhello world\n}\n"},
        {"open.pts", "version: 1\nn_points: 1\n{\n1 2\n"},
        {"huge.pts", "version: 1\nn_points: 99999999999\n{\n}\n"},
        {"binary.pts", "\x89PNG\r\n\x1a\n"},
    };
    for (const auto& [name, content] : cases) {
        std::ofstream(dir / name) << content;
        try {
            (void)morph::read_pts(dir / name);
            ADD_FAILURE() << name << " was accepted";
        } catch (const core::Error& e) {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    }
    EXPECT_THROW((void)morph::read_pts(dir / "missing.pts"), core::Error);
}

TEST(Landmarks, ReadsEveryRealAnnotation) {
    FACESYNTH_REQUIRE_SHARED_DATA(real, "real/lfpw_superviseddescent");
    int count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(real)) {
        if (entry.path().extension() != ".pts") continue;
        const auto p = morph::read_pts(entry.path());
        EXPECT_EQ(p.cols(), 68);
        EXPECT_GT(morph::inter_ocular_distance(p), 10.0);
        ++count;
    }
    EXPECT_EQ(count, 5);
}

TEST(FaceFrameOffsets, AreMeasuredInTheFacesOwnFrameAndApplyingThemInverts) {
    // A face of 68 points, rolled by 30° and scaled: offsets are in its frame, in inter-ocular distances.
    Eigen::Matrix2Xd face(2, 68);
    for (int i = 0; i < 68; ++i) face.col(i) << 10.0 * std::cos(0.37 * i) + i, 8.0 * std::sin(0.51 * i) - 0.3 * i;
    for (int i = 36; i < 42; ++i) face.col(i) << -20.0 + i - 36, 0.0;
    for (int i = 42; i < 48; ++i) face.col(i) << 15.0 + i - 42, 0.0;
    const double angle = 30.0 * 3.14159265358979 / 180.0;
    Eigen::Matrix2d rotation;
    rotation << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
    const Eigen::Matrix2Xd rolled = 3.0 * rotation * face;
    Eigen::Matrix2Xd offsets = Eigen::Matrix2Xd::Zero(2, 68);
    offsets(1, 17) = 0.1;   // iBUG 18 lower by a tenth of the inter-ocular distance
    offsets(0, 30) = -0.05;
    const Eigen::Matrix2Xd moved = morph::apply_face_frame_offsets(rolled, offsets);
    const Eigen::Matrix2Xd measured = morph::face_frame_offsets(moved, rolled);
    EXPECT_LT((measured - offsets).cwiseAbs().maxCoeff(), 1e-9);
    // "Down" in the face frame is the rolled image's down: perpendicular to the eye line.
    const Eigen::Vector2d step = moved.col(17) - rolled.col(17);
    EXPECT_NEAR(step.norm(), 0.1 * morph::inter_ocular_distance(rolled), 1e-9);
    EXPECT_NEAR(step.dot(rotation.col(0)), 0.0, 1e-9);
    EXPECT_THROW((void)morph::apply_face_frame_offsets(rolled, Eigen::Matrix2Xd::Zero(2, 5)), core::Error);
    EXPECT_THROW((void)morph::face_frame_offsets(Eigen::Matrix2Xd::Zero(2, 68), Eigen::Matrix2Xd::Zero(2, 68)), core::Error);
}
