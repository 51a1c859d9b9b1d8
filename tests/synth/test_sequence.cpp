// synth's clips (sequence.frames): what is drawn per clip stays, pose and expression move smoothly
// through keys, held intervals are exactly still, and sample i still depends only on (seed, i).
#include "common/toy_model.h"
#include "core/error.h"
#include "synth/config.h"
#include "synth/scene.h"

#include <gtest/gtest.h>

#include <cmath>

namespace facesynth::synth {
namespace {

SynthConfig clip_config(int frames) {
    SynthConfig config;
    config.sequence.frames = frames;
    config.expression.neutral_share = 0;
    config.occluders.probability = 1;
    return config;
}

double largest_change(const std::vector<float>& a, const std::vector<float>& b) {
    double change = 0;
    for (std::size_t c = 0; c < std::max(a.size(), b.size()); ++c)
        change = std::max(change, static_cast<double>(std::abs((c < a.size() ? a[c] : 0.0f) - (c < b.size() ? b[c] : 0.0f))));
    return change;
}

TEST(SynthSequence, AClipKeepsItsSceneAndMovesSmoothly) {
    const auto model = testkit::make_toy_model();
    const SynthConfig config = clip_config(90);
    // Fastest possible yaw: max_turn_deg per key interval, times 1.5 (the ease's steepest slope).
    const double max_yaw_step = 1.5 * config.sequence.max_turn_deg / (config.sequence.key_seconds * config.sequence.fps);
    bool moved = false;
    for (int clip = 0; clip < 3; ++clip) {
        const SampleSpec first = sample_scene(config, model, clip * 90);
        ASSERT_TRUE(first.sequence);
        EXPECT_EQ(first.sequence->clip, clip);
        EXPECT_EQ(first.sequence->frame, 0);
        SampleSpec previous = first;
        for (int frame = 1; frame < 90; ++frame) {
            const SampleSpec s = sample_scene(config, model, clip * 90 + frame);
            EXPECT_EQ(s.sequence->frame, frame);
            EXPECT_DOUBLE_EQ(s.sequence->time_s, frame / 30.0);
            EXPECT_EQ(s.key, sample_key(clip * 90 + frame));
            // Drawn once per clip.
            EXPECT_EQ(s.alpha, first.alpha);
            EXPECT_EQ(s.beta, first.beta);
            EXPECT_EQ(s.skin_tone, first.skin_tone);
            EXPECT_EQ(s.fov, first.fov);
            EXPECT_EQ(s.lighting.environment_radiance, first.lighting.environment_radiance);
            EXPECT_EQ(s.background.pattern_seed, first.background.pattern_seed);
            EXPECT_EQ(s.degradation.blur_sigma, first.degradation.blur_sigma);
            ASSERT_EQ(s.occluders.size(), first.occluders.size());
            if (!s.occluders.empty()) {
                EXPECT_EQ(s.occluders[0].centre, first.occluders[0].centre);
            }
            EXPECT_EQ(s.pose.translation.z(), first.pose.translation.z());
            // Smooth: small steps between frames, inside the configured ranges.
            EXPECT_LE(std::abs(s.angles.yaw - previous.angles.yaw), max_yaw_step + 1e-9) << "clip " << clip << " frame " << frame;
            EXPECT_LE(std::abs(s.angles.pitch - previous.angles.pitch), 0.5 * max_yaw_step + 1e-9);
            EXPECT_LE(std::abs(s.angles.yaw), 90.0);
            EXPECT_LT(largest_change(s.psi, previous.psi), 0.2) << "clip " << clip << " frame " << frame;
            EXPECT_LT((s.pose.translation - previous.pose.translation).norm(), 0.01 * s.pose.translation.z());
            moved = moved || s.angles.yaw != first.angles.yaw;
            previous = s;
        }
    }
    EXPECT_TRUE(moved);
    // The next clip is another scene.
    EXPECT_NE(sample_scene(config, model, 90).alpha, sample_scene(config, model, 0).alpha);
}

TEST(SynthSequence, FramesDependOnlyOnSeedAndIndexAndHeldClipsStandStill) {
    const auto model = testkit::make_toy_model();
    SynthConfig config = clip_config(40);
    const SampleSpec a = sample_scene(config, model, 77);
    const SampleSpec b = sample_scene(config, model, 77);
    EXPECT_EQ(a.angles.yaw, b.angles.yaw);
    EXPECT_EQ(a.psi, b.psi);
    EXPECT_EQ(a.sequence->clip, 1);
    EXPECT_EQ(a.sequence->frame, 37);
    // The first frame of a clip is the still sample with the clip's number as its index (its key aside).
    SynthConfig still = config;
    still.sequence.frames = 0;
    const SampleSpec clip_start = sample_scene(config, model, 40);
    const SampleSpec still_one = sample_scene(still, model, 1);
    EXPECT_EQ(clip_start.alpha, still_one.alpha);
    EXPECT_EQ(clip_start.angles.yaw, still_one.angles.yaw);
    EXPECT_TRUE(clip_start.pose.translation.isApprox(still_one.pose.translation, 1e-12));
    EXPECT_FALSE(still_one.sequence);

    config.sequence.hold_share = 1;
    const SampleSpec start = sample_scene(config, model, 0);
    for (int frame = 1; frame < 40; ++frame) {
        const SampleSpec s = sample_scene(config, model, frame);
        EXPECT_EQ(s.angles.yaw, start.angles.yaw);
        EXPECT_EQ(s.psi, start.psi);
        EXPECT_EQ(s.pose.translation, start.pose.translation);
    }
}

TEST(SynthSequence, BadSettingsNameTheKey) {
    for (const char* assignment : {"sequence.frames=-1", "sequence.fps=0", "sequence.key_seconds=0", "sequence.hold_share=1.5", "sequence.drift=0.9"}) {
        SynthConfig config;
        apply_override(config, assignment);
        const std::string key = std::string(assignment).substr(0, std::string(assignment).find('='));
        try {
            validate(config);
            ADD_FAILURE() << assignment << " was accepted";
        } catch (const core::Error& e) {
            EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
        }
    }
}

}  // namespace
}  // namespace facesynth::synth
