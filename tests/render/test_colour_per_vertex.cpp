// The gamma-encoded colour computed per vertex and interpolated (shaders.h COLOUR_PER_VERTEX, used for
// a uniform albedo without texture or lights) against the per-pixel encoding it replaces, over random
// poses, SH lightings and skin tones on the built-in and Surrey models; and the bare benchmark renderer.
#include "render_fixtures.h"

#include "common/colour_difference.h"
#include "common/test_data.h"
#include "morph/camera.h"
#include "morph/model_io.h"
#include "render/bare_renderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <random>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

// Lightings as synth draws them by default: a tinted environment of random strength with random
// SH bands, brighter from above and in front, some ambient light.
render::Lighting random_lighting(std::mt19937& rng) {
    std::uniform_real_distribution<float> radiance(0.5f, 1.4f), tint(0.85f, 1.15f), ambient(0.0f, 0.1f);
    std::normal_distribution<float> band(0.0f, 0.5f);
    render::Lighting lighting;
    Eigen::Vector3f dc = Eigen::Vector3f(tint(rng), 1.0f, tint(rng)) * (radiance(rng) * render::kShUniformDc);
    for (int c = 0; c < 3; ++c) lighting.sh[0][static_cast<std::size_t>(c)] = dc[c];
    for (std::size_t k = 1; k < lighting.sh.size(); ++k) {
        const float strength = band(rng) + (k == 1 || k == 2 ? 0.15f : 0.0f);
        for (int c = 0; c < 3; ++c) lighting.sh[k][static_cast<std::size_t>(c)] = dc[c] * strength;
    }
    const float a = ambient(rng);
    lighting.ambient = {a, a, a};
    return lighting;
}

// Renders `count` random views of `model`'s mean shape with one random skin tone each (none for
// every other view: the default grey) per vertex and per pixel, and compares the colours; every
// other output must be identical.
enum class Albedo { kUniform, kModel };

testkit::ColourDifference compare_encodings(const morph::MorphableModel& model, int count, int size, unsigned seed, Albedo albedo) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> yaw(-70, 70), pitch(-25, 25), roll(-15, 15);
    std::uniform_real_distribution<float> red(0.45f, 0.95f), share(0.55f, 0.85f);
    testkit::ColourDifference result;
    render::Frame per_vertex, per_pixel;
    for (int i = 0; i < count; ++i) {
        morph::Mesh mesh = model.instance({});
        if (albedo == Albedo::kModel) {
            // the model's own per-vertex colours
        } else if (i % 2 == 0) {
            const float r = red(rng), g = r * share(rng), b = g * share(rng);
            mesh.colours = Eigen::Vector3f(r, g, b).replicate(1, mesh.num_vertices());
        } else {
            mesh.colours.resize(3, 0);
        }
        render::RenderSettings settings;
        settings.antialiasing = render::Antialiasing::none();
        settings.normals = false;
        settings.lighting = random_lighting(rng);
        render::Camera framed = make_camera(yaw(rng), pitch(rng), roll(rng), size, size);
        // The mesh's centre on the optical axis, its bounding-box diagonal over ~80 % of the image.
        const Eigen::Vector3f low = mesh.vertices.rowwise().minCoeff(), high = mesh.vertices.rowwise().maxCoeff();
        const double distance = (high - low).cast<double>().norm() / (2.0 * std::tan(15.0 * std::numbers::pi / 180.0) * 0.8);
        const Eigen::Vector3d centre = (0.5f * (low + high)).cast<double>();
        framed.pose.translation = Eigen::Vector3d(0, 0, distance) - morph::model_to_camera_flip() * framed.pose.rotation * centre;
        shared_renderer().render(mesh, framed, settings, per_vertex);
        settings.per_pixel_colour = true;
        shared_renderer().render(mesh, framed, settings, per_pixel);
        EXPECT_EQ(cv::norm(per_vertex.mask, per_pixel.mask, cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(per_vertex.triangle_ids, per_pixel.triangle_ids, cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(per_vertex.depth, per_pixel.depth, cv::NORM_INF), 0.0) << "view " << i;
        result.add(per_vertex.rgb, per_pixel.rgb, per_vertex.mask);
        if (i == 0) {
            testkit::save_for_inspection(per_vertex.rgb, "colour_per_vertex_" + model.name + ".png");
            testkit::save_for_inspection(per_pixel.rgb, "colour_per_pixel_" + model.name + ".png");
        }
    }
    std::printf("%s at %d², %s albedo: %d views, max %d levels, mean %.4f, %ld of %ld face pixels differ, %ld by more than 2\n",
                model.name.c_str(), size, albedo == Albedo::kModel ? "own" : "uniform", count, result.max_level,
                result.mean_level(), result.differing_pixels, result.face_pixels, result.over_two_levels);
    return result;
}

// Measured (seeds as below): built-in 256² max 7 levels, mean 0.025, 0.09 % of face pixels over 2 levels;
// Surrey 256² max 4, mean 0.010, 0.003 %; Surrey 512² max 3, mean 0.014, 0.006 %. The largest
// differences are on the shading terminator, where the SH irradiance falls to zero at one corner.
void expect_within_tolerance(const testkit::ColourDifference& d, int views) {
    EXPECT_GT(d.face_pixels, views * 10000L);
    EXPECT_LE(d.max_level, 8);
    EXPECT_LT(d.mean_level(), 0.05);
    EXPECT_LT(static_cast<double>(d.over_two_levels), 0.002 * static_cast<double>(d.face_pixels));
}

}  // namespace

TEST(ColourPerVertex, BuiltinWithinAFewLevelsOfPerPixelEncoding) {
    expect_within_tolerance(compare_encodings(morph::load_model("builtin"), 24, 256, 7, Albedo::kUniform), 24);
}

TEST(ColourPerVertex, SurreyWithinAFewLevelsOfPerPixelEncoding) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const morph::MorphableModel model = morph::load_model(sfm.string());
    expect_within_tolerance(compare_encodings(model, 24, 256, 11, Albedo::kUniform), 24);
    expect_within_tolerance(compare_encodings(model, 12, 512, 11, Albedo::kUniform), 12);
}

// Where the albedo varies between vertices (the built-in model's own colours: hairline, iris, brows,
// lips) encoding before interpolating would blend features in gamma space, so the renderer keeps the
// per-pixel encoding: byte-identical to asking for it.
TEST(ColourPerVertex, VaryingAlbedoKeepsThePerPixelEncoding) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const morph::Mesh mesh = model.instance({});
    ASSERT_GT((mesh.colours.rowwise().maxCoeff() - mesh.colours.rowwise().minCoeff()).maxCoeff(), 0.2f);
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    const render::Camera camera = make_camera(30, -10, 0, 256, 256, 30.0, 700.0);
    const render::Frame per_vertex = shared_renderer().render(mesh, camera, settings);
    settings.per_pixel_colour = true;
    const render::Frame per_pixel = shared_renderer().render(mesh, camera, settings);
    EXPECT_GT(cv::countNonZero(per_vertex.mask), 10000);
    EXPECT_EQ(cv::norm(per_vertex.rgb, per_pixel.rgb, cv::NORM_INF), 0.0);
}

// The bare benchmark renderer draws the same mesh from the same camera: its coverage is the full
// render's mask without anti-aliasing, pixel for pixel.
TEST(BareRenderer, CoversExactlyTheFullRendersMask) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const morph::Mesh mesh = model.instance({});
    render::BareRenderer bare(mesh, {render::Backend::kEgl, false});
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    cv::Mat rgba;
    for (const double yaw : {-50.0, 0.0, 35.0}) {
        const render::Camera camera = make_camera(yaw, 10, -5, 200, 160, 30.0, 700.0);
        bare.render(camera, rgba);
        const render::Frame frame = shared_renderer().render(mesh, camera, settings);
        ASSERT_EQ(rgba.type(), CV_8UC4);
        cv::Mat coverage;
        cv::extractChannel(rgba, coverage, 3);
        EXPECT_GT(cv::countNonZero(coverage), 4500) << "yaw " << yaw;  // 4985 px frontally
        EXPECT_EQ(cv::norm(coverage, frame.mask, cv::NORM_INF), 0.0) << "yaw " << yaw;
    }
}

}  // namespace facesynth
