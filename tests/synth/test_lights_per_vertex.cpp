// Directional lights evaluated per vertex (render::RenderSettings::lights_per_vertex, synth
// render.lights_per_vertex) against the per-pixel reference, on synth's own scenes: its poses,
// cameras, face sizes, skin colours and lightings (sample_scene), at 256², 512² and 1024².
#include "common/colour_difference.h"
#include "common/test_data.h"
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"
#include "synth/scene.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

namespace facesynth::synth {
namespace {

struct LitComparison {
    testkit::ColourDifference difference;
    double mean_edge_px = 0;  // mean projected edge length of the triangles drawn
};

// Mean length in pixels of the projected edges of the triangles drawn in `frame` (ids present).
double mean_drawn_edge(const morph::Mesh& mesh, const render::Camera& camera, const render::Frame& frame) {
    std::vector<char> drawn(mesh.triangles.size(), 0);
    for (int y = 0; y < frame.triangle_ids.rows; ++y)
        for (int x = 0; x < frame.triangle_ids.cols; ++x)
            if (const int id = frame.triangle_ids.at<int>(y, x); id >= 0) drawn[static_cast<std::size_t>(id)] = 1;
    const Eigen::Matrix2Xd pixels = render::project_points(camera, mesh.vertices);
    double sum = 0;
    long edges = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        if (!drawn[t]) continue;
        const morph::Triangle& corners = mesh.triangles[t];
        for (std::size_t k = 0; k < 3; ++k, ++edges)
            sum += (pixels.col(corners[k]) - pixels.col(corners[(k + 1) % 3])).norm();
    }
    return edges > 0 ? sum / static_cast<double>(edges) : 0.0;
}

// Renders the first `views` samples with at least one directional light of synth's scene sampler at
// `size`² with the lights per pixel and per vertex, MSAA off, and compares the colours. Mask, ids and
// depth must be identical.
LitComparison compare_lights(const morph::MorphableModel& model, SynthConfig config, int size, int views) {
    config.camera.width = config.camera.height = size;
    const std::optional<morph::SkinColourCheck> check = make_albedo_check(config, model);
    static render::Renderer renderer({render::Backend::kEgl, false});
    LitComparison result;
    morph::Mesh mesh = model.instance({});
    double edge_sum = 0;
    render::Frame per_pixel, per_vertex;
    int compared = 0;
    for (std::int64_t index = 0; compared < views; ++index) {
        Eigen::Matrix3Xf vertices;
        const SampleSpec s = sample_scene(config, model, index, check ? &*check : nullptr, &vertices);
        if (s.lighting.lighting.lights.empty()) continue;
        mesh.vertices = std::move(vertices);
        if (s.skin_tone) mesh.colours = s.skin_tone->cast<float>().replicate(1, mesh.num_vertices());
        else mesh.colours = model.albedo_instance(s.beta);
        const render::Camera camera{s.intrinsics, s.pose, render::Projection::kPerspective};
        render::RenderSettings settings;
        settings.antialiasing = render::Antialiasing::none();
        settings.normals = false;
        settings.lighting = s.lighting.lighting;
        renderer.render(mesh, camera, settings, per_pixel);
        settings.lights_per_vertex = true;
        renderer.render(mesh, camera, settings, per_vertex);
        EXPECT_EQ(cv::norm(per_vertex.mask, per_pixel.mask, cv::NORM_INF), 0.0) << "sample " << index;
        EXPECT_EQ(cv::norm(per_vertex.triangle_ids, per_pixel.triangle_ids, cv::NORM_INF), 0.0) << "sample " << index;
        EXPECT_EQ(cv::norm(per_vertex.depth, per_pixel.depth, cv::NORM_INF), 0.0) << "sample " << index;
        result.difference.add(per_vertex.rgb, per_pixel.rgb, per_pixel.mask);
        edge_sum += mean_drawn_edge(mesh, camera, per_pixel);
        ++compared;
    }
    result.mean_edge_px = edge_sum / compared;
    const testkit::ColourDifference& d = result.difference;
    std::printf("%s %d², specular <= %.2f: %d lit views, mean edge %.1f px: max %d levels, mean %.4f, "
                "%.3f %% of %ld face pixels > 2 levels\n",
                model.name.c_str(), size, config.lighting.specular_max, compared, result.mean_edge_px, d.max_level,
                d.mean_level(), 100.0 * d.share_over_two_levels(), d.face_pixels);
    return result;
}

// Measured with synth's default lighting (12 lit views per size, seeds as here): built-in max 35-36
// levels, mean 0.128, 1.23 % of face pixels over 2 levels; Surrey max 22-31, mean 0.104, 0.51 %; the
// same at every size (the interpolation error belongs to the mesh, not to the image). The largest
// differences are narrow highlights on ridges and creases (nose, lids, lips) that fall between vertices.
// A renderer that ignored the lights, or the highlight, would be tens of levels off on most pixels.
void expect_within_tolerance(const LitComparison& c) {
    const testkit::ColourDifference& d = c.difference;
    EXPECT_GT(d.differing_pixels, 0) << "the lights were not evaluated per vertex";
    EXPECT_LE(d.max_level, 48);
    EXPECT_LT(d.mean_level(), 0.2);
    EXPECT_LT(d.share_over_two_levels(), 0.02);
}

}  // namespace

TEST(LightsPerVertex, BuiltinWithinTolerancesOfPerPixelLightsAtEverySize) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const LitComparison small = compare_lights(model, SynthConfig{}, 256, 8);
    expect_within_tolerance(small);
    expect_within_tolerance(compare_lights(model, SynthConfig{}, 512, 4));
    const LitComparison large = compare_lights(model, SynthConfig{}, 1024, 2);
    expect_within_tolerance(large);
    // Triangles grow with the image (synth frames the face at a fixed share of it).
    EXPECT_GT(large.mean_edge_px, 3.0 * small.mean_edge_px);
}

TEST(LightsPerVertex, SurreyWithinTolerancesOfPerPixelLightsAtEverySize) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const morph::MorphableModel model = morph::load_model(sfm.string());
    SynthConfig config;
    config.model = sfm.string();
    expect_within_tolerance(compare_lights(model, config, 256, 8));
    expect_within_tolerance(compare_lights(model, config, 512, 4));
    expect_within_tolerance(compare_lights(model, config, 1024, 2));
}

// render.lights_per_vertex reaches the renderer: a sample with directional lights changes a little, one
// without is byte-identical, and the landmarks (geometry) are the same.
TEST(LightsPerVertex, SynthKeyShadesLitSamplesPerVertexOnly) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig per_pixel;
    per_pixel.camera.width = per_pixel.camera.height = 128;
    per_pixel.render.lights_per_vertex = false;
    SynthConfig per_vertex = per_pixel;
    apply_override(per_vertex, "render.lights_per_vertex=true");
    ASSERT_TRUE(per_vertex.render.lights_per_vertex);
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator reference(per_pixel, model, none, none, options), gouraud(per_vertex, model, none, none, options);
    int lit = 0, unlit = 0;
    for (std::int64_t index = 0; index < 8; ++index) {
        const Sample a = reference.generate(index), b = gouraud.generate(index);
        const double difference = cv::norm(a.image, b.image, cv::NORM_INF);
        EXPECT_EQ(a.labels.landmarks_contour, b.labels.landmarks_contour) << "sample " << index;
        if (a.spec.lighting.lighting.lights.empty()) {
            ++unlit;
            EXPECT_EQ(difference, 0.0) << "sample " << index;
        } else {
            ++lit;
            EXPECT_GT(difference, 0.0) << "sample " << index;
            EXPECT_LT(cv::norm(a.image, b.image, cv::NORM_L1) / (3.0 * a.image.total()), 0.5) << "sample " << index;
        }
    }
    EXPECT_GT(lit, 0);
    EXPECT_GT(unlit, 0);
}

}  // namespace facesynth::synth
