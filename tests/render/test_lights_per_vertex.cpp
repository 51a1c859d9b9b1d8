// RenderSettings::lights_per_vertex where it must change nothing (no directional light, shadows,
// two-sided drawing) and with a texture and an orthographic camera, against the per-pixel lights.
// The error over synth's scenes at three image sizes is tested in tests/synth/test_lights_per_vertex.cpp.
#include "render_fixtures.h"

#include "common/colour_difference.h"
#include "morph/model_io.h"

#include <gtest/gtest.h>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

render::Lighting two_lights() {
    render::Lighting lighting;
    lighting.lights = {{{0.4f, 0.5f, 1.0f}, {0.5f, 0.45f, 0.4f}}, {{-0.6f, 0.2f, 0.8f}, {0.3f, 0.3f, 0.35f}}};
    lighting.specular = 0.2f;
    lighting.shininess = 20.0f;
    return lighting;
}

// The same render with the lights per pixel and per vertex.
struct Pair {
    render::Frame per_pixel, per_vertex;
};

Pair render_both(const morph::Mesh& mesh, const render::Camera& camera, render::RenderSettings settings,
                 const render::MeshExtras& extras = {}) {
    Pair pair;
    settings.lights_per_vertex = false;
    shared_renderer().render(mesh, camera, settings, pair.per_pixel, extras);
    settings.lights_per_vertex = true;
    shared_renderer().render(mesh, camera, settings, pair.per_vertex, extras);
    return pair;
}

}  // namespace

TEST(LightsPerVertex, ChangesNothingWithoutLightsWithShadowsOrTwoSided) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const morph::Mesh mesh = model.instance({});
    const render::Camera camera = make_camera(25, -5, 0, 160, 160, 30.0, 700.0);
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    const Pair unlit = render_both(mesh, camera, settings);
    EXPECT_EQ(cv::norm(unlit.per_pixel.rgb, unlit.per_vertex.rgb, cv::NORM_INF), 0.0);
    settings.lighting = two_lights();
    settings.lighting.shadows = true;
    const Pair shadowed = render_both(mesh, camera, settings);
    EXPECT_EQ(cv::norm(shadowed.per_pixel.rgb, shadowed.per_vertex.rgb, cv::NORM_INF), 0.0);
    settings.lighting.shadows = false;
    settings.cull_back_faces = false;
    const Pair two_sided = render_both(mesh, camera, settings);
    EXPECT_EQ(cv::norm(two_sided.per_pixel.rgb, two_sided.per_vertex.rgb, cv::NORM_INF), 0.0);
    settings.cull_back_faces = true;
    const Pair lit = render_both(mesh, camera, settings);
    EXPECT_GT(cv::norm(lit.per_pixel.rgb, lit.per_vertex.rgb, cv::NORM_INF), 0.0);
}

// A texture keeps its albedo per pixel (only the lighting is interpolated); an orthographic camera
// views every vertex along the same ray. Both stay as close to the per-pixel lights as perspective
// renders with per-vertex colours do (tests/synth: max 35 levels, mean 0.13 on synth's lightings).
TEST(LightsPerVertex, TexturedAndOrthographicRendersStayCloseToPerPixelLights) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const morph::Mesh mesh = model.instance({});
    ASSERT_EQ(mesh.uv.cols(), mesh.num_vertices());
    cv::Mat texture(64, 64, CV_8UC3);
    cv::randu(texture, cv::Scalar(150, 100, 80), cv::Scalar(230, 170, 140));
    const render::MeshExtras textured{{}, &texture};
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    settings.normals = false;
    settings.lighting = two_lights();
    for (const auto projection : {render::Projection::kPerspective, render::Projection::kOrthographic}) {
        render::Camera camera = make_camera(-30, 10, 5, 256, 256, 30.0, 700.0);
        camera.projection = projection;
        if (projection == render::Projection::kOrthographic) {
            camera.intrinsics.fx = camera.intrinsics.fy = 1.0;  // pixels per mm: the head fills ~80 % of the image
            camera.pose.translation.z() = 500.0;
        }
        for (const render::MeshExtras* extras : {static_cast<const render::MeshExtras*>(nullptr), &textured}) {
            const Pair pair = render_both(mesh, camera, settings, extras ? *extras : render::MeshExtras{});
            testkit::ColourDifference d;
            d.add(pair.per_vertex.rgb, pair.per_pixel.rgb, pair.per_pixel.mask);
            const char* name = projection == render::Projection::kOrthographic ? "orthographic" : "perspective";
            std::printf("%s%s: max %d levels, mean %.4f, %.3f %% of %ld face pixels > 2 levels\n", name,
                        extras ? ", textured" : "", d.max_level, d.mean_level(), 100.0 * d.share_over_two_levels(), d.face_pixels);
            EXPECT_GT(d.face_pixels, 10000) << name;
            EXPECT_GT(d.differing_pixels, 0) << name;
            EXPECT_LE(d.max_level, 48) << name;
            EXPECT_LT(d.mean_level(), 0.3) << name;
            EXPECT_LT(d.share_over_two_levels(), 0.03) << name;
        }
    }
}

}  // namespace facesynth
