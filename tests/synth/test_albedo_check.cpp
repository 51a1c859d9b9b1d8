// synth's colour draws judged by the skin colour check (synth/albedo_check.h), as `model
// albedo-check` reports them.
#include "synth/albedo_check.h"
#include "synth/scene.h"
#include "morph/builtin.h"

#include <gtest/gtest.h>

namespace facesynth::synth {
namespace {

TEST(AlbedoCheck, CountsTheDrawsSynthMakesAndWhatRejectingThemLeaves) {
    const morph::MorphableModel& model = morph::builtin_model();
    SynthConfig config;
    config.albedo.truncation = 3.0;  // wide draws, so that some are implausible
    config.albedo.scale = 1.5;
    int calls = 0;
    const AlbedoCheckResult r = check_albedo_draws(model, config, 300, [&] { ++calls; });
    EXPECT_EQ(calls, 300);
    EXPECT_EQ(r.count, 300);
    ASSERT_GT(r.implausible, 0);
    EXPECT_EQ(r.redrawn, r.implausible);
    EXPECT_LE(r.implausible_after, r.implausible);
    std::int64_t flagged = 0;
    for (const auto n : r.per_flaw) flagged += n;
    EXPECT_GE(flagged, r.implausible);  // every implausible draw has at least one flaw
    EXPECT_LE(r.luminance_p01, r.luminance_p50);
    EXPECT_LE(r.luminance_p50, r.luminance_p99);
    // The first implausible index is a draw the check rejects, exactly as synth draws it.
    const std::int64_t first = std::stoll(r.implausible_indices.substr(0, r.implausible_indices.find(',')));
    EXPECT_FALSE(morph::SkinColourCheck(model).check(sample_albedo(config, model, first, nullptr).beta).plausible());

    const nlohmann::json j = to_json(r, "builtin", model, config);
    EXPECT_EQ(j.at("implausible"), r.implausible);
    EXPECT_DOUBLE_EQ(j.at("implausible_share").get<double>(), static_cast<double>(r.implausible) / 300.0);
    EXPECT_EQ(j.at("max_redraws"), kMaxAlbedoRedraws);
    for (const auto& [key, value] : j.items()) EXPECT_FALSE(value.is_object() || value.is_array()) << key;  // flat
}

}  // namespace
}  // namespace facesynth::synth
