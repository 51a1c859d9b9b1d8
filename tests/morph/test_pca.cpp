#include "morph/pca.h"
#include "core/error.h"
#include "core/random.h"

#include <gtest/gtest.h>

using namespace facesynth;

TEST(Pca, RecoversKnownSubspaceAndVariances) {
    // Samples = mean + 3 orthonormal directions with standard deviations 5, 2, 1.
    const int d = 60, n = 600;
    Eigen::MatrixXf directions = Eigen::MatrixXf::Zero(d, 3);
    directions(0, 0) = 1;
    directions(7, 1) = 1;
    directions(20, 2) = 1;
    const Eigen::Vector3f sigma(5, 2, 1);
    core::Rng rng(3, 0);
    std::vector<Eigen::VectorXf> samples;
    for (int i = 0; i < n; ++i) {
        Eigen::VectorXf x = Eigen::VectorXf::Constant(d, 10.0f);
        for (int c = 0; c < 3; ++c) x += directions.col(c) * sigma[c] * static_cast<float>(rng.normal());
        samples.push_back(x);
    }
    const morph::PcaModel pca = morph::build_pca(samples);
    ASSERT_EQ(pca.num_components(), 3);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pca.eigenvalues[c], sigma[c] * sigma[c], 0.2f * sigma[c] * sigma[c]);
        EXPECT_NEAR(std::abs(pca.basis.col(c).dot(directions.col(c))), 1.0f, 1e-2f);
    }
    EXPECT_NEAR(pca.mean[5], 10.0f, 0.2f);
}

TEST(Pca, RespectsComponentLimitAndVarianceShare) {
    core::Rng rng(4, 0);
    std::vector<Eigen::VectorXf> samples;
    for (int i = 0; i < 30; ++i) {
        Eigen::VectorXf x(12);
        for (int k = 0; k < 12; ++k) x[k] = static_cast<float>(rng.normal() * (12 - k));
        samples.push_back(x);
    }
    EXPECT_EQ(morph::build_pca(samples, {.max_components = 4}).num_components(), 4);
    EXPECT_LT(morph::build_pca(samples, {.variance_fraction = 0.5}).num_components(), 12);
}

TEST(Pca, RejectsBadInput) {
    EXPECT_THROW((void)morph::build_pca({}), core::Error);
    EXPECT_THROW((void)morph::build_pca({Eigen::VectorXf::Zero(3)}), core::Error);
    EXPECT_THROW((void)morph::build_pca({Eigen::VectorXf::Zero(3), Eigen::VectorXf::Zero(4)}), core::Error);
    EXPECT_THROW((void)morph::build_pca({Eigen::VectorXf::Zero(3), Eigen::VectorXf::Zero(3)}), core::Error);
    Eigen::VectorXf nan = Eigen::VectorXf::Zero(3);
    nan[1] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW((void)morph::build_pca({Eigen::VectorXf::Ones(3), nan}), core::Error);
}
