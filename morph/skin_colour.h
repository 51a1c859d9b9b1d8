#pragma once
// Is a colour-model draw a plausible skin? The mean albedo of the model's skin vertices (region
// label kSkin) is compared with the range of real skin, and the share of skin vertices that
// albedo_instance's [0, 1] clamp cuts is counted. docs/builtin-model.md ("Implausible colour draws")
// gives the limits and why; `facesynth model albedo-check` measures a model with it and synth's
// albedo.reject_implausible redraws what it rejects.
#include "morph/model.h"
#include "core/random.h"

#include <Eigen/Core>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace facesynth::morph {

// Limits on the mean skin albedo (linear RGB; luminance Y = 0.2126 R + 0.7152 G + 0.0722 B).
struct SkinColourLimits {
    double min_luminance = 0.015;      // darker is black paint (the darkest real skin is about 0.018)
    double max_luminance = 0.90;       // lighter is white paint (the lightest real skin is about 0.86)
    double min_green_over_red = 0.30;  // redder is red paint (real skin: 0.45-0.92)
    double max_green_over_red = 1.0;   // skin reflects more red than green
    double max_blue_over_green = 1.0;  // and more green than blue
    double max_clamped_share = 0.10;   // skin vertices with a channel outside [0, 1] before the clamp
};

// Why a draw was rejected; a draw may have several reasons.
enum SkinColourFlaw : std::uint8_t {
    kSkinTooDark = 1,
    kSkinTooLight = 2,
    kSkinTooRed = 4,
    kSkinWrongHue = 8,   // green above red or blue above green
    kSkinClamped = 16,   // more than max_clamped_share of the skin clamped
};

struct SkinColourVerdict {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();  // linear RGB of the skin after the clamp
    double luminance = 0;
    double green_over_red = 0;
    double blue_over_green = 0;
    double clamped_share = 0;
    std::uint8_t flaws = 0;  // SkinColourFlaw bits
    [[nodiscard]] bool plausible() const { return flaws == 0; }
};

// "too_dark", "too_light", "too_red", "wrong_hue", "clamped" (the flaws set, comma-separated).
[[nodiscard]] std::string flaw_names(std::uint8_t flaws);

class SkinColourCheck {
public:
    // Throws core::Error naming the model when it has no colour model or no skin vertices
    // (region labels of its own, or derived from its 68 landmarks).
    explicit SkinColourCheck(const MorphableModel& model, const SkinColourLimits& limits = {});

    // The verdict on the albedo of colour coefficients `beta` (σ units, as albedo_instance takes).
    [[nodiscard]] SkinColourVerdict check(std::span<const float> beta) const;
    [[nodiscard]] int skin_vertices() const { return static_cast<int>(skin_mean_.size() / 3); }
    [[nodiscard]] const SkinColourLimits& limits() const { return limits_; }

private:
    SkinColourLimits limits_;
    Eigen::VectorXf skin_mean_;   // the colour model's mean, skin vertices only (3S)
    Eigen::MatrixXf skin_basis_;  // its basis scaled by the standard deviations, skin rows only (3S x K)
};

// Colour coefficients as synth draws them, with the redraws of albedo.reject_implausible.
struct AlbedoDraw {
    std::vector<float> beta;
    int redraws = 0;      // implausible draws replaced (0: the first draw was kept)
    double shrink = 1.0;  // < 1: no redraw was plausible and the first draw was scaled toward the mean
};

// The first draw comes from `first` (N(0,1) truncated at ±truncation, times scale), exactly as
// without a check. While `check` rejects the draw, up to max_redraws further draws come from
// `redraw`; if none passes, the first draw is scaled by 0.9, 0.8, ..., 0 until it passes (the mean
// must pass: SkinColourCheck::check({}) is tested by the caller). Without a check: the first draw.
[[nodiscard]] AlbedoDraw draw_albedo(core::Rng& first, core::Rng& redraw, int count, double truncation, double scale,
                                     const SkinColourCheck* check, int max_redraws);

}  // namespace facesynth::morph
