#include "morph/pca.h"

#include "core/error.h"

#include <Eigen/Eigenvalues>

namespace facesynth::morph {

PcaModel build_pca(const std::vector<Eigen::VectorXf>& samples, const PcaBuildOptions& options) {
    const auto n = static_cast<Eigen::Index>(samples.size());
    if (n < 2) throw core::Error("PCA needs at least 2 samples, got " + std::to_string(n));
    const Eigen::Index d = samples[0].size();
    if (d == 0) throw core::Error("PCA samples are empty");
    Eigen::MatrixXd data(d, n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const auto& s = samples[static_cast<std::size_t>(i)];
        if (s.size() != d)
            throw core::Error("PCA sample " + std::to_string(i) + " has " + std::to_string(s.size()) + " values, sample 0 has " +
                        std::to_string(d));
        if (!s.allFinite()) throw core::Error("PCA sample " + std::to_string(i) + " contains NaN or infinite values");
        data.col(i) = s.cast<double>();
    }
    const Eigen::VectorXd mean = data.rowwise().mean();
    data.colwise() -= mean;

    // With few samples of many dimensions, diagonalise the N x N Gram matrix instead of the D x D
    // covariance: if G v = λ v then X v / sqrt(λ) is a unit eigenvector of X Xᵀ with eigenvalue λ.
    const Eigen::MatrixXd gram = data.transpose() * data;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(gram);
    if (solver.info() != Eigen::Success) throw core::Error("PCA eigen-decomposition failed");
    const Eigen::VectorXd lambda = solver.eigenvalues().reverse();  // descending
    const Eigen::MatrixXd vectors = solver.eigenvectors().rowwise().reverse();

    const double total = lambda.cwiseMax(0.0).sum();
    const double tolerance = std::max(1e-12, 1e-10 * (lambda.size() ? lambda[0] : 0.0));
    Eigen::Index keep = 0;
    double explained = 0.0;
    for (Eigen::Index i = 0; i < std::min(n - 1, lambda.size()); ++i) {
        if (lambda[i] <= tolerance) break;
        if (options.max_components > 0 && keep >= options.max_components) break;
        if (options.variance_fraction < 1.0 && total > 0 && explained / total >= options.variance_fraction) break;
        explained += lambda[i];
        ++keep;
    }
    if (keep == 0) throw core::Error("PCA: the samples do not vary");

    PcaModel pca;
    pca.mean = mean.cast<float>();
    pca.basis.resize(d, keep);
    pca.eigenvalues.resize(keep);
    for (Eigen::Index i = 0; i < keep; ++i) {
        pca.basis.col(i) = (data * vectors.col(i) / std::sqrt(lambda[i])).cast<float>();
        pca.eigenvalues[i] = static_cast<float>(lambda[i] / static_cast<double>(n - 1));
    }
    return pca;
}

}  // namespace facesynth::morph
