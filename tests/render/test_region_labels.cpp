// The label image of a model whose region labels are derived from its landmarks
// (morph/region_labels.h): the Surrey model rendered frontally has each region where its landmarks
// are, as one blob (two for the eyes and the brows) of a plausible size.
#include "common/test_data.h"
#include "render_fixtures.h"

#include "morph/model_io.h"
#include "morph/regions.h"
#include "render/landmarks.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <string>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

morph::Region label_at(const cv::Mat& labels, const Eigen::Vector2d& p) {
    return static_cast<morph::Region>(labels.at<std::uint8_t>(static_cast<int>(std::lround(p.y())), static_cast<int>(std::lround(p.x()))));
}

// Whether `region` occurs in the 3x3 pixels around p (landmarks lie on region borders).
bool near_region(const cv::Mat& labels, const Eigen::Vector2d& p, morph::Region region) {
    const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
    for (int y = cy - 1; y <= cy + 1; ++y)
        for (int x = cx - 1; x <= cx + 1; ++x)
            if (labels.at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(region)) return true;
    return false;
}

// Connected blobs (8-connected) of a region, largest first, as pixel counts.
std::vector<int> blob_sizes(const cv::Mat& labels, morph::Region region) {
    cv::Mat stats, centroids, ids;
    const int n = cv::connectedComponentsWithStats(labels == static_cast<int>(region), ids, stats, centroids, 8);
    std::vector<int> sizes;
    for (int i = 1; i < n; ++i) sizes.push_back(stats.at<int>(i, cv::CC_STAT_AREA));
    std::sort(sizes.rbegin(), sizes.rend());
    return sizes;
}

TEST(RegionLabelImage, SurreyFrontalRegionsSitAtTheirLandmarks) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const morph::MorphableModel model = morph::load_model(sfm.string());
    ASSERT_EQ(static_cast<int>(model.vertex_labels.size()), model.num_vertices());
    const morph::Mesh mesh = model.instance({});
    const render::Camera camera = make_camera(0, 0, 0, 256, 256, 30.0, 600.0);
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    const render::Frame frame = shared_renderer().render(mesh, camera, settings, {model.vertex_labels, nullptr});
    const cv::Mat& labels = frame.labels;
    const Eigen::Matrix2Xd lm = render::project_points(camera, model.landmark_positions(mesh.vertices));
    const auto point = [&](int id) { return Eigen::Vector2d(lm.col(id)); };  // 0-based iBUG id
    const auto centre = [&](int first, int last) {
        Eigen::Vector2d c = Eigen::Vector2d::Zero();
        for (int id = first; id <= last; ++id) c += point(id);
        return Eigen::Vector2d(c / (last - first + 1));
    };

    EXPECT_EQ(label_at(labels, centre(36, 41)), morph::Region::kEyes);
    EXPECT_EQ(label_at(labels, centre(42, 47)), morph::Region::kEyes);
    for (int id = 36; id <= 47; ++id) EXPECT_TRUE(near_region(labels, point(id), morph::Region::kEyes)) << "iBUG " << id + 1;
    for (int id = 48; id <= 59; ++id) EXPECT_TRUE(near_region(labels, point(id), morph::Region::kLips)) << "iBUG " << id + 1;
    // The middle of each lip, between its outer and inner landmarks.
    EXPECT_EQ(label_at(labels, (point(51) + point(62)) / 2), morph::Region::kLips);
    EXPECT_EQ(label_at(labels, (point(57) + point(66)) / 2), morph::Region::kLips);
    EXPECT_EQ(label_at(labels, point(30)), morph::Region::kNose);  // the nose tip
    EXPECT_EQ(label_at(labels, (point(27) + point(30)) / 2), morph::Region::kNose);
    for (int id : {19, 24}) EXPECT_EQ(label_at(labels, point(id)), morph::Region::kBrows) << "iBUG " << id + 1;
    // The cheeks: halfway between the jaw and the nostrils; the forehead above the brows' middle.
    EXPECT_EQ(label_at(labels, (point(3) + point(31)) / 2), morph::Region::kSkin);
    EXPECT_EQ(label_at(labels, (point(13) + point(35)) / 2), morph::Region::kSkin);
    EXPECT_EQ(label_at(labels, point(27) + 0.6 * (point(27) - point(30))), morph::Region::kSkin);

    // One blob per region (eyes and brows: one per side) of a plausible share of the face's pixels;
    // specks of a few pixels along ragged borders are ignored.
    const double face = cv::countNonZero(labels);
    struct Expect {
        morph::Region region;
        int blobs;
        double min_share, max_share;  // of the face's pixels, per blob
    };
    for (const Expect& e : {Expect{morph::Region::kSkin, 1, 0.5, 0.9}, Expect{morph::Region::kNose, 1, 0.04, 0.15},
                            Expect{morph::Region::kLips, 1, 0.015, 0.08}, Expect{morph::Region::kEyes, 2, 0.004, 0.03},
                            Expect{morph::Region::kBrows, 2, 0.01, 0.06}}) {
        const std::string name(morph::region_name(e.region));
        const std::vector<int> sizes = blob_sizes(labels, e.region);
        int large = 0, specks = 0;
        for (int s : sizes) {
            if (s >= 5) {
                ++large;
            } else {
                specks += s;
            }
        }
        EXPECT_EQ(large, e.blobs) << name;
        ASSERT_GE(static_cast<int>(sizes.size()), e.blobs) << name;
        for (int b = 0; b < e.blobs; ++b) {
            const double share = sizes[static_cast<std::size_t>(b)] / face;
            ::testing::Test::RecordProperty(name + "_blob" + std::to_string(b) + "_share", std::to_string(share));
            EXPECT_GT(share, e.min_share) << name;
            EXPECT_LT(share, e.max_share) << name;
        }
        EXPECT_LT(specks, 0.02 * face) << name;
    }
    testkit::save_for_inspection(labels * 25, "surrey_labels_frontal.png");
}

}  // namespace
}  // namespace facesynth
