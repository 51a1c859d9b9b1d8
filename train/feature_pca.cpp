#include "train/feature_pca.h"

#include "core/error.h"
#include "core/random.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <string>

namespace facesynth::train {
namespace {

constexpr int kOversampling = 16;
constexpr int kPowerIterations = 3;
constexpr std::uint64_t kPcaStream = 0x5043'4100;  // "PCA"

Eigen::MatrixXd orthonormal_basis(const Eigen::MatrixXd& columns) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(columns);
    return qr.householderQ() * Eigen::MatrixXd::Identity(columns.rows(), columns.cols());
}

// Eigenpairs of a small symmetric matrix, largest first, the first `count` kept.
LeadingEigenpairs largest_first(const Eigen::MatrixXd& symmetric, int count) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(symmetric);
    if (solver.info() != Eigen::Success) throw core::Error("feature PCA: the eigensolver did not converge");
    return {solver.eigenvalues().tail(count).reverse(), solver.eigenvectors().rightCols(count).rowwise().reverse()};
}

}  // namespace

LeadingEigenpairs leading_eigenpairs(const Eigen::MatrixXd& symmetric, int count, std::uint64_t seed) {
    const Eigen::Index n = symmetric.rows();
    if (count < 1 || count > n)
        throw core::Error("feature PCA: " + std::to_string(count) + " components requested of a " + std::to_string(n) +
                    "-dimensional space");
    const Eigen::Index width = count + kOversampling;
    if (4 * width > n) return largest_first(symmetric, count);
    core::Rng rng(seed, 0, kPcaStream);
    Eigen::MatrixXd start(n, width);
    for (Eigen::Index j = 0; j < width; ++j)
        for (Eigen::Index i = 0; i < n; ++i) start(i, j) = rng.normal();
    Eigen::MatrixXd basis = orthonormal_basis(symmetric * start);
    for (int i = 0; i < kPowerIterations; ++i) basis = orthonormal_basis(symmetric * basis);
    const Eigen::MatrixXd projected = basis.transpose() * symmetric * basis;
    LeadingEigenpairs small = largest_first(0.5 * (projected + projected.transpose()), count);
    return {std::move(small.values), basis * small.vectors};
}

Eigen::MatrixXd projected_ridge(const LeadingEigenpairs& eigen, const Eigen::MatrixXd& cross, double lambda) {
    const Eigen::VectorXd shrink = (eigen.values.array() + lambda).inverse();
    return eigen.vectors * (shrink.asDiagonal() * (eigen.vectors.transpose() * cross));
}

}  // namespace facesynth::train
