#include "morph/model.h"
#include "core/error.h"

#include "common/toy_model.h"

#include <gtest/gtest.h>

using namespace facesynth;

TEST(Model, ToyModelIsValidAndOrthonormal) {
    const morph::MorphableModel m = testkit::make_toy_model();
    EXPECT_NO_THROW(m.validate("toy"));
    const Eigen::MatrixXf gram = m.shape.basis.transpose() * m.shape.basis;
    EXPECT_LT((gram - Eigen::MatrixXf::Identity(gram.rows(), gram.cols())).cwiseAbs().maxCoeff(), 1e-4f);
    EXPECT_EQ(m.landmarks.size(), 68u);
}

TEST(Model, DrawScalesByStandardDeviation) {
    const morph::MorphableModel m = testkit::make_toy_model();
    std::vector<float> alpha(static_cast<std::size_t>(m.num_shape_components()), 0.0f);
    alpha[0] = 2.0f;
    const Eigen::VectorXf x = m.shape.draw(alpha);
    const float projected = m.shape.basis.col(0).dot(x - m.shape.mean);
    EXPECT_NEAR(projected, 2.0f * std::sqrt(m.shape.eigenvalues[0]), 1e-3f);
}

TEST(Model, NormalsPointOutward) {
    const morph::MorphableModel m = testkit::make_toy_model();
    const Eigen::Matrix3Xf v = m.shape_instance({});
    const Eigen::Matrix3Xf n = morph::vertex_normals(v, m.triangles);
    int outward = 0;
    for (Eigen::Index i = 0; i < v.cols(); ++i) outward += n.col(i).dot(v.col(i)) > 0;
    EXPECT_GT(outward, 0.98 * static_cast<double>(v.cols()));
}

TEST(Model, ValidateRejectsBadIndicesAndNaN) {
    morph::MorphableModel m = testkit::make_toy_model();
    m.triangles[3][1] = m.num_vertices();
    EXPECT_THROW(m.validate("bad"), core::Error);
    m = testkit::make_toy_model();
    m.shape.basis(5, 2) = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(m.validate("nan"), core::Error);
}

TEST(Model, ChecksumChangesWithContent) {
    morph::MorphableModel m = testkit::make_toy_model();
    const std::string a = m.checksum();
    EXPECT_EQ(a, testkit::make_toy_model().checksum());
    m.shape.mean[0] += 1.0f;
    EXPECT_NE(a, m.checksum());
}
