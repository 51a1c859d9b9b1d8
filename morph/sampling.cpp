#include "morph/sampling.h"

namespace facesynth::morph {

std::vector<float> sample_coefficients(core::Rng& rng, int count, double truncation) {
    std::vector<float> coefficients(static_cast<std::size_t>(std::max(count, 0)));
    for (auto& c : coefficients)
        c = static_cast<float>(truncation > 0 ? rng.truncated_normal(truncation) : rng.normal());
    return coefficients;
}

}  // namespace facesynth::morph
