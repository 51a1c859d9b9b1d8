// Geometric exactness: the GL projection agrees with project_points, the frontal render of a
// symmetric model is mirror-symmetric, and the two backends agree.
#include "render_fixtures.h"

#include "core/random.h"
#include "render/landmarks.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <map>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;
using testkit::toy;

// Where vertex `vertex` of `triangle` lands in the rendered image according to the GL barycentric
// buffer: the screen-space barycentrics (surface weights times the corners' depths, normalised)
// are affine in the pixel position, so a least-squares affine fit over the triangle's pixels
// extrapolates exactly to the corner. nullopt when too few pixels cover the triangle.
std::optional<Eigen::Vector2d> corner_from_buffers(const render::Frame& frame, const morph::Mesh& mesh, const render::Camera& camera,
                                                   int triangle, int corner) {
    const morph::Triangle& t = mesh.triangles[static_cast<std::size_t>(triangle)];
    Eigen::Vector3d depth;
    for (int i = 0; i < 3; ++i) {
        const double z = to_camera(camera.pose, Eigen::Vector3d(mesh.vertices.col(t[static_cast<std::size_t>(i)]).cast<double>())).z();
        depth[i] = camera.projection == render::Projection::kPerspective ? z : 1.0;
    }
    std::vector<Eigen::Vector3d> rows;
    std::vector<Eigen::Vector2d> values;
    for (int y = 0; y < frame.triangle_ids.rows; ++y)
        for (int x = 0; x < frame.triangle_ids.cols; ++x) {
            if (frame.triangle_ids.at<int>(y, x) != triangle) continue;
            const cv::Vec3f b = frame.barycentrics.at<cv::Vec3f>(y, x);
            Eigen::Vector3d screen(b[0] * depth[0], b[1] * depth[1], b[2] * depth[2]);
            screen /= screen.sum();
            rows.emplace_back(x, y, 1.0);
            values.emplace_back(screen[(corner + 1) % 3], screen[(corner + 2) % 3]);
        }
    if (rows.size() < 6) return std::nullopt;
    Eigen::MatrixX3d a(static_cast<Eigen::Index>(rows.size()), 3);
    Eigen::MatrixX2d b(static_cast<Eigen::Index>(rows.size()), 2);
    for (std::size_t i = 0; i < rows.size(); ++i) {
        a.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
        b.row(static_cast<Eigen::Index>(i)) = values[i].transpose();
    }
    const Eigen::Matrix<double, 3, 2> fit = a.colPivHouseholderQr().solve(b);
    // The corner is where both other corners' weights vanish: fit^T [x y 1] = 0.
    const Eigen::Matrix2d m = fit.topRows<2>().transpose();
    if (std::abs(m.determinant()) < 1e-12) return std::nullopt;
    return Eigen::Vector2d(m.inverse() * (-fit.row(2).transpose()));
}

struct Agreement {
    double max_error = 0;
    int checked = 0;
};

Agreement check_vertex_projection(render::Renderer& renderer, const morph::Mesh& mesh, const render::Camera& camera) {
    render::RenderSettings settings;
    settings.barycentrics = true;
    settings.antialiasing = render::Antialiasing::none();
    const render::Frame frame = renderer.render(mesh, camera, settings);
    // Triangles around each landmark vertex, by pixel count.
    std::map<int, int> pixels_per_triangle;
    for (int y = 0; y < frame.triangle_ids.rows; ++y)
        for (int x = 0; x < frame.triangle_ids.cols; ++x)
            if (const int id = frame.triangle_ids.at<int>(y, x); id >= 0) ++pixels_per_triangle[id];
    Agreement agreement;
    for (const morph::SurfacePoint& landmark : toy().landmarks) {
        const int vertex = landmark.vertices[0];
        int best = -1, best_pixels = 0, best_corner = 0;
        for (int tri = 0; tri < mesh.num_triangles(); ++tri)
            for (int c = 0; c < 3; ++c)
                if (mesh.triangles[static_cast<std::size_t>(tri)][static_cast<std::size_t>(c)] == vertex) {
                    const auto it = pixels_per_triangle.find(tri);
                    if (it != pixels_per_triangle.end() && it->second > best_pixels) {
                        best = tri;
                        best_pixels = it->second;
                        best_corner = c;
                    }
                }
        if (best < 0) continue;
        const auto from_gl = corner_from_buffers(frame, mesh, camera, best, best_corner);
        if (!from_gl) continue;
        const Eigen::Vector2d projected = render::project_point(camera, mesh.vertices.col(vertex).cast<double>());
        agreement.max_error = std::max(agreement.max_error, (projected - *from_gl).norm());
        ++agreement.checked;
    }
    return agreement;
}

class ProjectionAgreement : public ::testing::TestWithParam<render::Backend> {};

TEST_P(ProjectionAgreement, LandmarksMatchTheBarycentricBufferWithinFiveHundredthsOfAPixel) {
    auto& renderer = shared_renderer(GetParam());
    const std::vector<std::pair<int, int>> sizes{{256, 256}, {317, 241}, {200, 333}, {511, 383}};
    int total_checked = 0;
    for (int i = 0; i < 12; ++i) {
        core::Rng rng(7, static_cast<std::uint64_t>(i), 0);
        const auto [w, h] = sizes[static_cast<std::size_t>(i) % sizes.size()];
        std::vector<float> alpha(static_cast<std::size_t>(toy().num_shape_components()));
        for (float& a : alpha) a = static_cast<float>(rng.normal());
        const morph::Mesh mesh = toy().instance(alpha);
        render::Camera camera = make_camera(rng.uniform(-60, 60), rng.uniform(-30, 30), rng.uniform(-30, 30), w, h,
                                            rng.uniform(15, 50), rng.uniform(450, 900));
        camera.intrinsics.cx += rng.uniform(-20, 20);
        camera.intrinsics.cy += rng.uniform(-20, 20);
        camera.intrinsics.fx *= rng.uniform(0.9, 1.1);
        camera.pose.translation.x() = rng.uniform(-30, 30);
        if (i % 4 == 3) {
            camera.projection = render::Projection::kOrthographic;
            camera.intrinsics.fx = camera.intrinsics.fy = 0.8 * std::min(w, h) / 220.0;
        }
        const Agreement a = check_vertex_projection(renderer, mesh, camera);
        EXPECT_LT(a.max_error, 0.05) << "pose " << i << " (" << w << "x" << h << ")";
        EXPECT_GT(a.checked, 20) << "pose " << i;
        total_checked += a.checked;
    }
    EXPECT_GT(total_checked, 400);
}

INSTANTIATE_TEST_SUITE_P(Backends, ProjectionAgreement,
                         ::testing::Values(render::Backend::kEgl, render::Backend::kOsmesa),
                         [](const auto& info) { return render::to_string(info.param); });

TEST(Symmetry, FrontalRenderOfASymmetricModelIsMirrorSymmetric) {
    const morph::Mesh mesh = toy().instance({});
    for (const int width : {256, 255}) {
        const render::Camera camera = make_camera(0, 0, 0, width, 240);
        const render::Frame frame = shared_renderer().render(mesh, camera);
        cv::Mat mirrored_mask, mirrored_rgb, diff;
        cv::flip(frame.mask, mirrored_mask, 1);
        cv::flip(frame.rgb, mirrored_rgb, 1);
        cv::absdiff(frame.mask, mirrored_mask, diff);
        // Anti-aliasing samples sit at asymmetric positions inside a pixel: edge pixels may differ.
        double max_diff = 0;
        cv::minMaxLoc(diff, nullptr, &max_diff);
        EXPECT_LT(cv::mean(diff)[0], 0.5) << width;
        EXPECT_LE(max_diff, 128) << width;
        cv::absdiff(frame.rgb, mirrored_rgb, diff);
        const cv::Scalar mean = cv::mean(diff);
        EXPECT_LT((mean[0] + mean[1] + mean[2]) / 3.0, 0.5) << width;
        // Geometry (sampled at pixel centres) is symmetric apart from the rasteriser's tie rules.
        cv::Mat ids_mirrored, face = frame.triangle_ids >= 0;
        cv::flip(face, ids_mirrored, 1);
        EXPECT_LT(cv::countNonZero(face != ids_mirrored), 0.002 * width * 240) << width;
    }
}

TEST(Backends, EglAndOsmesaAgree) {
    const morph::Mesh mesh = toy().instance({});
    render::RenderSettings settings;
    settings.lighting.lights.push_back({{0.3f, 0.6f, 1.0f}, {0.5f, 0.5f, 0.5f}});
    settings.lighting.specular = 0.2f;
    const render::Camera camera = make_camera(35, -12, 8, 301, 257);
    const render::Frame egl = shared_renderer(render::Backend::kEgl).render(mesh, camera, settings);
    const render::Frame osmesa = shared_renderer(render::Backend::kOsmesa).render(mesh, camera, settings);
    cv::Mat diff;
    double max_diff = 0;
    cv::absdiff(egl.rgb, osmesa.rgb, diff);
    cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
    EXPECT_LE(max_diff, 1.0);
    cv::absdiff(egl.mask, osmesa.mask, diff);
    cv::minMaxLoc(diff, nullptr, &max_diff);
    EXPECT_LE(max_diff, 1.0);
    cv::absdiff(egl.depth, osmesa.depth, diff);
    cv::minMaxLoc(diff, nullptr, &max_diff);
    EXPECT_LE(max_diff, 1e-3);
    EXPECT_EQ(cv::countNonZero(egl.triangle_ids != osmesa.triangle_ids), 0);
}

}  // namespace
}  // namespace facesynth
