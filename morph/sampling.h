#pragma once
// Coefficients drawn from a model's Gaussian prior (σ units), truncated at a number of σ.
#include "core/random.h"

#include <vector>

namespace facesynth::morph {

// `count` independent N(0,1) draws, each restricted to [-truncation, truncation]
// (truncation <= 0 means no truncation).
[[nodiscard]] std::vector<float> sample_coefficients(core::Rng& rng, int count, double truncation);

}  // namespace facesynth::morph
