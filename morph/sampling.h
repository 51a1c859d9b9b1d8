#pragma once
// Coefficients drawn from a model's Gaussian prior (σ units), truncated at a number of σ.
#include "core/random.h"
#include "morph/model.h"

#include <cstdint>
#include <vector>

namespace facesynth::morph {

// `count` independent N(0,1) draws, each restricted to [-truncation, truncation]
// (truncation <= 0 means no truncation).
[[nodiscard]] std::vector<float> sample_coefficients(core::Rng& rng, int count, double truncation);

// A random face of `model` as `facesynth render --seed` draws it: identity and colour coefficients from
// (seed, 0)'s identity and albedo streams, truncated at ±truncation σ.
struct FaceCoefficients {
    std::vector<float> alpha;  // identity
    std::vector<float> beta;   // colour (empty for a model without a colour model)
};
[[nodiscard]] FaceCoefficients sample_face(const MorphableModel& model, std::uint64_t seed, double truncation);

}  // namespace facesynth::morph
