#include "morph/random.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace facesynth;

TEST(Random, SameSeedAndIndexGiveSameSequence) {
    Rng a(42, 17, 3), b(42, 17, 3);
    for (int i = 0; i < 100; ++i) EXPECT_EQ(a.next_u64(), b.next_u64());
}

TEST(Random, DifferentIndicesAndStreamsDiffer) {
    EXPECT_NE(Rng(42, 17, 3).next_u64(), Rng(42, 18, 3).next_u64());
    EXPECT_NE(Rng(42, 17, 3).next_u64(), Rng(42, 17, 4).next_u64());
    EXPECT_NE(Rng(42, 17, 3).next_u64(), Rng(43, 17, 3).next_u64());
}

TEST(Random, NormalHasUnitMoments) {
    Rng rng(1, 2);
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
    Rng rng(5, 6);
    const auto c = sample_coefficients(rng, 10000, 2.0);
    ASSERT_EQ(c.size(), 10000u);
    for (float x : c) EXPECT_LE(std::abs(x), 2.0f);
}

TEST(Random, SamplingIsReproducibleFromSeedAndIndex) {
    Rng a = make_rng(9, 123, RandomStream::kIdentity);
    Rng b = make_rng(9, 123, RandomStream::kIdentity);
    EXPECT_EQ(sample_coefficients(a, 63, 3.0), sample_coefficients(b, 63, 3.0));
}
