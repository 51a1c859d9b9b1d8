// Shadow maps for the directional lights (docs/render.md "Shadows"): the nose shadows the cheek on
// its far side from a side light, lit skin facing the light keeps its shade (no acne), shadows off
// renders byte for byte as before, the backends agree, the flag round-trips through JSON, and
// shadow maps are made once per renderer.
#include "render_fixtures.h"

#include "morph/builtin.h"
#include "core/error.h"
#include "render/landmarks.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <string>

namespace facesynth {
namespace {

using testkit::make_camera;
using testkit::shared_renderer;

const morph::MorphableModel& builtin() {
    static const morph::MorphableModel model = morph::builtin_model();
    return model;
}

// A weak sky and one strong light from the image right, a little toward the camera (view space).
render::RenderSettings side_light(bool shadows) {
    render::RenderSettings settings;
    settings.lighting = render::uniform_lighting(0.25f);
    settings.lighting.lights.push_back({{1.0f, 0.0f, 0.3f}, {0.9f, 0.9f, 0.9f}});
    settings.lighting.specular = 0.2f;
    settings.lighting.shadows = shadows;
    return settings;
}

struct FrontalFace {
    morph::Mesh mesh;
    render::Camera camera = make_camera(0, 0, 0, 256, 256, 30.0, 650.0);
    render::MeshExtras extras;
};

const FrontalFace& frontal_face() {
    static const FrontalFace face = [] {
        FrontalFace f;
        f.mesh = builtin().instance({});
        f.extras.vertex_labels = builtin().vertex_labels;
        return f;
    }();
    return face;
}

render::Frame render_face(const render::RenderSettings& settings, render::Backend backend = render::Backend::kEgl) {
    const FrontalFace& face = frontal_face();
    return shared_renderer(backend).render(face.mesh, face.camera, settings, face.extras);
}

// Per pixel, the largest channel difference a - b (positive: b is darker).
int darkening(const render::Frame& a, const render::Frame& b, int x, int y) {
    const cv::Vec3b p = a.rgb.at<cv::Vec3b>(y, x), q = b.rgb.at<cv::Vec3b>(y, x);
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, int(p[c]) - int(q[c]));
    return d;
}

int largest_difference(const render::Frame& a, const render::Frame& b, int x, int y) {
    const cv::Vec3b p = a.rgb.at<cv::Vec3b>(y, x), q = b.rgb.at<cv::Vec3b>(y, x);
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(p[c]) - int(q[c])));
    return d;
}

TEST(Shadows, NoseShadowsTheCheekOnItsFarSideAndLitSkinKeepsItsShade) {
    const render::Frame off = render_face(side_light(false)), on = render_face(side_light(true));
    const FrontalFace& face = frontal_face();
    const auto lm = render::project_landmarks(builtin().landmarks, face.mesh, face.camera, off);
    // iBUG 32 is the nostril point on the image left at a frontal pose, 36 the one on the right;
    // 29 is on the nose ridge between the eyes' height and the tip, 34 under the nose.
    const Eigen::Vector2d left_nostril = lm.pixels.col(31), right_nostril = lm.pixels.col(35);
    const double top = lm.pixels(1, 28), bottom = lm.pixels(1, 33);

    // Just left of the nose (the side away from the light), between the ridge point and the base.
    int shadow_pixels = 0, strongly_darker = 0;
    double total_darkening = 0;
    for (int y = static_cast<int>(top); y <= static_cast<int>(bottom); ++y)
        for (int x = static_cast<int>(left_nostril.x()) - 10; x < static_cast<int>(left_nostril.x()); ++x) {
            if (off.mask.at<std::uint8_t>(y, x) != 255) continue;
            const int d = darkening(off, on, x, y);
            ++shadow_pixels;
            total_darkening += d;
            strongly_darker += d >= 15 ? 1 : 0;
        }
    ASSERT_GT(shadow_pixels, 50);
    EXPECT_GT(total_darkening / shadow_pixels, 8.0) << shadow_pixels << " pixels";
    EXPECT_GT(strongly_darker, shadow_pixels / 4) << shadow_pixels << " pixels";

    // The cheek on the light's side, where the surface faces the light: nothing stands between it and
    // the light, so shadows must not change it (acne would darken speckles of it).
    const Eigen::Vector3d toward_light = morph::model_to_camera_flip() * Eigen::Vector3d(1.0, 0.0, 0.3).normalized();
    int lit_pixels = 0, worst = 0;
    for (int y = static_cast<int>(top); y <= static_cast<int>(bottom); ++y)
        for (int x = static_cast<int>(right_nostril.x()) + 3; x < static_cast<int>(lm.pixels(0, 14)) - 3; ++x) {
            if (off.mask.at<std::uint8_t>(y, x) != 255) continue;
            const cv::Vec3f n = off.normals.at<cv::Vec3f>(y, x);
            if (n[0] * toward_light.x() + n[1] * toward_light.y() + n[2] * toward_light.z() < 0.5) continue;
            ++lit_pixels;
            worst = std::max(worst, largest_difference(off, on, x, y));
        }
    EXPECT_GT(lit_pixels, 200);
    EXPECT_LE(worst, 1) << "over " << lit_pixels << " lit cheek pixels";

    // Shadows only take light away.
    for (int y = 0; y < on.rgb.rows; ++y)
        for (int x = 0; x < on.rgb.cols; ++x) ASSERT_LE(darkening(on, off, x, y), 1) << x << "," << y;
    testkit::save_for_inspection(off.rgb, "shadows_off.png");
    testkit::save_for_inspection(on.rgb, "shadows_on.png");
}

void expect_identical(const render::Frame& a, const render::Frame& b, const std::string& what) {
    const std::pair<const cv::Mat*, const cv::Mat*> maps[] = {
        {&a.rgb, &b.rgb}, {&a.mask, &b.mask}, {&a.depth, &b.depth}, {&a.normals, &b.normals}, {&a.triangle_ids, &b.triangle_ids}};
    for (const auto& [x, y] : maps) {
        ASSERT_EQ(x->size(), y->size()) << what;
        const std::size_t bytes = x->total() * x->elemSize();
        EXPECT_EQ(0, std::memcmp(x->data, y->data, bytes)) << what;
    }
}

TEST(Shadows, OffRendersByteForByteAsWithoutAnyShadowSetting) {
    const render::Frame plain = render_face(side_light(false));
    render::RenderSettings settings = side_light(false);
    settings.shadow_map_size = 64;  // ignored without shadows
    (void)render_face(side_light(true));  // the shadow pass leaves no state behind
    expect_identical(plain, render_face(settings), "shadows off after a render with shadows");
    render::Renderer fresh(render::RendererOptions{render::Backend::kEgl, false});
    const FrontalFace& face = frontal_face();
    expect_identical(plain, fresh.render(face.mesh, face.camera, side_light(false), face.extras), "a fresh renderer");
    // Without directional lights there is nothing to shadow: no pass, the same bytes.
    render::RenderSettings sky;
    const render::Frame sky_plain = render_face(sky);
    sky.lighting.shadows = true;
    expect_identical(sky_plain, render_face(sky), "shadows without directional lights");
    // MSAA off takes the single-pass path.
    render::RenderSettings single = side_light(false);
    single.antialiasing = render::Antialiasing::none();
    const render::Frame single_plain = render_face(single);
    (void)render_face([&] { auto s = single; s.lighting.shadows = true; return s; }());
    expect_identical(single_plain, render_face(single), "single-sample shadows off");
}

TEST(Shadows, EglAndOsmesaAgree) {
    for (int msaa : {0, 4}) {
        render::RenderSettings settings = side_light(true);
        settings.lighting.lights.push_back({{-0.3f, 1.0f, 0.5f}, {0.3f, 0.3f, 0.25f}});  // a second light, another layer
        settings.antialiasing = msaa > 0 ? render::Antialiasing::msaa(msaa) : render::Antialiasing::none();
        const render::Frame egl = render_face(settings, render::Backend::kEgl);
        const render::Frame osmesa = render_face(settings, render::Backend::kOsmesa);
        int worst = 0, differing = 0;
        for (int y = 0; y < egl.rgb.rows; ++y)
            for (int x = 0; x < egl.rgb.cols; ++x) {
                const int d = largest_difference(egl, osmesa, x, y);
                worst = std::max(worst, d);
                differing += d > 0 ? 1 : 0;
            }
        EXPECT_LE(worst, 1) << "msaa " << msaa << ", " << differing << " pixels differ";
    }
}

TEST(Shadows, TwoLightsShadowIndependently) {
    // Light from the right shadows the left of the nose, light from the left the right of it; with
    // both, each shadow still gets the other light (each light has its own map).
    render::RenderSettings right = side_light(true), left = side_light(true), both = side_light(true);
    left.lighting.lights[0].direction = {-1.0f, 0.0f, 0.3f};
    both.lighting.lights.push_back(left.lighting.lights[0]);
    render::RenderSettings both_off = both;
    both_off.lighting.shadows = false;
    const render::Frame r = render_face(right), l = render_face(left), b = render_face(both), b_off = render_face(both_off);
    const FrontalFace& face = frontal_face();
    const auto lm = render::project_landmarks(builtin().landmarks, face.mesh, face.camera, b_off);
    // The largest darkening from `from` to `to` in a band 14 pixels wide beside the nose.
    auto beside_nose = [&](const render::Frame& from, const render::Frame& to, bool left_side) {
        const int x0 = left_side ? static_cast<int>(lm.pixels(0, 31)) - 14 : static_cast<int>(lm.pixels(0, 35)) + 1;
        int most = 0;
        for (int y = static_cast<int>(lm.pixels(1, 28)); y <= static_cast<int>(lm.pixels(1, 33)); ++y)
            for (int x = x0; x < x0 + 14; ++x) most = std::max(most, darkening(from, to, x, y));
        return most;
    };
    EXPECT_GT(beside_nose(b_off, b, true), 10);
    EXPECT_GT(beside_nose(b_off, b, false), 10);
    EXPECT_GT(beside_nose(b, r, true), 10);  // without the left light that side goes darker still
    EXPECT_GT(beside_nose(b, l, false), 10);
}

TEST(Shadows, LightingJsonCarriesTheFlag) {
    render::Lighting lighting;
    EXPECT_FALSE(lighting.shadows);
    lighting.shadows = true;
    lighting.lights.push_back({{1.0f, 0.0f, 0.3f}, {0.9f, 0.9f, 0.9f}});
    const nlohmann::json j = lighting;
    EXPECT_EQ(j.at("shadows"), true);
    const render::Lighting back = j.get<render::Lighting>();
    EXPECT_TRUE(back.shadows);
    EXPECT_EQ(nlohmann::json(back), j);
    EXPECT_FALSE(nlohmann::json::parse(R"({"gamma": 2.0})").get<render::Lighting>().shadows);  // missing: off
    EXPECT_THROW((void)nlohmann::json::parse(R"({"shadows": "yes"})").get<render::Lighting>(), core::Error);
}

TEST(Shadows, MapSizeOutOfRangeIsAnError) {
    render::RenderSettings settings = side_light(true);
    settings.shadow_map_size = 8;
    try {
        (void)render_face(settings);
        FAIL() << "no error for shadow_map_size 8";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("shadow_map_size"), std::string::npos) << e.what();
    }
}

TEST(Shadows, ManyRendersWithShadowsKeepMemorySteady) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "RSS is not a leak measure under AddressSanitizer (LeakSanitizer checks leaks in that build)";
#endif
    const morph::Mesh mesh = testkit::toy().instance({});
    render::Renderer& renderer = shared_renderer();
    render::Frame frame;
    render::RenderSettings settings = side_light(true);
    const render::DirectionalLight light = settings.lighting.lights[0];
    auto run = [&](int count) {
        for (int i = 0; i < count; ++i) {
            settings.shadow_map_size = 64 + 64 * (i / 100 % 2);  // maps are re-made on each size change
            settings.antialiasing = i % 3 == 0 ? render::Antialiasing::msaa(2) : render::Antialiasing::none();
            settings.lighting.lights.assign(static_cast<std::size_t>(1 + i % 2), light);
            renderer.render(mesh, make_camera(i % 90 - 45.0, 0, 0, 32, 33), settings, frame);
        }
    };
    run(200);
    const long before = testkit::resident_kib();
    run(800);
    const long after = testkit::resident_kib();
    EXPECT_LT(after - before, 2048) << "RSS grew from " << before << " to " << after << " KiB";
}

}  // namespace
}  // namespace facesynth
