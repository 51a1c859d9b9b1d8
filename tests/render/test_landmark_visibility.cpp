// Visibility flags of the 51 non-jaw landmarks (render/landmarks.h, is_unoccluded) against an exact
// CPU ray cast over the whole mesh: the segment from the camera centre to the landmark's 3D point
// crosses a front-facing triangle (back faces are culled in the render) more than 0.1 mm before the
// point, or not. Both models, mean face at 256², yaw -85..85 in 5° steps, pitch -20, 0, 20. The
// far eye's corners next to the nose's outline are where the former depth-tolerance rule went wrong.
#include "common/test_data.h"
#include "render_fixtures.h"

#include "morph/builtin.h"
#include "morph/camera.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "render/landmarks.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

constexpr double kMarginMm = 0.1;

// The mesh in camera space with each triangle's bounding box on the normalised image plane
// (x/z, y/z), so that a ray cast skips the triangles whose box misses the ray.
struct CameraMesh {
    Eigen::Matrix3Xd vertices;
    const std::vector<morph::Triangle>* triangles;
    std::vector<Eigen::Vector4d> boxes;  // min x, min y, max x, max y
};

CameraMesh camera_mesh(const morph::Mesh& mesh, const render::Camera& camera) {
    CameraMesh out{to_camera(camera.pose, mesh.vertices), &mesh.triangles, {}};
    out.boxes.reserve(mesh.triangles.size());
    for (const morph::Triangle& t : mesh.triangles) {
        Eigen::Vector4d box(1e9, 1e9, -1e9, -1e9);
        for (const int v : t) {
            const Eigen::Vector3d c = out.vertices.col(v);
            const Eigen::Vector2d p(c.x() / c.z(), c.y() / c.z());
            box = Eigen::Vector4d(std::min(box[0], p.x()), std::min(box[1], p.y()), std::max(box[2], p.x()), std::max(box[3], p.y()));
        }
        out.boxes.push_back(box);
    }
    return out;
}

// Whether the segment from the camera centre to `point` (camera space) crosses a front-facing
// triangle more than kMarginMm before the point: every triangle of the mesh (Möller–Trumbore).
bool ray_hidden(const CameraMesh& mesh, const Eigen::Vector3d& point) {
    const double length = point.norm();
    const Eigen::Vector3d direction = point / length;
    const Eigen::Vector2d on_plane(point.x() / point.z(), point.y() / point.z());
    for (std::size_t i = 0; i < mesh.triangles->size(); ++i) {
        const Eigen::Vector4d& box = mesh.boxes[i];
        if (on_plane.x() < box[0] || on_plane.y() < box[1] || on_plane.x() > box[2] || on_plane.y() > box[3]) continue;
        const morph::Triangle& t = (*mesh.triangles)[i];
        const Eigen::Vector3d a = mesh.vertices.col(t[0]);
        const Eigen::Vector3d e1 = mesh.vertices.col(t[1]) - a, e2 = mesh.vertices.col(t[2]) - a;
        const Eigen::Vector3d p = direction.cross(e2);
        const double det = e1.dot(p);
        if (det <= 1e-12) continue;  // a back face: culled by the renderer, it hides nothing in the image
        const Eigen::Vector3d s = -a;
        const double u = s.dot(p) / det;
        if (u < 0.0 || u > 1.0) continue;
        const Eigen::Vector3d q = s.cross(e1);
        const double v = direction.dot(q) / det;
        if (v < 0.0 || u + v > 1.0) continue;
        const double distance = e2.dot(q) / det;
        if (distance > 0.0 && distance < length - kMarginMm) return true;
    }
    return false;
}

// Whether the ray cast's answer changes when the point moves up to `radius_px` in the image at the
// same depth (8 directions, half and full radius): the point lies that close to an occluding outline.
bool near_an_outline(const CameraMesh& mesh, const render::Camera& camera, const Eigen::Vector3d& point,
                     double radius_px, bool hidden) {
    const double mm_per_px = point.z() / std::sqrt(camera.intrinsics.fx * camera.intrinsics.fy);
    for (int k = 0; k < 8; ++k) {
        const double angle = k * M_PI / 4.0;
        for (const double r : {radius_px / 2.0, radius_px}) {
            const Eigen::Vector3d moved = point + r * mm_per_px * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0);
            if (ray_hidden(mesh, moved) != hidden) return true;
        }
    }
    return false;
}

struct Disagreements {
    int count = 0;
    int flagged_visible = 0;  // the rest: flagged hidden, the ray cast says visible
    int outside_band = 0;     // more than 1 px from an occluding outline
    std::map<int, int> by_landmark;  // 1-based iBUG id -> count

    void add(int ibug, bool flagged, bool in_band) {
        ++count;
        flagged_visible += flagged ? 1 : 0;
        outside_band += in_band ? 0 : 1;
        ++by_landmark[ibug];
    }
    [[nodiscard]] std::string summary() const {
        std::ostringstream text;
        text << count << " (" << flagged_visible << " flagged visible, " << outside_band
             << " more than 1 px from an outline; by iBUG id:";
        for (const auto& [id, n] : by_landmark) text << ' ' << id << 'x' << n;
        text << ')';
        return text.str();
    }
};

struct VisibilityComparison {
    int compared = 0;
    Disagreements rule;        // project_landmarks (is_unoccluded)
    Disagreements depth_test;  // the former rule: is_visible, 2 mm in a 3x3 window
};

VisibilityComparison compare_with_ray_cast(const morph::MorphableModel& model, const std::string& name, int size) {
    const morph::Mesh mesh = model.instance({});
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    settings.normals = false;
    VisibilityComparison out;
    for (const double pitch : {-20.0, 0.0, 20.0})
        for (int yaw = -85; yaw <= 85; yaw += 5) {
            const render::Camera camera = make_camera(yaw, pitch, 0, size, size, 30.0, 600.0);
            const render::Frame frame = shared_renderer().render(mesh, camera, settings);
            const auto lm = render::project_landmarks(model.landmarks, mesh, camera, frame);
            const CameraMesh cmesh = camera_mesh(mesh, camera);
            for (int i = morph::kNumJawLandmarks; i < morph::kNumIbugLandmarks; ++i) {
                const Eigen::Vector3d point = lm.camera_points.col(i);
                const bool hidden = ray_hidden(cmesh, point);
                const bool flagged = lm.visible[static_cast<std::size_t>(i)] != 0;
                const bool depth_flag = render::is_visible(frame, lm.pixels.col(i), point.z());
                ++out.compared;
                if (flagged == hidden) out.rule.add(i + 1, flagged, near_an_outline(cmesh, camera, point, 1.0, hidden));
                if (depth_flag == hidden) out.depth_test.add(i + 1, depth_flag, near_an_outline(cmesh, camera, point, 1.0, hidden));
            }
        }
    std::printf("%s %d², %d flags compared with the ray cast\n  disagreements: %s\n  former depth test: %s\n", name.c_str(),
                size, out.compared, out.rule.summary().c_str(), out.depth_test.summary().c_str());
    return out;
}

// Disagreements are allowed only where the point lies within a pixel of an occluding outline (a
// sliver of surface thinner than a pixel, between pixel centres, that the window's triangles and
// their neighbours do not include), and at most 1 % of the flags.
void expect_agreement(const VisibilityComparison& c) {
    EXPECT_EQ(c.rule.outside_band, 0) << c.rule.summary();
    EXPECT_LE(c.rule.count, c.compared / 100) << c.rule.summary();
    EXPECT_LT(c.rule.count, c.depth_test.count);
}

TEST(LandmarkVisibility, BuiltinAgreesWithARayCastExceptWithinAPixelOfAnOutline) {
    expect_agreement(compare_with_ray_cast(morph::builtin_model(), "builtin", 256));
}

TEST(LandmarkVisibility, SurreyAgreesWithARayCastExceptWithinAPixelOfAnOutline) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    expect_agreement(compare_with_ray_cast(morph::load_model(sfm.string()), "surrey", 256));
}

}  // namespace
}  // namespace facesynth
