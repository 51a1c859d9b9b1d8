#pragma once
// Optional PCA of the SDM features (docs/train.md, "Feature PCA"): a stage regresses on the K leading
// principal components of its centred training features, and the projection is folded into the
// stage's weights (W = V · R), so that detection and the .sdm format are unchanged.
#include <Eigen/Core>

#include <cstdint>

namespace facesynth::train {

// Leading eigenpairs of a symmetric positive semi-definite matrix, largest eigenvalue first.
struct LeadingEigenpairs {
    Eigen::VectorXd values;   // K
    Eigen::MatrixXd vectors;  // n x K, orthonormal columns with vectorsᵀ · matrix · vectors = diag(values)
};

// The `count` leading eigenpairs of `symmetric` (n x n, 1 <= count <= n). Exact (full eigensolver) when
// count is more than a quarter of n; otherwise a randomised subspace iteration (Gaussian start seeded by
// `seed`, power iterations, Rayleigh-Ritz), whose vectors are orthonormal and diagonalise the matrix
// exactly on their span, so that the ridge regression below is exact on that span.
[[nodiscard]] LeadingEigenpairs leading_eigenpairs(const Eigen::MatrixXd& symmetric, int count, std::uint64_t seed);

// Ridge regression restricted to the span of `eigen.vectors`, folded back: with S = AᵀA = V Λ Vᵀ + (rest),
// returns V (Λ + λI)⁻¹ Vᵀ · cross. Primal form (S the centred feature scatter, cross = A_cᵀY_c): the
// weights W (D x outputs) of ridge on the projected features Z = A_c V, folded (W = V R). Dual form (S the
// centred Gram matrix A_c A_cᵀ, cross = Y_c): the dual coefficients α of the same regression, W = A_cᵀα.
[[nodiscard]] Eigen::MatrixXd projected_ridge(const LeadingEigenpairs& eigen, const Eigen::MatrixXd& cross, double lambda);

}  // namespace facesynth::train
