#include "synth/albedo_check.h"

#include "synth/scene.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace facesynth::synth {
namespace {

// The p-th quantile (0..1) of `values` (sorted in place), nearest rank; 0 when empty.
double quantile(std::vector<double>& values, double p) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const auto rank = static_cast<std::size_t>(std::lround(p * static_cast<double>(values.size() - 1)));
    return values[rank];
}

}  // namespace

AlbedoCheckResult check_albedo_draws(const morph::MorphableModel& model, const SynthConfig& config, std::int64_t count,
                                     const std::function<void()>& on_draw) {
    const morph::SkinColourCheck check(model);
    AlbedoCheckResult r;
    r.count = count;
    r.skin_vertices = check.skin_vertices();
    r.limits = check.limits();
    r.mean = check.check({});
    int listed = 0;
    std::vector<double> luminance, green_over_red;
    for (std::int64_t i = 0; i < count; ++i) {
        const morph::AlbedoDraw first = sample_albedo(config, model, i, nullptr);
        const morph::SkinColourVerdict v = check.check(first.beta);
        luminance.push_back(v.luminance);
        green_over_red.push_back(v.green_over_red);
        if (!v.plausible()) {
            ++r.implausible;
            for (std::size_t f = 0; f < kSkinColourFlaws.size(); ++f)
                if ((v.flaws & kSkinColourFlaws[f]) != 0) ++r.per_flaw[f];
            if (listed++ < 40) {
                if (!r.implausible_indices.empty()) r.implausible_indices += ',';
                r.implausible_indices += std::to_string(i);
            }
            const morph::AlbedoDraw fixed = sample_albedo(config, model, i, &check);
            ++r.redrawn;
            r.redraws += fixed.redraws;
            r.shrunk += fixed.shrink < 1.0 ? 1 : 0;
            r.implausible_after += check.check(fixed.beta).plausible() ? 0 : 1;
        }
        if (on_draw) on_draw();
    }
    r.luminance_p01 = quantile(luminance, 0.01), r.luminance_p50 = quantile(luminance, 0.5), r.luminance_p99 = quantile(luminance, 0.99);
    r.green_over_red_p01 = quantile(green_over_red, 0.01), r.green_over_red_p50 = quantile(green_over_red, 0.5);
    r.green_over_red_p99 = quantile(green_over_red, 0.99);
    return r;
}

nlohmann::json to_json(const AlbedoCheckResult& r, const std::string& model_spec, const morph::MorphableModel& model,
                       const SynthConfig& config) {
    nlohmann::json j;
    j["model"] = model_spec;
    j["model_checksum"] = model.checksum();
    j["count"] = r.count;
    j["seed"] = config.seed;
    j["truncation"] = config.albedo.truncation;
    j["scale"] = config.albedo.scale;
    j["skin_vertices"] = r.skin_vertices;
    j["implausible"] = r.implausible;
    j["implausible_share"] = r.implausible_share();
    for (std::size_t f = 0; f < kSkinColourFlaws.size(); ++f) j[morph::flaw_names(kSkinColourFlaws[f])] = r.per_flaw[f];
    j["implausible_indices"] = r.implausible_indices;
    j["mean_luminance"] = r.mean.luminance;
    j["mean_green_over_red"] = r.mean.green_over_red;
    j["mean_blue_over_green"] = r.mean.blue_over_green;
    j["mean_plausible"] = r.mean.plausible();
    j["luminance_p01"] = r.luminance_p01;
    j["luminance_p50"] = r.luminance_p50;
    j["luminance_p99"] = r.luminance_p99;
    j["green_over_red_p01"] = r.green_over_red_p01;
    j["green_over_red_p50"] = r.green_over_red_p50;
    j["green_over_red_p99"] = r.green_over_red_p99;
    j["limit_min_luminance"] = r.limits.min_luminance;
    j["limit_max_luminance"] = r.limits.max_luminance;
    j["limit_min_green_over_red"] = r.limits.min_green_over_red;
    j["limit_max_green_over_red"] = r.limits.max_green_over_red;
    j["limit_max_blue_over_green"] = r.limits.max_blue_over_green;
    j["limit_max_clamped_share"] = r.limits.max_clamped_share;
    j["redrawn"] = r.redrawn;
    j["redraws"] = r.redraws;
    j["shrunk"] = r.shrunk;
    j["implausible_after"] = r.implausible_after;
    j["max_redraws"] = kMaxAlbedoRedraws;
    return j;
}

}  // namespace facesynth::synth
