// Coefficient sampling from (seed, index): morph/sampling.h on core::Rng.
#include "core/random.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace facesynth;

TEST(Sampling, TruncatedCoefficientsStayInRange) {
    core::Rng rng(5, 6);
    const auto c = morph::sample_coefficients(rng, 10000, 2.0);
    ASSERT_EQ(c.size(), 10000u);
    for (float x : c) EXPECT_LE(std::abs(x), 2.0f);
}

TEST(Sampling, SamplingIsReproducibleFromSeedAndIndex) {
    core::Rng a = core::make_rng(9, 123, core::RandomStream::kIdentity);
    core::Rng b = core::make_rng(9, 123, core::RandomStream::kIdentity);
    EXPECT_EQ(morph::sample_coefficients(a, 63, 3.0), morph::sample_coefficients(b, 63, 3.0));
}
