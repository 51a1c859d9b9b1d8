#include "morph/skin_colour.h"

#include "core/error.h"
#include "morph/region_labels.h"
#include "morph/regions.h"
#include "morph/sampling.h"

#include <array>
#include <cmath>
#include <utility>

namespace facesynth::morph {

std::string flaw_names(std::uint8_t flaws) {
    constexpr std::array<std::pair<SkinColourFlaw, const char*>, 5> names{{{kSkinTooDark, "too_dark"},
                                                                           {kSkinTooLight, "too_light"},
                                                                           {kSkinTooRed, "too_red"},
                                                                           {kSkinWrongHue, "wrong_hue"},
                                                                           {kSkinClamped, "clamped"}}};
    std::string out;
    for (const auto& [flaw, name] : names) {
        if ((flaws & flaw) == 0) continue;
        if (!out.empty()) out += ',';
        out += name;
    }
    return out;
}

SkinColourCheck::SkinColourCheck(const MorphableModel& model, const SkinColourLimits& limits) : limits_(limits) {
    if (!model.albedo || model.albedo->empty())
        throw core::Error("model '" + model.name + "' has no colour model, so there is no colour draw to check");
    const std::vector<std::uint8_t> labels = model.vertex_labels.empty() ? derive_region_labels(model) : model.vertex_labels;
    std::vector<Eigen::Index> skin;
    for (std::size_t v = 0; v < labels.size(); ++v)
        if (labels[v] == static_cast<std::uint8_t>(Region::kSkin)) skin.push_back(static_cast<Eigen::Index>(v));
    if (skin.empty() || labels.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("model '" + model.name +
                    "' has no skin vertices: it has no region labels and no 68 iBUG landmarks to derive them from");
    // Only the skin's rows of the rescaled basis: rescaling the whole basis first would cost a copy of
    // the model's colour basis at every check made.
    std::vector<Eigen::Index> rows;
    rows.reserve(3 * skin.size());
    for (const Eigen::Index v : skin)
        for (Eigen::Index c = 0; c < 3; ++c) rows.push_back(3 * v + c);
    skin_mean_ = model.albedo->mean(rows);
    skin_basis_ = model.albedo->basis(rows, Eigen::all) * model.albedo->eigenvalues.cwiseSqrt().asDiagonal();
}

SkinColourVerdict SkinColourCheck::check(std::span<const float> beta) const {
    Eigen::VectorXf colours = skin_mean_;
    const auto n = std::min<Eigen::Index>(static_cast<Eigen::Index>(beta.size()), skin_basis_.cols());
    if (n > 0) colours.noalias() += skin_basis_.leftCols(n) * Eigen::Map<const Eigen::VectorXf>(beta.data(), n);
    const Eigen::Index vertices = colours.size() / 3;
    const Eigen::Map<const Eigen::Matrix3Xf> points(colours.data(), 3, vertices);
    SkinColourVerdict v;
    int clamped = 0;
    for (Eigen::Index i = 0; i < vertices; ++i) {
        const Eigen::Vector3f c = points.col(i);
        if ((c.array() < 0.0f).any() || (c.array() > 1.0f).any()) ++clamped;
        v.mean += c.cwiseMax(0.0f).cwiseMin(1.0f).cast<double>();
    }
    v.mean /= static_cast<double>(vertices);
    v.clamped_share = static_cast<double>(clamped) / static_cast<double>(vertices);
    v.luminance = 0.2126 * v.mean.x() + 0.7152 * v.mean.y() + 0.0722 * v.mean.z();
    // A black mean (all channels clamped to 0) has no hue: its ratios are 0 and it is too dark.
    v.green_over_red = v.mean.x() > 0 ? v.mean.y() / v.mean.x() : 0.0;
    v.blue_over_green = v.mean.y() > 0 ? v.mean.z() / v.mean.y() : 0.0;
    const SkinColourLimits& l = limits_;
    if (v.luminance < l.min_luminance) v.flaws |= kSkinTooDark;
    if (v.luminance > l.max_luminance) v.flaws |= kSkinTooLight;
    if (v.green_over_red < l.min_green_over_red) v.flaws |= kSkinTooRed;
    if (v.green_over_red > l.max_green_over_red || v.blue_over_green > l.max_blue_over_green) v.flaws |= kSkinWrongHue;
    if (v.clamped_share > l.max_clamped_share) v.flaws |= kSkinClamped;
    return v;
}

AlbedoDraw draw_albedo(core::Rng& first, core::Rng& redraw, int count, double truncation, double scale, const SkinColourCheck* check,
                       int max_redraws) {
    const auto scaled = [&](core::Rng& rng) {
        std::vector<float> beta = sample_coefficients(rng, count, truncation);
        for (float& b : beta) b = static_cast<float>(b * scale);
        return beta;
    };
    AlbedoDraw draw;
    draw.beta = scaled(first);
    if (check == nullptr || check->check(draw.beta).plausible()) return draw;
    const std::vector<float> first_beta = draw.beta;
    while (draw.redraws < max_redraws) {
        ++draw.redraws;
        draw.beta = scaled(redraw);
        if (check->check(draw.beta).plausible()) return draw;
    }
    // Every redraw failed (a model whose draws are mostly implausible): move the first draw toward
    // the mean, whose colour the caller has checked, until it passes.
    for (int step = 9; step >= 0; --step) {
        draw.shrink = 0.1 * step;
        draw.beta = first_beta;
        for (float& b : draw.beta) b = static_cast<float>(b * draw.shrink);
        if (check->check(draw.beta).plausible()) break;
    }
    return draw;
}

}  // namespace facesynth::morph
