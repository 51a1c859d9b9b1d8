#include "morph/model.h"

#include "core/error.h"
#include "morph/regions.h"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace facesynth::morph {
namespace {

bool all_finite(const auto& matrix) { return matrix.size() == 0 || matrix.allFinite(); }

void check_pca(const PcaModel& pca, int num_vertices, const std::string& what, const std::string& context) {
    if (pca.mean.size() != 3 * static_cast<Eigen::Index>(num_vertices))
        throw core::Error(context + ": " + what + " mean has " + std::to_string(pca.mean.size()) +
                    " values, expected 3 x " + std::to_string(num_vertices));
    if (pca.basis.rows() != pca.mean.size())
        throw core::Error(context + ": " + what + " basis has " + std::to_string(pca.basis.rows()) + " rows, expected " +
                    std::to_string(pca.mean.size()));
    if (pca.eigenvalues.size() != pca.basis.cols())
        throw core::Error(context + ": " + what + " has " + std::to_string(pca.basis.cols()) + " basis vectors but " +
                    std::to_string(pca.eigenvalues.size()) + " eigenvalues");
    if (!all_finite(pca.mean) || !all_finite(pca.basis) || !all_finite(pca.eigenvalues))
        throw core::Error(context + ": " + what + " contains NaN or infinite values");
    if ((pca.eigenvalues.array() < 0).any()) throw core::Error(context + ": " + what + " has negative eigenvalues");
}

class Fnv1a {
public:
    void add(const void* data, std::size_t size) {
        const auto* bytes = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < size; ++i) hash_ = (hash_ ^ bytes[i]) * 1099511628211ull;
    }
    template <typename T>
    void add_value(const T& value) { add(&value, sizeof(T)); }
    void add_matrix(const auto& m) {
        add_value(static_cast<std::int64_t>(m.rows()));
        add_value(static_cast<std::int64_t>(m.cols()));
        add(m.data(), sizeof(float) * static_cast<std::size_t>(m.size()));
    }
    void add_pca(const PcaModel& p) { add_matrix(p.mean); add_matrix(p.basis); add_matrix(p.eigenvalues); }
    void add_string(const std::string& s) { add_value(s.size()); add(s.data(), s.size()); }
    [[nodiscard]] std::uint64_t value() const { return hash_; }

private:
    std::uint64_t hash_ = 14695981039346656037ull;
};

}  // namespace

Eigen::VectorXf PcaModel::draw(std::span<const float> coefficients) const {
    const auto k = std::min<Eigen::Index>(static_cast<Eigen::Index>(coefficients.size()), basis.cols());
    Eigen::VectorXf result = mean;
    if (k == 0) return result;
    const Eigen::Map<const Eigen::VectorXf> c(coefficients.data(), k);
    const Eigen::VectorXf scaled = c.cwiseProduct(eigenvalues.head(k).cwiseSqrt());
    result.noalias() += basis.leftCols(k) * scaled;
    return result;
}

Eigen::MatrixXf PcaModel::rescaled_basis() const {
    return basis * eigenvalues.cwiseSqrt().asDiagonal();
}

Eigen::Vector3f SurfacePoint::position(const Eigen::Matrix3Xf& v) const {
    return weights[0] * v.col(vertices[0]) + weights[1] * v.col(vertices[1]) + weights[2] * v.col(vertices[2]);
}

int MorphableModel::num_expression_components() const {
    if (!expression) return 0;
    if (const auto* pca = std::get_if<PcaModel>(&*expression)) return pca->num_components();
    return static_cast<int>(std::get<std::vector<Blendshape>>(*expression).size());
}

Eigen::VectorXf MorphableModel::expression_offsets(std::span<const float> psi) const {
    Eigen::VectorXf offsets = Eigen::VectorXf::Zero(shape.mean.size());
    if (!expression) return offsets;
    // An expression PCA's mean is itself an offset from the neutral shape (BFM 2017), so it is
    // always added; blendshapes add nothing at zero weight.
    if (const auto* pca = std::get_if<PcaModel>(&*expression)) return pca->draw(psi);
    if (psi.empty()) return offsets;
    const auto& shapes = std::get<std::vector<Blendshape>>(*expression);
    const std::size_t n = std::min(psi.size(), shapes.size());
    for (std::size_t i = 0; i < n; ++i)
        if (psi[i] != 0.0f) offsets += psi[i] * shapes[i].offsets;
    return offsets;
}

Eigen::Matrix3Xf MorphableModel::shape_instance(std::span<const float> alpha, std::span<const float> psi) const {
    Eigen::VectorXf stacked = shape.draw(alpha);
    if (expression) stacked += expression_offsets(psi);
    return as_points(stacked);
}

Eigen::Matrix3Xf MorphableModel::albedo_instance(std::span<const float> beta) const {
    if (!albedo || albedo->empty()) return Eigen::Matrix3Xf::Constant(3, num_vertices(), 0.6f);
    Eigen::VectorXf stacked = albedo->draw(beta).cwiseMax(0.0f).cwiseMin(1.0f);
    return as_points(stacked);
}

Mesh MorphableModel::instance(std::span<const float> alpha, std::span<const float> psi,
                              std::span<const float> beta) const {
    Mesh mesh;
    mesh.vertices = shape_instance(alpha, psi);
    mesh.triangles = triangles;
    mesh.colours = albedo_instance(beta);
    mesh.uv = uv;
    return mesh;
}

Eigen::Matrix3Xf MorphableModel::landmark_positions(const Eigen::Matrix3Xf& vertices) const {
    Eigen::Matrix3Xf result(3, static_cast<Eigen::Index>(landmarks.size()));
    for (std::size_t i = 0; i < landmarks.size(); ++i) result.col(static_cast<Eigen::Index>(i)) = landmarks[i].position(vertices);
    return result;
}

void MorphableModel::validate(const std::string& context) const {
    const int v = num_vertices();
    if (v <= 0) throw core::Error(context + ": model has no vertices");
    check_pca(shape, v, "shape model", context);
    if (albedo && !albedo->empty()) check_pca(*albedo, v, "colour model", context);
    if (expression) {
        if (const auto* pca = std::get_if<PcaModel>(&*expression)) {
            check_pca(*pca, v, "expression model", context);
        } else {
            for (const auto& b : std::get<std::vector<Blendshape>>(*expression)) {
                if (b.offsets.size() != 3 * static_cast<Eigen::Index>(v))
                    throw core::Error(context + ": blendshape '" + b.name + "' has " + std::to_string(b.offsets.size()) +
                                " values, expected 3 x " + std::to_string(v));
                if (!all_finite(b.offsets)) throw core::Error(context + ": blendshape '" + b.name + "' contains NaN");
            }
        }
    }
    for (std::size_t i = 0; i < triangles.size(); ++i)
        for (int id : triangles[i])
            if (id < 0 || id >= v)
                throw core::Error(context + ": triangle " + std::to_string(i) + " refers to vertex " + std::to_string(id) +
                            " of " + std::to_string(v));
    if (uv.cols() != 0 && uv.cols() != v)
        throw core::Error(context + ": " + std::to_string(uv.cols()) + " texture coordinates for " + std::to_string(v) +
                    " vertices");
    if (!all_finite(uv)) throw core::Error(context + ": texture coordinates contain NaN");
    for (std::size_t i = 0; i < landmarks.size(); ++i) {
        for (int id : landmarks[i].vertices)
            if (id < 0 || id >= v)
                throw core::Error(context + ": landmark " + std::to_string(i + 1) + " refers to vertex " +
                            std::to_string(id) + " of " + std::to_string(v));
        for (float w : landmarks[i].weights)
            if (!std::isfinite(w)) throw core::Error(context + ": landmark " + std::to_string(i + 1) + " has a NaN weight");
    }
    for (const auto* chain : {&contour.right, &contour.left})
        for (int id : *chain)
            if (id < 0 || id >= v) throw core::Error(context + ": contour vertex " + std::to_string(id) + " out of range");
    if (!symmetry.empty() && static_cast<int>(symmetry.size()) != v)
        throw core::Error(context + ": symmetry map has " + std::to_string(symmetry.size()) + " entries for " +
                    std::to_string(v) + " vertices");
    for (int id : symmetry)
        if (id < -1 || id >= v) throw core::Error(context + ": symmetry map refers to vertex " + std::to_string(id));
    if (!vertex_labels.empty() && static_cast<int>(vertex_labels.size()) != v)
        throw core::Error(context + ": " + std::to_string(vertex_labels.size()) + " vertex labels for " + std::to_string(v) +
                    " vertices");
    for (std::size_t i = 0; i < vertex_labels.size(); ++i)
        if (vertex_labels[i] >= kNumRegions)
            throw core::Error(context + ": vertex " + std::to_string(i) + " has region label " + std::to_string(vertex_labels[i]) +
                        " (ids are 0-" + std::to_string(kNumRegions - 1) + ")");
}

std::string MorphableModel::checksum() const {
    Fnv1a h;
    h.add_string(name);
    h.add_pca(shape);
    h.add_value(static_cast<int>(expression.has_value()));
    if (expression) {
        if (const auto* pca = std::get_if<PcaModel>(&*expression)) {
            h.add_value(0);
            h.add_pca(*pca);
        } else {
            h.add_value(1);
            for (const auto& b : std::get<std::vector<Blendshape>>(*expression)) {
                h.add_string(b.name);
                h.add_matrix(b.offsets);
            }
        }
    }
    h.add_value(static_cast<int>(albedo.has_value()));
    if (albedo) h.add_pca(*albedo);
    h.add_value(triangles.size());
    if (!triangles.empty()) h.add(triangles.data(), triangles.size() * sizeof(Triangle));
    h.add_matrix(uv);
    h.add_value(landmarks.size());
    for (const auto& l : landmarks) { h.add_value(l.vertices); h.add_value(l.weights); }
    for (const auto* chain : {&contour.right, &contour.left}) {
        h.add_value(chain->size());
        if (!chain->empty()) h.add(chain->data(), chain->size() * sizeof(int));
    }
    h.add_value(symmetry.size());
    if (!symmetry.empty()) h.add(symmetry.data(), symmetry.size() * sizeof(int));
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.value()));
    return hex;
}

}  // namespace facesynth::morph
