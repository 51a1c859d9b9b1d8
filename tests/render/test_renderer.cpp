#include "render_fixtures.h"

#include "core/error.h"
#include "render/landmarks.h"

#include <gtest/gtest.h>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;
using testkit::toy;

TEST(Renderer, ReportsBackendAndRenderer) {
    auto& r = shared_renderer();
    EXPECT_FALSE(r.renderer_string().empty());
    EXPECT_EQ(r.backend().rfind("egl", 0), 0u) << r.backend();
}

TEST(Renderer, FrontalToyFaceIsCentredAndLit) {
    const morph::Mesh mesh = toy().instance({});
    const render::Camera camera = make_camera(0, 0, 0, 256, 256);
    const render::Frame frame = shared_renderer().render(mesh, camera);
    testkit::save_for_inspection(frame.rgb, "toy_frontal.png");
    render::RenderSettings lit;
    lit.lighting.lights.push_back({{0.5f, 0.5f, 1.0f}, {0.6f, 0.6f, 0.6f}});
    lit.lighting.specular = 0.3f;
    testkit::save_for_inspection(shared_renderer().render(mesh, make_camera(30, -10, 10, 320, 240), lit).rgb,
                                 "toy_yaw30_pitch-10_roll10.png");
    ASSERT_EQ(frame.rgb.type(), CV_8UC3);
    ASSERT_EQ(frame.rgb.size(), cv::Size(256, 256));
    // The head's silhouette: an ellipse of semi-axes 75 x 100 mm seen at ~600 mm.
    const cv::Moments m = cv::moments(frame.mask, false);
    ASSERT_GT(m.m00, 0);
    EXPECT_NEAR(m.m10 / m.m00, 127.5, 1.0);
    EXPECT_NEAR(m.m01 / m.m00, 127.5, 1.5);
    // Depth: the nose tip (model z ~ 112 mm) is the closest point, ~488 mm away.
    double min_depth = 1e9;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const float d = frame.depth.at<float>(y, x);
            if (d > 0) min_depth = std::min(min_depth, static_cast<double>(d));
        }
    EXPECT_NEAR(min_depth, 600.0 - 112.0, 2.0);
    const cv::Vec3b centre = frame.rgb.at<cv::Vec3b>(128, 128);
    EXPECT_GT(centre[0], centre[2]);
}

TEST(Renderer, RejectsInvalidInput) {
    morph::Mesh mesh = toy().instance({});
    render::Camera camera = make_camera(0, 0, 0, 0, 64);
    EXPECT_THROW((void)shared_renderer().render(mesh, camera), core::Error);
    camera = make_camera(0, 0, 0, 64, 64);
    mesh.triangles[0][1] = mesh.num_vertices();
    EXPECT_THROW((void)shared_renderer().render(mesh, camera), core::Error);
}

TEST(Renderer, TextureAndVertexLabelsReachTheOutputs) {
    const morph::Mesh mesh = toy().instance({});
    const cv::Mat texture(8, 8, CV_8UC3, cv::Scalar(200, 100, 50));  // R G B, sRGB-encoded
    const std::vector<std::uint8_t> labels(static_cast<std::size_t>(mesh.num_vertices()),
                                           static_cast<std::uint8_t>(render::Region::kLips));
    render::RenderSettings settings;
    settings.lighting = render::uniform_lighting(1.0f);
    settings.antialiasing = render::Antialiasing::none();
    const render::Frame frame =
        shared_renderer().render(mesh, make_camera(0, 0, 0, 64, 64), settings, {labels, &texture});
    // Sampled as sRGB (linearised), lit by a uniform radiance of 1, re-encoded with gamma 2.2: the
    // texel comes back to within the sRGB-vs-2.2 curve difference.
    const cv::Vec3b centre = frame.rgb.at<cv::Vec3b>(32, 32);
    EXPECT_NEAR(centre[0], 200, 4);
    EXPECT_NEAR(centre[1], 100, 4);
    EXPECT_NEAR(centre[2], 50, 6);
    EXPECT_EQ(frame.labels.at<std::uint8_t>(32, 32), static_cast<std::uint8_t>(render::Region::kLips));
    EXPECT_EQ(frame.labels.at<std::uint8_t>(0, 0), static_cast<std::uint8_t>(render::Region::kBackground));
    EXPECT_EQ(frame.triangle_ids.at<int>(0, 0), -1);
}

// Triangle ids come from a flat per-vertex attribute on a re-indexed mesh (no gl_PrimitiveID); they
// must name the same triangles as the geometry-shader pass, and each pixel's depth must be the
// camera z of that triangle's surface at the pixel centre.
TEST(Renderer, IdsLabelsMaskAndDepthMatchTheReferencePassAndTheSurface) {
    const morph::Mesh mesh = toy().instance({});
    std::vector<std::uint8_t> vertex_labels(static_cast<std::size_t>(mesh.num_vertices()));
    for (std::size_t i = 0; i < vertex_labels.size(); ++i) vertex_labels[i] = static_cast<std::uint8_t>(1 + i % 9);
    for (const render::Projection projection : {render::Projection::kPerspective, render::Projection::kOrthographic}) {
        render::Camera camera = make_camera(40, -15, 10, 211, 173);
        camera.projection = projection;
        if (projection == render::Projection::kOrthographic) camera.intrinsics.fx = camera.intrinsics.fy = 0.7;
        render::RenderSettings fast;
        fast.antialiasing = render::Antialiasing::none();
        fast.normals = false;
        render::RenderSettings reference = fast;
        reference.barycentrics = true;
        const render::Frame a = shared_renderer().render(mesh, camera, fast, {vertex_labels, nullptr});
        const render::Frame b = shared_renderer().render(mesh, camera, reference, {vertex_labels, nullptr});
        EXPECT_TRUE(a.normals.empty());
        EXPECT_TRUE(a.barycentrics.empty());
        ASSERT_EQ(cv::countNonZero(a.triangle_ids != b.triangle_ids), 0);
        int face_pixels = 0;
        double max_depth_error = 0;
        for (int y = 0; y < a.triangle_ids.rows; ++y)
            for (int x = 0; x < a.triangle_ids.cols; ++x) {
                const int id = a.triangle_ids.at<int>(y, x);
                const auto label = a.labels.at<std::uint8_t>(y, x);
                // Without MSAA the coverage is exactly the id buffer's, and the background is black.
                if (id < 0) {
                    ASSERT_EQ(label, 0);
                    ASSERT_EQ(a.depth.at<float>(y, x), 0.0f);
                    ASSERT_EQ(a.mask.at<std::uint8_t>(y, x), 0);
                    ASSERT_EQ(a.rgb.at<cv::Vec3b>(y, x), cv::Vec3b(0, 0, 0));
                    continue;
                }
                ASSERT_EQ(a.mask.at<std::uint8_t>(y, x), 255);
                ASSERT_GT(a.depth.at<float>(y, x), 0.0f);
                ++face_pixels;
                const morph::Triangle& t = mesh.triangles[static_cast<std::size_t>(id)];
                ASSERT_EQ(label, vertex_labels[static_cast<std::size_t>(t[2])]) << "labels follow the provoking (last) vertex";
                const auto point = render::surface_point_at(mesh, camera, a, x, y);
                ASSERT_TRUE(point.has_value());
                max_depth_error = std::max(max_depth_error, std::abs(to_camera(camera.pose, *point).z() - a.depth.at<float>(y, x)));
            }
        EXPECT_GT(face_pixels, 2000);
        EXPECT_LT(max_depth_error, 0.01);  // measured: 0.0024 mm (float vertex transform)
    }
}

}  // namespace
}  // namespace facesynth
