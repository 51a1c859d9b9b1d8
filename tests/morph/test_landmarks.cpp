#include "morph/landmarks.h"
#include "morph/error.h"

#include "common/test_data.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace facesynth;

TEST(Landmarks, SubsetsHaveDocumentedSizes) {
    EXPECT_EQ(landmark_subset(LandmarkSubset::k7).size(), 7u);
    EXPECT_EQ(landmark_subset(LandmarkSubset::k13).size(), 13u);
    EXPECT_EQ(landmark_subset(LandmarkSubset::k49).size(), 49u);
    EXPECT_EQ(landmark_subset(LandmarkSubset::k68).size(), 68u);
    for (int i : landmark_subset(LandmarkSubset::k49)) {
        EXPECT_GE(i, 17);
        EXPECT_NE(i, 60);
        EXPECT_NE(i, 64);
    }
    EXPECT_THROW((void)parse_landmark_subset("12"), Error);
}

TEST(Landmarks, MirrorPairsAreAnInvolution) {
    const auto m = ibug_mirror_pairs();
    for (int i = 0; i < 68; ++i) EXPECT_EQ(m[static_cast<std::size_t>(m[static_cast<std::size_t>(i)])], i);
    EXPECT_EQ(m[36], 45);  // outer eye corners
    EXPECT_EQ(m[8], 8);    // chin
}

TEST(Landmarks, PtsRoundTripConvertsToOneBased) {
    const auto dir = testkit::fresh_temp_dir("pts_roundtrip");
    Eigen::Matrix2Xd points = Eigen::Matrix2Xd::Random(2, 68) * 100.0;
    write_pts(dir / "a.pts", points);
    const std::string text = [&] {
        std::ifstream in(dir / "a.pts");
        return std::string(std::istreambuf_iterator<char>(in), {});
    }();
    EXPECT_NE(text.find("n_points: 68"), std::string::npos);
    const Eigen::Matrix2Xd back = read_pts(dir / "a.pts");
    EXPECT_LT((back - points).cwiseAbs().maxCoeff(), 1e-6);

    std::ofstream(dir / "one.pts") << "version: 1\nn_points: 1\n{\n1 1\n}\n";
    EXPECT_EQ(read_pts(dir / "one.pts").col(0), Eigen::Vector2d(0, 0));
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
            (void)read_pts(dir / name);
            ADD_FAILURE() << name << " was accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    }
    EXPECT_THROW((void)read_pts(dir / "missing.pts"), Error);
}

TEST(Landmarks, ReadsEveryRealAnnotation) {
    FACESYNTH_REQUIRE_SHARED_DATA(real, "real/lfpw_superviseddescent");
    int count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(real)) {
        if (entry.path().extension() != ".pts") continue;
        const auto p = read_pts(entry.path());
        EXPECT_EQ(p.cols(), 68);
        EXPECT_GT(inter_ocular_distance(p), 10.0);
        ++count;
    }
    EXPECT_EQ(count, 5);
}
