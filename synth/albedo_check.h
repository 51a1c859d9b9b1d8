#pragma once
// How often synth's colour draws are implausible skin (`facesynth model albedo-check`): the colour
// coefficients of samples 0..count-1 drawn exactly as synth draws them (albedo.truncation,
// albedo.scale, seed), each judged by the skin colour check (morph/skin_colour.h), and what
// albedo.reject_implausible makes of the rejected ones.
#include "morph/model.h"
#include "morph/skin_colour.h"
#include "synth/config.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <string>

namespace facesynth::synth {

inline constexpr std::array<morph::SkinColourFlaw, 5> kSkinColourFlaws{morph::kSkinTooDark, morph::kSkinTooLight, morph::kSkinTooRed,
                                                                       morph::kSkinWrongHue, morph::kSkinClamped};

struct AlbedoCheckResult {
    std::int64_t count = 0;
    int skin_vertices = 0;
    morph::SkinColourLimits limits;
    morph::SkinColourVerdict mean;  // the model's mean colour
    std::int64_t implausible = 0;
    std::array<std::int64_t, kSkinColourFlaws.size()> per_flaw{};  // a draw may have several flaws
    std::string implausible_indices;  // the first 40, comma-separated, for looking at them
    double luminance_p01 = 0, luminance_p50 = 0, luminance_p99 = 0;
    double green_over_red_p01 = 0, green_over_red_p50 = 0, green_over_red_p99 = 0;
    // albedo.reject_implausible on the implausible draws:
    std::int64_t redrawn = 0, redraws = 0, shrunk = 0, implausible_after = 0;

    [[nodiscard]] double implausible_share() const { return count > 0 ? static_cast<double>(implausible) / static_cast<double>(count) : 0.0; }
};

// `config` gives seed, albedo.truncation and albedo.scale. Throws core::Error naming the model when
// it has no colour model or no skin vertices. `on_draw` is called after each sample.
[[nodiscard]] AlbedoCheckResult check_albedo_draws(const morph::MorphableModel& model, const SynthConfig& config, std::int64_t count,
                                                   const std::function<void()>& on_draw = {});

// Flat keys: model, model_checksum, count, seed, truncation, scale, the counts, the flaw names,
// quantiles, limit_* and max_redraws.
[[nodiscard]] nlohmann::json to_json(const AlbedoCheckResult& result, const std::string& model_spec, const morph::MorphableModel& model,
                                     const SynthConfig& config);

}  // namespace facesynth::synth
