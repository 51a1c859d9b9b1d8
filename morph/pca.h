#pragma once
// PCA over meshes in dense correspondence: the code behind `facesynth model build` and the built-in
// model. Each sample is a stacked 3V vector (x0 y0 z0 x1 ...), all with the same V.
#include "morph/model.h"

#include <vector>

namespace facesynth::morph {

struct PcaBuildOptions {
    int max_components = 0;           // 0: as many as the data supports (N - 1)
    double variance_fraction = 1.0;   // keep the fewest components explaining this share of variance
};

// Mean, orthonormal basis (columns sorted by decreasing variance) and eigenvalues = sample variances
// (1 / (N - 1) normalisation) along each basis vector. Needs at least 2 samples of equal size.
// Throws core::Error on empty, mismatched or non-finite input.
[[nodiscard]] PcaModel build_pca(const std::vector<Eigen::VectorXf>& samples, const PcaBuildOptions& options = {});

}  // namespace facesynth::morph
