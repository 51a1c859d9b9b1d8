#include "core/random.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace facesynth;

TEST(Random, SameSeedAndIndexGiveSameSequence) {
    core::Rng a(42, 17, 3), b(42, 17, 3);
    for (int i = 0; i < 100; ++i) EXPECT_EQ(a.next_u64(), b.next_u64());
}

TEST(Random, DifferentIndicesAndStreamsDiffer) {
    EXPECT_NE(core::Rng(42, 17, 3).next_u64(), core::Rng(42, 18, 3).next_u64());
    EXPECT_NE(core::Rng(42, 17, 3).next_u64(), core::Rng(42, 17, 4).next_u64());
    EXPECT_NE(core::Rng(42, 17, 3).next_u64(), core::Rng(43, 17, 3).next_u64());
}

TEST(Random, NormalHasUnitMoments) {
    core::Rng rng(1, 2);
    double sum = 0, sum_sq = 0;
    constexpr int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double x = rng.normal();
        sum += x;
        sum_sq += x * x;
    }
    EXPECT_NEAR(sum / n, 0.0, 0.01);
    EXPECT_NEAR(sum_sq / n, 1.0, 0.01);
}

TEST(Random, TruncatedCoefficientsStayInRange) {
    core::Rng rng(5, 6);
    const auto c = morph::sample_coefficients(rng, 10000, 2.0);
    ASSERT_EQ(c.size(), 10000u);
    for (float x : c) EXPECT_LE(std::abs(x), 2.0f);
}

TEST(Random, SamplingIsReproducibleFromSeedAndIndex) {
    core::Rng a = core::make_rng(9, 123, core::RandomStream::kIdentity);
    core::Rng b = core::make_rng(9, 123, core::RandomStream::kIdentity);
    EXPECT_EQ(morph::sample_coefficients(a, 63, 3.0), morph::sample_coefficients(b, 63, 3.0));
}
