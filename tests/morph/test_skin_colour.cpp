// The skin colour check (morph/skin_colour.h) and the redrawing colour sampler behind synth's
// albedo.reject_implausible.
#include "core/error.h"
#include "core/random.h"
#include "morph/regions.h"
#include "morph/sampling.h"
#include "morph/skin_colour.h"

#include "common/toy_model.h"

#include <gtest/gtest.h>

namespace facesynth {
namespace {

morph::MorphableModel toy_with_colour(const Eigen::Vector3f& mean, const Eigen::Vector3f& shift_per_sigma) {
    morph::MorphableModel m = testkit::make_toy_model();
    testkit::set_uniform_colour_model(m, mean, shift_per_sigma);
    return m;
}

std::uint8_t flaws_of_mean(const Eigen::Vector3f& colour) {
    return morph::SkinColourCheck(toy_with_colour(colour, Eigen::Vector3f(0.01f, 0.01f, 0.01f))).check({}).flaws;
}

TEST(SkinColourCheck, NamesEachWayAMeanSkinColourLeavesTheRangeOfRealSkin) {
    EXPECT_EQ(flaws_of_mean({0.72f, 0.52f, 0.42f}), 0);  // light skin
    EXPECT_EQ(flaws_of_mean({0.11f, 0.045f, 0.022f}), 0);  // the built-in model's darkest tone, sRGB (92, 59, 41)
    EXPECT_EQ(flaws_of_mean({0.6f, 0.05f, 0.04f}), morph::kSkinTooRed);
    EXPECT_EQ(flaws_of_mean({0.01f, 0.006f, 0.004f}), morph::kSkinTooDark);
    EXPECT_EQ(flaws_of_mean({0.97f, 0.93f, 0.9f}), morph::kSkinTooLight);
    EXPECT_EQ(flaws_of_mean({0.3f, 0.5f, 0.2f}), morph::kSkinWrongHue);  // green
    EXPECT_EQ(flaws_of_mean({0.3f, 0.25f, 0.4f}), morph::kSkinWrongHue);  // violet
    EXPECT_EQ(morph::flaw_names(morph::kSkinTooRed | morph::kSkinClamped), "too_red,clamped");
}

TEST(SkinColourCheck, CountsSkinClampedByTheUnitRangeAndUsesOnlySkinVertices) {
    // Each σ takes 0.3 from green and blue: at +2σ every vertex has negative blue, clamped to 0.
    const morph::MorphableModel m = toy_with_colour({0.7f, 0.55f, 0.45f}, {0.0f, -0.3f, -0.3f});
    const morph::SkinColourCheck check(m);
    const std::vector<std::uint8_t> labels = m.vertex_labels;  // the toy model's own: none, so derived
    EXPECT_TRUE(labels.empty());
    EXPECT_GT(check.skin_vertices(), 0);
    EXPECT_LT(check.skin_vertices(), m.num_vertices());  // eyes, brows, lips, nose and neck are left out
    const morph::SkinColourVerdict at_mean = check.check({});
    EXPECT_TRUE(at_mean.plausible());
    EXPECT_EQ(at_mean.clamped_share, 0.0);
    const std::vector<float> two_sigma{2.0f};
    const morph::SkinColourVerdict v = check.check(two_sigma);
    EXPECT_NEAR(v.clamped_share, 1.0, 1e-9);
    EXPECT_NEAR(v.mean.z(), 0.0, 1e-6);
    EXPECT_NE(v.flaws & morph::kSkinClamped, 0);
    EXPECT_NE(v.flaws & morph::kSkinTooRed, 0);  // green 0.55 - 0.6 < 0 too
}

TEST(SkinColourCheck, RefusesAModelWithoutAColourModelOrSkin) {
    morph::MorphableModel m = testkit::make_toy_model();
    m.albedo.reset();
    EXPECT_THROW({ const morph::SkinColourCheck check(m); }, core::Error);
    morph::MorphableModel unlabelled = testkit::make_toy_model();
    unlabelled.landmarks.clear();  // nothing to derive labels from
    try {
        const morph::SkinColourCheck check(unlabelled);
        FAIL() << "no skin vertices accepted";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("no skin vertices"), std::string::npos) << e.what();
    }
}

TEST(DrawAlbedo, KeepsEveryPassingFirstDrawAndRedrawsTheOthersFromTheirOwnStream) {
    // Each σ takes 0.2 from green: draws above +0.75σ are too red, below -1σ greener than red.
    const morph::MorphableModel m = toy_with_colour({0.5f, 0.3f, 0.2f}, {0.0f, -0.2f, 0.0f});
    const morph::SkinColourCheck check(m);
    int redrawn = 0;
    for (std::uint64_t i = 0; i < 200; ++i) {
        core::Rng first = core::make_rng(5, i, core::RandomStream::kAlbedo), redraw = core::make_rng(5, i, core::RandomStream::kAlbedoRedraw);
        const morph::AlbedoDraw checked = morph::draw_albedo(first, redraw, 1, 2.0, 1.0, &check, 16);
        core::Rng plain_first = core::make_rng(5, i, core::RandomStream::kAlbedo), plain_redraw = core::make_rng(5, i, core::RandomStream::kAlbedoRedraw);
        const morph::AlbedoDraw plain = morph::draw_albedo(plain_first, plain_redraw, 1, 2.0, 1.0, nullptr, 16);
        core::Rng reference = core::make_rng(5, i, core::RandomStream::kAlbedo);
        EXPECT_EQ(plain.beta, morph::sample_coefficients(reference, 1, 2.0));  // without a check: the draw as before
        EXPECT_EQ(plain.redraws, 0);
        EXPECT_TRUE(check.check(checked.beta).plausible()) << "sample " << i;
        EXPECT_EQ(checked.shrink, 1.0);
        if (check.check(plain.beta).plausible()) {
            EXPECT_EQ(checked.beta, plain.beta) << "sample " << i;
            EXPECT_EQ(checked.redraws, 0);
        } else {
            EXPECT_GE(checked.redraws, 1) << "sample " << i;
            ++redrawn;
        }
    }
    EXPECT_GT(redrawn, 50);  // about 40 % of draws at 2σ truncation
    EXPECT_LT(redrawn, 110);
}

TEST(DrawAlbedo, ShrinksTheFirstDrawTowardTheMeanWhenNoRedrawPasses) {
    // Only draws within about ±0.03σ of the mean pass: with one redraw allowed, most samples shrink.
    const morph::MorphableModel m = toy_with_colour({0.5f, 0.3f, 0.2f}, {0.0f, -5.0f, 0.0f});
    const morph::SkinColourCheck check(m);
    int shrunk = 0;
    for (std::uint64_t i = 0; i < 50; ++i) {
        core::Rng first = core::make_rng(9, i, core::RandomStream::kAlbedo), redraw = core::make_rng(9, i, core::RandomStream::kAlbedoRedraw);
        const morph::AlbedoDraw d = morph::draw_albedo(first, redraw, 1, 2.0, 1.0, &check, 1);
        EXPECT_TRUE(check.check(d.beta).plausible()) << "sample " << i;
        if (d.shrink < 1.0) {
            ++shrunk;
            EXPECT_EQ(d.redraws, 1);
            core::Rng again = core::make_rng(9, i, core::RandomStream::kAlbedo);
            const float first_draw = morph::sample_coefficients(again, 1, 2.0)[0];
            EXPECT_FLOAT_EQ(d.beta[0], static_cast<float>(first_draw * d.shrink)) << "sample " << i;
        }
    }
    EXPECT_GT(shrunk, 40);
}

}  // namespace
}  // namespace facesynth
