#pragma once
// The model's linear part restricted to a set of surface points (used by the linear fit and the
// Ceres refinement): X_i = m_i + V_i α + E_i ψ with V and E scaled to σ units (for blendshapes E
// holds the raw offsets). Library-internal helper, not part of the documented interface.
#include "morph/model.h"

#include <Eigen/Core>

#include <variant>
#include <vector>

namespace facesynth::fit {

// True when a surface point has a definition (models mark undefined landmarks with zero weights).
[[nodiscard]] inline bool defined(const morph::SurfacePoint& p) { return p.weights[0] + p.weights[1] + p.weights[2] != 0.0f; }

struct LandmarkRows {
    Eigen::Matrix3Xd mean;    // 3 x L (includes an expression PCA's mean offset)
    Eigen::MatrixXd identity; // 3L x K
    Eigen::MatrixXd expression;  // 3L x E
};

class LandmarkBasis {
public:
    LandmarkBasis(const morph::MorphableModel& model, int k)
        : model_(model), k_(k), identity_sd_(model.shape.eigenvalues.head(k).cwiseSqrt()) {
        if (model.expression) {
            if (const auto* pca = std::get_if<morph::PcaModel>(&*model.expression)) {
                expression_pca_ = pca;
                e_ = pca->num_components();
                expression_sd_ = pca->eigenvalues.cwiseSqrt();
            } else {
                blendshapes_ = &std::get<std::vector<morph::Blendshape>>(*model.expression);
                e_ = static_cast<int>(blendshapes_->size());
            }
        }
    }
    int k() const { return k_; }
    int e() const { return e_; }
    bool has_blendshapes() const { return blendshapes_ != nullptr; }

    void resize(Eigen::Index points) {
        rows_.mean.resize(3, points);
        rows_.identity.resize(3 * points, k_);
        rows_.expression.resize(3 * points, e_);
    }
    void set_point(Eigen::Index i, const morph::SurfacePoint& p) {
        rows_.mean.col(i).setZero();
        rows_.identity.middleRows(3 * i, 3).setZero();
        rows_.expression.middleRows(3 * i, 3).setZero();
        for (int c = 0; c < 3; ++c) {
            const double w = p.weights[static_cast<std::size_t>(c)];
            if (w == 0) continue;
            const int v = p.vertices[static_cast<std::size_t>(c)];
            rows_.mean.col(i) += w * model_.shape.mean.segment<3>(3 * v).cast<double>();
            rows_.identity.middleRows(3 * i, 3) +=
                w * (model_.shape.basis.block(3 * v, 0, 3, k_) * identity_sd_.asDiagonal())
                        .cast<double>();
            if (expression_pca_) {
                rows_.mean.col(i) += w * expression_pca_->mean.segment<3>(3 * v).cast<double>();
                rows_.expression.middleRows(3 * i, 3) +=
                    w * (expression_pca_->basis.block(3 * v, 0, 3, e_) * expression_sd_.asDiagonal())
                            .cast<double>();
            } else if (blendshapes_) {
                for (int b = 0; b < e_; ++b)
                    rows_.expression.block<3, 1>(3 * i, b) += w * (*blendshapes_)[static_cast<std::size_t>(b)].offsets.segment<3>(3 * v).cast<double>();
            }
        }
    }
    // Point i takes point j of `from` (a basis of the same model with at least k() components).
    void copy_point(Eigen::Index i, const LandmarkBasis& from, Eigen::Index j) {
        rows_.mean.col(i) = from.rows_.mean.col(j);
        rows_.identity.middleRows(3 * i, 3) = from.rows_.identity.block(3 * j, 0, 3, k_);
        rows_.expression.middleRows(3 * i, 3) = from.rows_.expression.middleRows(3 * j, 3);
    }
    const LandmarkRows& rows() const { return rows_; }

    Eigen::Matrix3Xd positions(const Eigen::VectorXd& alpha, const Eigen::VectorXd& psi) const {
        Eigen::VectorXd stacked = rows_.identity * alpha;
        if (e_ > 0) stacked += rows_.expression * psi;
        return rows_.mean + Eigen::Map<const Eigen::Matrix3Xd>(stacked.data(), 3, rows_.mean.cols());
    }

private:
    const morph::MorphableModel& model_;
    int k_;
    int e_ = 0;
    const morph::PcaModel* expression_pca_ = nullptr;
    const std::vector<morph::Blendshape>* blendshapes_ = nullptr;
    Eigen::VectorXf identity_sd_, expression_sd_;  // sqrt(eigenvalues): σ-unit scaling
    LandmarkRows rows_;
};

}  // namespace facesynth::fit
