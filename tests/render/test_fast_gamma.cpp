// The per-pixel gamma encoding for gamma 2.2 (shaders.h GAMMA_2_2: a sum of powers of x^(1/8) from three
// square roots) against GLSL's pow, on the built-in model's own colours with per-pixel and per-vertex
// lights. The reference is the same render at the next float above 2.2, which takes the pow path; one ulp
// of gamma moves no output by a measurable fraction of a level.
#include "render_fixtures.h"

#include "common/colour_difference.h"
#include "morph/model_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

TEST(FastGamma, WithinOneLevelOfPowOnTheBuiltinModelsOwnColours) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const morph::Mesh mesh = model.instance({});
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> yaw(-60, 60), pitch(-20, 20);
    std::uniform_real_distribution<float> strength(0.2f, 0.6f), ambient(0.0f, 0.1f);
    testkit::ColourDifference difference;
    render::Frame fast, reference;
    const int views = 8;
    for (int i = 0; i < views; ++i) {
        render::RenderSettings settings;
        settings.antialiasing = render::Antialiasing::none();
        settings.normals = false;
        settings.lights_per_vertex = i % 2 == 0;
        const float a = ambient(rng), s = strength(rng);
        settings.lighting.ambient = {a, a, a};
        settings.lighting.lights = {{{0.4f, 0.5f, 1.0f}, {s, s, 0.9f * s}}, {{-0.6f, 0.2f, 0.8f}, {0.3f, 0.3f, 0.35f}}};
        settings.lighting.specular = 0.25f;
        settings.lighting.shininess = 32.0f;
        const render::Camera camera = make_camera(yaw(rng), pitch(rng), 0, 256, 256, 30.0, 700.0);
        ASSERT_EQ(settings.lighting.gamma, 2.2f);
        shared_renderer().render(mesh, camera, settings, fast);
        settings.lighting.gamma = std::nextafter(2.2f, 3.0f);
        shared_renderer().render(mesh, camera, settings, reference);
        EXPECT_EQ(cv::norm(fast.mask, reference.mask, cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(fast.triangle_ids, reference.triangle_ids, cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(fast.depth, reference.depth, cv::NORM_INF), 0.0) << "view " << i;
        difference.add(fast.rgb, reference.rgb, fast.mask);
    }
    std::printf("fast gamma: %d views, max %d levels, mean %.4f, %ld of %ld face pixels differ\n", views,
                difference.max_level, difference.mean_level(), difference.differing_pixels, difference.face_pixels);
    EXPECT_GT(difference.face_pixels, views * 10000L);
    EXPECT_LE(difference.max_level, 1);
    EXPECT_LT(static_cast<double>(difference.differing_pixels), 0.05 * static_cast<double>(difference.face_pixels));
    // The cheaper form is in use: a few values sit on the other side of a rounding boundary.
    EXPECT_GT(difference.differing_pixels, 0);
}

}  // namespace
}  // namespace facesynth
