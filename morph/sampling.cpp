#include "morph/sampling.h"

namespace facesynth::morph {

std::vector<float> sample_coefficients(core::Rng& rng, int count, double truncation) {
    std::vector<float> coefficients(static_cast<std::size_t>(std::max(count, 0)));
    for (auto& c : coefficients)
        c = static_cast<float>(truncation > 0 ? rng.truncated_normal(truncation) : rng.normal());
    return coefficients;
}

FaceCoefficients sample_face(const MorphableModel& model, std::uint64_t seed, double truncation) {
    core::Rng identity = core::make_rng(seed, 0, core::RandomStream::kIdentity);
    core::Rng albedo = core::make_rng(seed, 0, core::RandomStream::kAlbedo);
    return {sample_coefficients(identity, model.num_shape_components(), truncation),
            sample_coefficients(albedo, model.num_albedo_components(), truncation)};
}

}  // namespace facesynth::morph
