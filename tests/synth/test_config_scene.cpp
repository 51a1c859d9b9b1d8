// Configuration parsing and the per-sample scene sampler (library level, no rendering).
#include "common/test_data.h"
#include "common/toy_model.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "synth/config.h"
#include "synth/dataset.h"
#include "synth/scene.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <set>

namespace facesynth::synth {
namespace {

TEST(SynthConfig, TomlFileSetsKeysAndRejectsUnknownKeyNamingIt) {
    const auto dir = testkit::fresh_temp_dir("synth_config_toml");
    core::write_file_atomically(dir / "good.toml", "seed = 7\ncount = 5\n[pose.yaw]\ndistribution = \"normal\"\nstddev = 20\n[camera]\nwidth = 128\nfov_min = 12\n");
    SynthConfig config;
    apply_toml_file(config, dir / "good.toml");
    EXPECT_EQ(config.seed, 7u);
    EXPECT_EQ(config.count, 5);
    EXPECT_EQ(config.pose.yaw.distribution, "normal");
    EXPECT_EQ(config.pose.yaw.stddev, 20.0);
    EXPECT_EQ(config.camera.width, 128);
    EXPECT_EQ(config.camera.fov_min, 12.0);  // an integer is accepted for a number
    EXPECT_NO_THROW(validate(config));

    core::write_file_atomically(dir / "bad.toml", "[pose.yaw]\nmax = 40\nmaxx = 50\n");
    SynthConfig other;
    const std::string message = testkit::error_message_of([&] { apply_toml_file(other, dir / "bad.toml"); });
    EXPECT_NE(message.find("pose.yaw.maxx"), std::string::npos) << message;
    EXPECT_NE(message.find("bad.toml"), std::string::npos) << message;

    core::write_file_atomically(dir / "type.toml", "[camera]\nwidth = \"wide\"\n");
    const std::string type_message = testkit::error_message_of([&] { apply_toml_file(other, dir / "type.toml"); });
    EXPECT_NE(type_message.find("camera.width"), std::string::npos) << type_message;
}

TEST(SynthConfig, FuzzFindingInvalidUtf8IsRefusedNamingTheFileAndLine) {
    // fuzz_synth_config: a literal string with invalid UTF-8 made toml11 3.7 read past its buffer
    // (heap-buffer-overflow in location::reset). The config reader now refuses the bytes first.
    const auto kept = testkit::test_files_dir() / "fuzz_regressions" /
                      "synth_config-toml11-heap-overflow-3ea07958.toml";
    ASSERT_TRUE(std::filesystem::exists(kept)) << kept;
    SynthConfig config;
    const std::string message = testkit::error_message_of([&] { apply_toml_file(config, kept); });
    EXPECT_NE(message.find(kept.string() + ": line 2, byte 9: not valid UTF-8"), std::string::npos) << message;
    EXPECT_EQ(config.count, SynthConfig{}.count);  // nothing applied
}

TEST(SynthConfig, OverridesParseByTypeAndNameTheKey) {
    SynthConfig config;
    apply_override(config, "pose.roll.max=5.5");
    apply_override(config, "output.depth=true");
    apply_override(config, "landmarks.mode=fixed");
    EXPECT_EQ(config.pose.roll.max, 5.5);
    EXPECT_TRUE(config.output.depth);
    EXPECT_EQ(config.landmarks.mode, "fixed");
    EXPECT_NE(testkit::error_message_of([&] { apply_override(config, "pose.rol.max=1"); }).find("pose.rol.max"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([&] { apply_override(config, "camera.width=12.5"); }).find("camera.width"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([&] { apply_override(config, "nothing"); }).find("key.sub=value"), std::string::npos);
}

TEST(SynthConfig, ValidationNamesTheOffendingKey) {
    SynthConfig config;
    config.pose.pitch.min = 10;
    config.pose.pitch.max = -10;
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("pose.pitch.min"), std::string::npos);
    config = {};
    config.output.formats = "folder,zip";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("output.formats"), std::string::npos);
    config = {};
    config.landmarks.mode = "dense";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("landmarks.mode"), std::string::npos);
}

TEST(SynthConfig, JsonRoundTripKeepsEveryKey) {
    SynthConfig config;
    config.seed = 99;
    config.pose.yaw.max = 33;
    config.output.formats = "wds,coco";
    config.background.folder = "/x";
    const SynthConfig back = config_from_json(to_json(config));
    EXPECT_EQ(to_json(back), to_json(config));
    EXPECT_EQ(to_json(config)["pose"]["yaw"]["max"], 33.0);
}

TEST(SynthShard, ParsesExplicitAndEnvironmentShards) {
    const auto s = parse_shard("2/5");
    EXPECT_EQ(s.index, 2);
    EXPECT_EQ(s.count, 5);
    EXPECT_THROW((void)parse_shard("5/5"), core::Error);
    EXPECT_THROW((void)parse_shard("1-2"), core::Error);
    ::setenv("JOB_COMPLETION_INDEX", "3", 1);
    const auto k8s = parse_shard("auto", 4);
    EXPECT_EQ(k8s.index, 3);
    EXPECT_EQ(k8s.count, 4);
    EXPECT_THROW((void)parse_shard("auto"), core::Error);  // no total known
    ::unsetenv("JOB_COMPLETION_INDEX");
    ::setenv("SLURM_ARRAY_TASK_ID", "1", 1);
    ::setenv("SLURM_ARRAY_TASK_COUNT", "3", 1);
    const auto slurm = parse_shard("auto");
    EXPECT_EQ(slurm.index, 1);
    EXPECT_EQ(slurm.count, 3);
    ::unsetenv("SLURM_ARRAY_TASK_ID");
    ::unsetenv("SLURM_ARRAY_TASK_COUNT");
    const auto none = parse_shard("auto");
    EXPECT_EQ(none.index, 0);
    EXPECT_EQ(none.count, 1);
}

TEST(SynthScene, DependsOnlyOnSeedAndIndex) {
    const auto model = testkit::make_toy_model();
    SynthConfig config;
    const auto a = sample_scene(config, model, 17);
    const auto b = sample_scene(config, model, 17);
    const auto c = sample_scene(config, model, 18);
    EXPECT_EQ(a.alpha, b.alpha);
    EXPECT_EQ(a.psi, b.psi);
    EXPECT_TRUE(a.pose.rotation.isApprox(b.pose.rotation, 0));
    EXPECT_TRUE(a.pose.translation == b.pose.translation);
    EXPECT_EQ(a.key, "s00000017");
    EXPECT_NE(a.alpha, c.alpha);
    config.seed = 2;
    EXPECT_NE(sample_scene(config, model, 17).alpha, a.alpha);
}

TEST(SynthScene, PlacesTheFaceAtTheSampledSizeInsideTheAngleRanges) {
    const auto model = testkit::make_toy_model();
    SynthConfig config;
    config.camera.face_scale_min = 0.4;
    config.camera.face_scale_max = 0.5;
    config.pose.translation_jitter = 0.05;
    const double diagonal = std::hypot(config.camera.width, config.camera.height);
    for (int i = 0; i < 50; ++i) {
        const auto s = sample_scene(config, model, i);
        EXPECT_LE(std::abs(s.angles.yaw), 90.0);
        EXPECT_LE(std::abs(s.angles.pitch), 30.0);
        EXPECT_LE(std::abs(s.angles.roll), 20.0);
        EXPECT_GT(s.pose.translation.z(), 0.0);
        const auto vertices = model.shape_instance(s.alpha, s.psi);
        const Eigen::Matrix2Xd p = project(s.intrinsics, s.pose, model.landmark_positions(vertices));
        const double size = (p.rowwise().maxCoeff() - p.rowwise().minCoeff()).norm() / diagonal;
        EXPECT_GT(size, 0.4 - 0.02) << "sample " << i;
        EXPECT_LT(size, 0.5 + 0.02) << "sample " << i;
        const Eigen::Vector2d centre = 0.5 * (p.rowwise().maxCoeff() + p.rowwise().minCoeff());
        EXPECT_LT(std::abs(centre.x() - 127.5), 0.05 * 256 + 2) << "sample " << i;
    }
}

TEST(SynthScene, NeutralShareGivesEmptyExpressions) {
    const auto model = testkit::make_toy_model();
    SynthConfig config;
    config.expression.neutral_share = 1.0;
    for (int i = 0; i < 10; ++i) EXPECT_TRUE(sample_scene(config, model, i).psi.empty());
    config.expression.neutral_share = 0.0;
    for (int i = 0; i < 10; ++i) {
        const auto psi = sample_scene(config, model, i).psi;
        ASSERT_EQ(static_cast<int>(psi.size()), model.num_expression_components());
        EXPECT_GT(*std::max_element(psi.begin(), psi.end()), 0.0f);
    }
}

// albedo.reject_implausible changes only the colour coefficients of the samples whose first draw
// the skin colour check rejects; every other sample, and every other draw, stays as it was.
TEST(SynthScene, RejectImplausibleRedrawsOnlyTheRejectedColourDraws) {
    morph::MorphableModel model = testkit::make_toy_model();
    testkit::set_uniform_colour_model(model, {0.5f, 0.3f, 0.2f}, {0.0f, -0.2f, 0.0f});  // 40 % rejected
    const morph::SkinColourCheck check(model);
    SynthConfig on, off;
    off.albedo.reject_implausible = false;
    EXPECT_TRUE(on.albedo.reject_implausible);  // the default
    const std::optional<morph::SkinColourCheck> made = make_albedo_check(on, model);
    ASSERT_TRUE(made.has_value());
    EXPECT_FALSE(make_albedo_check(off, model).has_value());
    int redrawn = 0;
    for (int i = 0; i < 60; ++i) {
        const SampleSpec a = sample_scene(off, model, i), b = sample_scene(on, model, i, &*made);
        EXPECT_EQ(a.alpha, b.alpha);
        EXPECT_EQ(a.psi, b.psi);
        EXPECT_TRUE(a.pose.translation == b.pose.translation);
        EXPECT_EQ(nlohmann::json(a.lighting.lighting), nlohmann::json(b.lighting.lighting));
        EXPECT_EQ(a.albedo_redraws, 0);
        EXPECT_TRUE(check.check(b.beta).plausible()) << i;
        if (check.check(a.beta).plausible()) {
            EXPECT_EQ(a.beta, b.beta) << i;
            EXPECT_EQ(b.albedo_redraws, 0) << i;
        } else {
            EXPECT_GE(b.albedo_redraws, 1) << i;
            ++redrawn;
        }
        EXPECT_EQ(sample_scene(on, model, i).beta, b.beta) << i;  // the check made inside gives the same draw
    }
    EXPECT_GT(redrawn, 3);
    // A model whose mean colour already fails cannot be sampled with the check.
    testkit::set_uniform_colour_model(model, {0.6f, 0.05f, 0.04f}, {0.0f, 0.01f, 0.0f});
    model.name = "red";
    const std::string message = testkit::error_message_of([&] { (void)make_albedo_check(on, model); });
    EXPECT_NE(message.find("'red'"), std::string::npos) << message;
    EXPECT_NE(message.find("albedo.reject_implausible"), std::string::npos) << message;
}

TEST(SynthScene, ShadowProbabilityOnlyAddsTheShadowFlag) {
    const morph::MorphableModel model = testkit::make_toy_model();
    SynthConfig off, on, half;
    on.lighting.shadow_probability = 1.0;
    half.lighting.shadow_probability = 0.5;
    int lit = 0, half_shadowed = 0;
    for (int i = 0; i < 40; ++i) {
        const render::Lighting a = sample_scene(off, model, i).lighting.lighting;
        const render::Lighting b = sample_scene(on, model, i).lighting.lighting;
        EXPECT_FALSE(a.shadows) << i;
        EXPECT_EQ(b.shadows, !b.lights.empty()) << i;  // no directional light, nothing to shadow
        nlohmann::json ja = a, jb = b;
        ja.erase("shadows");
        jb.erase("shadows");
        EXPECT_EQ(ja, jb) << i;  // the other draws are those of a dataset without shadows
        lit += b.lights.empty() ? 0 : 1;
        half_shadowed += sample_scene(half, model, i).lighting.lighting.shadows ? 1 : 0;
    }
    EXPECT_GT(lit, 10);
    EXPECT_GT(half_shadowed, 0);
    EXPECT_LT(half_shadowed, lit);
    half.lighting.shadow_probability = 1.5;
    EXPECT_NE(testkit::error_message_of([&] { validate(half); }).find("lighting.shadow_probability"), std::string::npos);
    half.lighting.shadow_probability = 0.5;
    half.render.shadow_map_size = 8;
    EXPECT_NE(testkit::error_message_of([&] { validate(half); }).find("render.shadow_map_size"), std::string::npos);
}

// Sharpening is drawn after every other degradation: turning it on changes no other value, so the
// images of a dataset made before it existed stay as they were.
TEST(SynthScene, SharpenProbabilityOnlyAddsTheSharpenAmount) {
    const morph::MorphableModel model = testkit::make_toy_model();
    SynthConfig off, on;
    on.degrade.sharpen_probability = 1.0;
    on.degrade.sharpen_amount_max = 3.0;
    for (int i = 0; i < 40; ++i) {
        const degrade::DegradationSpec a = sample_scene(off, model, i).degradation;
        const degrade::DegradationSpec b = sample_scene(on, model, i).degradation;
        EXPECT_EQ(a.sharpen_amount, 0.0) << i;
        EXPECT_GE(b.sharpen_amount, 0.25) << i;
        EXPECT_LE(b.sharpen_amount, 3.0) << i;
        EXPECT_EQ(a.blur_sigma, b.blur_sigma) << i;
        EXPECT_EQ(a.noise_sigma, b.noise_sigma) << i;
        EXPECT_EQ(a.jpeg_quality, b.jpeg_quality) << i;
        EXPECT_EQ(a.gamma, b.gamma) << i;
        EXPECT_EQ(a.gains, b.gains) << i;
        EXPECT_EQ(a.downscale, b.downscale) << i;
    }
    on.degrade.sharpen_amount_max = 0.1;
    EXPECT_NE(testkit::error_message_of([&] { validate(on); }).find("degrade.sharpen_amount_max"), std::string::npos);
    on.degrade.sharpen_amount_max = 3.0;
    on.degrade.sharpen_probability = -0.5;
    EXPECT_NE(testkit::error_message_of([&] { validate(on); }).find("degrade.sharpen_probability"), std::string::npos);
}

// occluders.fill = "image" adds a crop seed to each occluder and changes nothing else that is drawn; it
// needs background images to crop.
TEST(SynthScene, ImageFilledOccludersOnlyAddTheImageSeed) {
    const morph::MorphableModel model = testkit::make_toy_model();
    SynthConfig flat;
    flat.occluders.probability = 1.0;
    flat.occluders.max_count = 3;
    SynthConfig filled = flat;
    filled.occluders.fill = "image";
    filled.background.type = "wallpapers";
    std::set<std::uint64_t> seeds;
    for (int i = 0; i < 40; ++i) {
        const SampleSpec a = sample_scene(flat, model, i), b = sample_scene(filled, model, i);
        ASSERT_EQ(a.occluders.size(), b.occluders.size()) << i;
        ASSERT_FALSE(a.occluders.empty()) << i;
        for (std::size_t k = 0; k < a.occluders.size(); ++k) {
            EXPECT_EQ(a.occluders[k].image_seed, 0U) << i;
            EXPECT_NE(b.occluders[k].image_seed, 0U) << i;
            seeds.insert(b.occluders[k].image_seed);
            EXPECT_EQ(a.occluders[k].shape, b.occluders[k].shape) << i;
            EXPECT_EQ(a.occluders[k].centre, b.occluders[k].centre) << i;
            EXPECT_EQ(a.occluders[k].half_size, b.occluders[k].half_size) << i;
            EXPECT_EQ(a.occluders[k].angle, b.occluders[k].angle) << i;
            EXPECT_EQ(a.occluders[k].colour, b.occluders[k].colour) << i;
        }
    }
    EXPECT_GT(seeds.size(), 60U);  // one crop per occluder, not one per sample
    filled.background.type = "solid";
    EXPECT_NE(testkit::error_message_of([&] { validate(filled); }).find("occluders.fill"), std::string::npos);
    filled.background.type = "wallpapers";
    filled.occluders.fill = "photo";
    EXPECT_NE(testkit::error_message_of([&] { validate(filled); }).find("occluders.fill"), std::string::npos);
}

// occluders.fill = "skin" only adds a shade to each occluder; occluders.placement = "jaw" changes where
// the shapes lie, and both keys name themselves when given a value they do not take.
TEST(SynthScene, SkinFilledOccludersOnlyAddAShadeAndPlacementIsChecked) {
    const morph::MorphableModel model = testkit::make_toy_model();
    SynthConfig flat;
    flat.occluders.probability = 1.0;
    flat.occluders.max_count = 3;
    SynthConfig skin = flat;
    skin.occluders.fill = "skin";
    SynthConfig jaw = flat;
    jaw.occluders.placement = "jaw";
    int moved = 0;
    for (int i = 0; i < 20; ++i) {
        const SampleSpec a = sample_scene(flat, model, i), b = sample_scene(skin, model, i), c = sample_scene(jaw, model, i);
        ASSERT_EQ(a.occluders.size(), b.occluders.size()) << i;
        ASSERT_EQ(a.occluders.size(), c.occluders.size()) << i;
        for (std::size_t k = 0; k < a.occluders.size(); ++k) {
            EXPECT_EQ(a.occluders[k].skin_shade, 0.0) << i;
            EXPECT_GE(b.occluders[k].skin_shade, 0.8) << i;
            EXPECT_LE(b.occluders[k].skin_shade, 1.1) << i;
            EXPECT_EQ(a.occluders[k].centre, b.occluders[k].centre) << i;
            EXPECT_EQ(a.occluders[k].half_size, b.occluders[k].half_size) << i;
            EXPECT_EQ(a.occluders[k].angle, b.occluders[k].angle) << i;
            moved += a.occluders[k].centre != c.occluders[k].centre ? 1 : 0;
        }
    }
    EXPECT_GT(moved, 20);
    validate(skin);
    validate(jaw);
    jaw.occluders.placement = "chin";
    EXPECT_NE(testkit::error_message_of([&] { validate(jaw); }).find("occluders.placement"), std::string::npos);
}

TEST(SynthScene, DirectionalMinLightsEverySample) {
    const morph::MorphableModel model = testkit::make_toy_model();
    SynthConfig by_default, at_least_one, exactly_two;
    at_least_one.lighting.directional_min = 1;
    exactly_two.lighting.directional_min = 2;
    int unlit_by_default = 0, one_light = 0;
    for (int i = 0; i < 40; ++i) {
        unlit_by_default += sample_scene(by_default, model, i).lighting.lighting.lights.empty() ? 1 : 0;
        const std::size_t lights = sample_scene(at_least_one, model, i).lighting.lighting.lights.size();
        EXPECT_GE(lights, 1U) << i;
        EXPECT_LE(lights, 2U) << i;
        one_light += lights == 1 ? 1 : 0;
        EXPECT_EQ(sample_scene(exactly_two, model, i).lighting.lighting.lights.size(), 2U) << i;
    }
    EXPECT_GT(unlit_by_default, 5);  // by default a third of the samples have the environment's light only
    EXPECT_GT(one_light, 5);
    EXPECT_LT(one_light, 35);
    exactly_two.lighting.directional_min = 3;
    EXPECT_NE(testkit::error_message_of([&] { validate(exactly_two); }).find("lighting.directional_min"), std::string::npos);
}

// The defaults are the recipe's pose, lens and degradations (measured, docs/results.md); the file of the
// earlier defaults restores exactly what figures measured before them were made with.
TEST(SynthConfig, DefaultsAreThePhotographsPoseAndTheEarlierOnesAreAFileAway) {
    const SynthConfig now;
    EXPECT_EQ(now.pose.yaw.distribution, "normal");
    EXPECT_EQ(now.pose.yaw.stddev, 25.0);
    EXPECT_EQ(now.pose.yaw.max, 60.0);
    EXPECT_EQ(now.pose.pitch.distribution, "normal");
    EXPECT_EQ(now.pose.roll.stddev, 8.0);
    EXPECT_EQ(now.camera.fov_max, 20.0);
    EXPECT_EQ(now.degrade.jpeg_probability, 0.5);
    EXPECT_NO_THROW(validate(now));
    SynthConfig earlier;
    apply_toml_file(earlier, testkit::source_dir() / "data" / "synth_defaults_2026-11.toml");
    EXPECT_EQ(earlier.pose.yaw.distribution, "uniform");
    EXPECT_EQ(earlier.pose.yaw.min, -90.0);
    EXPECT_EQ(earlier.pose.yaw.max, 90.0);
    EXPECT_EQ(earlier.pose.pitch.distribution, "uniform");
    EXPECT_EQ(earlier.pose.roll.distribution, "uniform");
    EXPECT_EQ(earlier.camera.fov_min, 10.0);
    EXPECT_EQ(earlier.camera.fov_max, 40.0);
    for (const double p : {earlier.degrade.blur_probability, earlier.degrade.noise_probability, earlier.degrade.jpeg_probability,
                           earlier.degrade.gamma_probability, earlier.degrade.colour_jitter_probability, earlier.degrade.downscale_probability})
        EXPECT_EQ(p, 0.0);
    EXPECT_NO_THROW(validate(earlier));
}

// One anti-aliasing method, with a sample count bounded per method; the error names the key at fault.
TEST(SynthConfig, AntialiasingIsOneMethodWithItsSampleCount) {
    SynthConfig config;
    EXPECT_EQ(config.render.antialiasing, "edges");  // the default
    EXPECT_EQ(config.render.antialiasing_samples, 0);
    EXPECT_NO_THROW(validate(config));
    apply_override(config, "render.antialiasing=msaa");
    EXPECT_NO_THROW(validate(config));  // 0: MSAA's default of 4
    apply_override(config, "render.antialiasing_samples=32");
    const std::string too_many = testkit::error_message_of([&] { validate(config); });
    EXPECT_NE(too_many.find("render.antialiasing_samples"), std::string::npos) << too_many;
    EXPECT_NE(too_many.find("2 to 16"), std::string::npos) << too_many;
    apply_override(config, "render.antialiasing=supersampling");
    apply_override(config, "render.antialiasing_samples=5");
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("render.antialiasing_samples"), std::string::npos);
    apply_override(config, "render.antialiasing_samples=2");
    EXPECT_NO_THROW(validate(config));
    apply_override(config, "render.antialiasing=edges");
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("render.antialiasing_samples"), std::string::npos);  // edges take none
    apply_override(config, "render.antialiasing=blur");
    const std::string unknown = testkit::error_message_of([&] { validate(config); });
    EXPECT_NE(unknown.find("render.antialiasing'"), std::string::npos) << unknown;
    EXPECT_NE(unknown.find("none, msaa, supersampling or edges"), std::string::npos) << unknown;
    apply_override(config, "render.antialiasing=supersampling");
    EXPECT_EQ(config_from_json(to_json(config)).render.antialiasing, "supersampling");
    EXPECT_EQ(config_from_json(to_json(config)).render.antialiasing_samples, 2);
    // The keys it replaced are named as such.
    for (const char* old_key : {"render.msaa_samples=4", "render.supersampling=2", "render.edge_antialiasing=false"}) {
        const std::string replaced = testkit::error_message_of([&] { apply_override(config, old_key); });
        EXPECT_NE(replaced.find("was replaced by render.antialiasing"), std::string::npos) << replaced;
    }
}

TEST(SynthScene, ColourTemperatureIsWhiteAtDaylightAndWarmBelow) {
    const auto daylight = colour_of_temperature(6500);
    EXPECT_NEAR(daylight.x(), 1.0, 1e-9);
    EXPECT_NEAR(daylight.z(), 1.0, 1e-9);
    const auto warm = colour_of_temperature(3000);
    EXPECT_GT(warm.x(), warm.y());
    EXPECT_GT(warm.y(), warm.z());
}

TEST(SynthScene, WhiteBalanceRemovesTheEnvironmentCastByTheChosenShare) {
    const auto model = testkit::make_toy_model();
    SynthConfig config;
    config.lighting.colour_temperature_min = config.lighting.colour_temperature_max = 3200;
    const auto dc_of = [&](double share) {
        config.lighting.white_balance = share;
        const LightingSpec spec = sample_scene(config, model, 7).lighting;
        return Eigen::Vector3d(spec.lighting.sh[0][0], spec.lighting.sh[0][1], spec.lighting.sh[0][2]);
    };
    const Eigen::Vector3d raw = dc_of(0), balanced = dc_of(1), partial = dc_of(0.7);
    const Eigen::Vector3d warm = colour_of_temperature(3200);
    EXPECT_NEAR(raw.x() / raw.z(), warm.x() / warm.z(), 1e-5);   // the raw illuminant colour
    EXPECT_NEAR(balanced.x() / balanced.z(), 1.0, 1e-5);          // grey
    EXPECT_GT(partial.x() / partial.z(), 1.05);                   // still warm
    EXPECT_LT(partial.x() / partial.z(), raw.x() / raw.z());
    EXPECT_NEAR(balanced.mean(), raw.mean(), 1e-5 * raw.mean());  // brightness kept
}

}  // namespace
}  // namespace facesynth::synth
