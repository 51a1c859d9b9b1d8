#include "core/random.h"

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
