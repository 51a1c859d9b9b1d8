// The depth-only pass, render targets reused across image sizes and textures replaced in place give
// exactly what a full render in a fresh renderer gives.
#include "render_fixtures.h"

#include <gtest/gtest.h>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::toy;

double max_difference(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return 1e30;
    return cv::norm(a, b, cv::NORM_INF);
}

TEST(RenderSizes, DepthOnlyPassHasTheDepthOfAFullRender) {
    const morph::Mesh mesh = toy().instance({});
    const render::Camera camera = make_camera(35, -10, 5, 200, 150);
    render::RenderSettings full;
    full.antialiasing = render::Antialiasing::none();
    render::RenderSettings depth_only;
    depth_only.depth_only = true;
    auto& renderer = testkit::shared_renderer();
    const render::Frame reference = renderer.render(mesh, camera, full);
    const render::Frame depth = renderer.render(mesh, camera, depth_only);
    ASSERT_EQ(depth.depth.size(), cv::Size(200, 150));
    EXPECT_GT(cv::countNonZero(depth.depth > 0), 2000);
    EXPECT_EQ(max_difference(depth.depth, reference.depth), 0.0);
    EXPECT_TRUE(depth.rgb.empty() && depth.mask.empty() && depth.triangle_ids.empty() && depth.normals.empty());
    // A full render after a depth-only one has every map again (the surface attributes come back).
    const render::Frame again = renderer.render(mesh, camera, full);
    EXPECT_EQ(max_difference(again.rgb, reference.rgb), 0.0);
    EXPECT_EQ(max_difference(again.normals, reference.normals), 0.0);
}

TEST(RenderSizes, SmallImageAfterALargeOneMatchesAFreshRenderer) {
    const morph::Mesh mesh = toy().instance({});
    render::RenderSettings plain;
    plain.antialiasing = render::Antialiasing::none();
    render::RenderSettings depth_only;
    depth_only.depth_only = true;
    const render::Camera small = make_camera(20, 5, 0, 96, 80);

    render::Renderer fresh(render::RendererOptions{render::Backend::kEgl, false});
    const render::Frame want = fresh.render(mesh, small, plain);
    const render::Frame want_msaa = fresh.render(mesh, small);  // MSAA 4, default

    render::Renderer reused(render::RendererOptions{render::Backend::kEgl, false});
    (void)reused.render(mesh, make_camera(-30, 0, 0, 320, 240), plain);  // targets grow to 320 x 240
    (void)reused.render(mesh, make_camera(0, 0, 0, 140, 300), depth_only);
    const render::Frame got = reused.render(mesh, small, plain);  // drawn into the targets' corner
    ASSERT_EQ(got.rgb.size(), cv::Size(96, 80));
    EXPECT_EQ(max_difference(got.rgb, want.rgb), 0.0);
    EXPECT_EQ(max_difference(got.mask, want.mask), 0.0);
    EXPECT_EQ(max_difference(got.depth, want.depth), 0.0);
    EXPECT_EQ(max_difference(got.triangle_ids, want.triangle_ids), 0.0);
    EXPECT_EQ(max_difference(got.normals, want.normals), 0.0);
    (void)reused.render(mesh, make_camera(10, 0, 0, 256, 256), render::RenderSettings{});
    const render::Frame got_msaa = reused.render(mesh, small);
    EXPECT_EQ(max_difference(got_msaa.rgb, want_msaa.rgb), 0.0);
    EXPECT_EQ(max_difference(got_msaa.mask, want_msaa.mask), 0.0);
}

TEST(RenderSizes, ASecondTextureOfTheSameSizeReplacesTheFirst) {
    const morph::Mesh mesh = toy().instance({});
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    const render::Camera camera = make_camera(0, 0, 0, 64, 64);
    const cv::Mat first(16, 16, CV_8UC3, cv::Scalar(200, 100, 50));
    cv::Mat second(16, 16, CV_8UC3, cv::Scalar(30, 160, 220));
    second(cv::Rect(0, 0, 8, 16)).setTo(cv::Scalar(90, 20, 140));
    render::Renderer fresh(render::RendererOptions{render::Backend::kEgl, false});
    const render::Frame want = fresh.render(mesh, camera, settings, {{}, &second});
    auto& renderer = testkit::shared_renderer();
    const render::Frame before = renderer.render(mesh, camera, settings, {{}, &first});
    const render::Frame got = renderer.render(mesh, camera, settings, {{}, &second});
    EXPECT_GT(max_difference(before.rgb, want.rgb), 50.0);
    EXPECT_EQ(max_difference(got.rgb, want.rgb), 0.0);
}

}  // namespace
}  // namespace facesynth
