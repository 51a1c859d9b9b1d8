// Contour jaw points against the rendered outline of the face region (morph/jaw_contour.h), on the
// built-in and the Surrey model, over yaw 0 to ±75°: every jaw point in contour mode lies on the
// outer edge of the rendered face-region mask along its horizontal line, far side and near side.
#include "common/test_data.h"
#include "render_fixtures.h"

#include "morph/builtin.h"
#include "morph/jaw_contour.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "render/landmarks.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <limits>
#include <string>
#include <vector>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

// Rendered pixels whose visible triangle lies wholly in the face region: the region as the image shows it.
cv::Mat face_region_mask(const morph::MorphableModel& model, const morph::JawContourRegion& region, const render::Frame& frame) {
    std::vector<char> in_region(static_cast<std::size_t>(model.num_vertices()), 0);
    for (int v : region.vertices) in_region[static_cast<std::size_t>(v)] = 1;
    std::vector<char> triangle_in(model.triangles.size(), 0);
    for (std::size_t t = 0; t < model.triangles.size(); ++t) {
        const auto& tri = model.triangles[t];
        triangle_in[t] = in_region[static_cast<std::size_t>(tri[0])] && in_region[static_cast<std::size_t>(tri[1])] &&
                         in_region[static_cast<std::size_t>(tri[2])];
    }
    cv::Mat mask(frame.triangle_ids.size(), CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            const int t = frame.triangle_ids.at<int>(y, x);
            if (t >= 0 && triangle_in[static_cast<std::size_t>(t)]) mask.at<std::uint8_t>(y, x) = 255;
        }
    return mask;
}

bool inside(const cv::Mat& mask, const Eigen::Vector2d& p) {
    const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
    return x >= 0 && y >= 0 && x < mask.cols && y < mask.rows && mask.at<std::uint8_t>(y, x) != 0;
}

// Signed distance (pixels, along `outward`) from `start` to the last mask pixel centre on the ray.
std::optional<double> outermost_along(const cv::Mat& mask, const Eigen::Vector2d& start, const Eigen::Vector2d& outward) {
    std::optional<double> last;
    for (double s = -60.0; s <= 120.0; s += 0.1)
        if (inside(mask, start + s * outward)) last = s;
    return last;
}

// Distance from p to the nearest mask pixel centre that has a 4-neighbour outside the mask.
double distance_to_border(const cv::Mat& mask, const Eigen::Vector2d& p) {
    double best = std::numeric_limits<double>::max();
    for (int y = 1; y + 1 < mask.rows; ++y)
        for (int x = 1; x + 1 < mask.cols; ++x) {
            if (!mask.at<std::uint8_t>(y, x)) continue;
            if (mask.at<std::uint8_t>(y - 1, x) && mask.at<std::uint8_t>(y + 1, x) && mask.at<std::uint8_t>(y, x - 1) &&
                mask.at<std::uint8_t>(y, x + 1))
                continue;
            best = std::min(best, (Eigen::Vector2d(x, y) - p).norm());
        }
    return best;
}

void check_model(const morph::MorphableModel& model, const std::string& name) {
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    ASSERT_FALSE(region.vertices.empty()) << name;
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    int checked = 0, on_outline = 0, hidden = 0;
    for (int identity = 0; identity < 3; ++identity) {
        std::vector<float> alpha(static_cast<std::size_t>(model.num_shape_components()), 0.0f);
        if (identity > 0) {
            core::Rng rng = core::make_rng(2026, static_cast<std::uint64_t>(identity), core::RandomStream::kIdentity);
            for (auto& a : alpha) a = static_cast<float>(std::clamp(rng.normal(), -2.0, 2.0));
        }
        const morph::Mesh mesh = model.instance(alpha);
        for (const double yaw : {0.0, 30.0, -30.0, 45.0, -45.0, 60.0, -60.0, 75.0, -75.0}) {
            const render::Camera camera = make_camera(yaw, 0, 0, 256, 256, 30.0, 600.0);
            const render::Frame frame = shared_renderer().render(mesh, camera, settings);
            const auto lm = render::project_landmarks(model.landmarks, mesh, camera, frame, {}, &region);
            const cv::Mat mask = face_region_mask(model, region, frame);
            const cv::Mat head = frame.triangle_ids >= 0;
            const int far = morph::far_side(camera.pose.rotation);
            for (int j = 0; j < morph::kNumJawLandmarks; ++j) {
                if (j == morph::kChinLandmark) continue;
                const Eigen::Vector3d x = lm.model_points.col(j);
                const Eigen::Vector2d toward_left =
                    (render::project_point(camera, x + Eigen::Vector3d::UnitX()) - lm.pixels.col(j)).normalized();
                const Eigen::Vector2d outward = j < morph::kChinLandmark ? Eigen::Vector2d(-toward_left) : toward_left;
                const Eigen::Vector2d p = lm.contour_pixels.col(j);
                const auto edge = outermost_along(mask, lm.pixels.col(j), outward);
                const std::string where = name + " identity " + std::to_string(identity) + " yaw " + std::to_string(yaw) +
                                          " jaw point " + std::to_string(j + 1);
                if (morph::jaw_on_side(j, far)) {
                    ASSERT_TRUE(edge.has_value()) << where;
                    EXPECT_NEAR((p - lm.pixels.col(j)).dot(Eigen::Vector2d(-outward.y(), outward.x())), 0.0, 0.01) << where;
                    // On the outer edge of the rendered face region along its line, at its fixed
                    // point's height, never inside it; where the region's outline lies further out
                    // than the rendered region reaches, the nose or the lips (not in the region) hide it.
                    const double offset = (p - lm.pixels.col(j)).dot(outward);
                    EXPECT_GT(offset, *edge - 1.5) << where;
                    if (offset > *edge + 1.5) {
                        // Beyond the rendered region: hidden behind the nose or the lips (not in the
                        // region), or on the head's own outline past them.
                        const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
                        ASSERT_TRUE(cx >= 0 && cy >= 0 && cx < mask.cols && cy < mask.rows) << where;
                        const bool covered = frame.triangle_ids.at<int>(cy, cx) >= 0 && !mask.at<std::uint8_t>(cy, cx);
                        EXPECT_TRUE(covered || distance_to_border(head, p) <= 1.5) << where;
                        ++hidden;
                    } else {
                        ++on_outline;
                    }
                } else {
                    // The near side keeps the fixed point, which is on the region's border.
                    EXPECT_EQ(p, lm.pixels.col(j)) << where;
                    if (lm.visible[static_cast<std::size_t>(j)]) {
                        // Border pixel centres lie up to half a pixel inside the region's edge, and a
                        // visible jaw point may lie behind up to outline_tolerance_mm of the face's own
                        // outline (render::is_outline_visible).
                        const double outline_px = std::ceil(render::LandmarkOptions{}.outline_tolerance_mm *
                                                            camera.intrinsics.fy / lm.camera_points(2, j));
                        EXPECT_LE(distance_to_border(mask, p), std::max(2.0, outline_px + 0.5)) << where;
                    }
                }
                ++checked;
            }
            if (yaw == 0.0) {  // frontal: contour = fixed
                for (int j = 0; j < morph::kNumJawLandmarks; ++j) EXPECT_EQ(lm.contour_pixels.col(j), lm.pixels.col(j)) << name;
            }
            if ((identity == 0 && std::abs(yaw) == 60.0) || (identity == 2 && yaw == 75.0) || (identity == 1 && yaw == 45.0)) {
                // 3x enlarged: the region's edge in orange, fixed jaw points cyan, contour points green.
                cv::Mat overlay = frame.rgb.clone();
                cv::Mat region_edge;
                cv::morphologyEx(mask, region_edge, cv::MORPH_GRADIENT, cv::Mat::ones(3, 3, CV_8U));
                overlay.setTo(cv::Scalar(255, 90, 0), region_edge);
                cv::resize(overlay, overlay, {}, 3, 3, cv::INTER_NEAREST);
                const auto at = [](const Eigen::Vector2d& q) {
                    return cv::Point(static_cast<int>(std::lround(3 * q.x() + 1)), static_cast<int>(std::lround(3 * q.y() + 1)));
                };
                for (int j = 0; j < morph::kNumJawLandmarks; ++j) {
                    cv::circle(overlay, at(lm.pixels.col(j)), 3, cv::Scalar(0, 255, 255), -1);
                    cv::circle(overlay, at(lm.contour_pixels.col(j)), 3, cv::Scalar(0, 255, 0), -1);
                }
                testkit::save_for_inspection(overlay, "contour_" + name + "_id" + std::to_string(identity) + "_yaw" + std::to_string(static_cast<int>(yaw)) + ".png");
            }
        }
    }
    EXPECT_GT(checked, 0);
    // At 45-75° the points at nose and mouth height fall behind the nose and lips; the rest are on
    // the visible outline.
    EXPECT_GT(on_outline, hidden) << name;
    ::testing::Test::RecordProperty(name + "_far_on_outline", on_outline);
    ::testing::Test::RecordProperty(name + "_far_hidden_or_on_head_outline", hidden);
}

TEST(ContourOutline, BuiltinJawPointsLieOnTheRenderedFaceOutline) { check_model(morph::builtin_model(), "builtin"); }

TEST(ContourOutline, SurreyJawPointsLieOnTheRenderedFaceOutline) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    check_model(morph::load_model(sfm.string()), "surrey");
}

}  // namespace
}  // namespace facesynth
