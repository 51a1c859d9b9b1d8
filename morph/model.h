#pragma once
// The morphable model: shape PCA, optional expression model and albedo PCA, topology, UVs,
// landmark definitions, jaw contour chains and symmetry. Instances: shape(alpha, psi), albedo(beta).
//
// Coefficients are in units of standard deviations: x = mean + basis · diag(sqrt(eigenvalues)) · alpha.
#include "morph/mesh.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace facesynth::morph {

// A PCA model over stacked 3-vectors (x0 y0 z0 x1 y1 z1 ...).
struct PcaModel {
    Eigen::VectorXf mean;         // 3V
    Eigen::MatrixXf basis;        // 3V x K, orthonormal columns
    Eigen::VectorXf eigenvalues;  // K, variances

    [[nodiscard]] int num_components() const { return static_cast<int>(basis.cols()); }
    [[nodiscard]] int num_vertices() const { return static_cast<int>(mean.size() / 3); }
    [[nodiscard]] bool empty() const { return mean.size() == 0; }
    // mean + basis · (sqrt(eigenvalues) ∘ coefficients); fewer coefficients than K use the first ones.
    [[nodiscard]] Eigen::VectorXf draw(std::span<const float> coefficients) const;
    // The basis with column i scaled by sqrt(eigenvalue i): the map from σ-unit coefficients to offsets.
    [[nodiscard]] Eigen::MatrixXf rescaled_basis() const;
};

struct Blendshape {
    std::string name;
    Eigen::VectorXf offsets;  // 3V, added to the shape with weight psi
};

// Expressions are either a PCA model (coefficients in σ units) or named blendshapes (weights,
// typically in [0, 1]).
using ExpressionModel = std::variant<PcaModel, std::vector<Blendshape>>;

// A point on the surface: a weighted sum of up to three vertices. A vertex landmark is
// {{v, v, v}, {1, 0, 0}}; a barycentric point uses a triangle's corners.
struct SurfacePoint {
    std::array<int, 3> vertices{};
    std::array<float, 3> weights{1.0f, 0.0f, 0.0f};

    static SurfacePoint at_vertex(int v) { return {{v, v, v}, {1.0f, 0.0f, 0.0f}}; }
    [[nodiscard]] Eigen::Vector3f position(const Eigen::Matrix3Xf& vertices) const;
};

// Vertex chains along the jaw outline used to place contour landmarks, from eyebrow height down
// toward the chin (chin excluded). "right" is the subject's right (image left at frontal pose).
struct ContourChains {
    std::vector<int> right;
    std::vector<int> left;
};

struct MorphableModel {
    std::string name;
    PcaModel shape;
    std::optional<ExpressionModel> expression;
    std::optional<PcaModel> albedo;     // linear RGB in [0, 1], stacked like the shape
    std::vector<Triangle> triangles;
    Eigen::Matrix2Xf uv;                // per-vertex isomap coordinates, v = 0 at the top; may be empty
    std::vector<SurfacePoint> landmarks;  // iBUG 68 in order (0-based index = iBUG id - 1)
    ContourChains contour;
    std::vector<int> symmetry;          // mirror vertex of each vertex, -1 where unknown; may be empty
    std::vector<std::uint8_t> vertex_labels;  // Region (morph/regions.h) of each vertex; may be empty

    [[nodiscard]] int num_vertices() const { return shape.num_vertices(); }
    [[nodiscard]] int num_shape_components() const { return shape.num_components(); }
    [[nodiscard]] int num_expression_components() const;
    [[nodiscard]] int num_albedo_components() const { return albedo ? albedo->num_components() : 0; }

    // Shape with identity alpha (σ units) and expression psi (σ units or blendshape weights).
    [[nodiscard]] Eigen::Matrix3Xf shape_instance(std::span<const float> alpha,
                                                  std::span<const float> psi = {}) const;
    // Per-vertex albedo for beta; the model's mean albedo (or uniform grey when it has none).
    [[nodiscard]] Eigen::Matrix3Xf albedo_instance(std::span<const float> beta = {}) const;
    // Full mesh instance with colours and uv.
    [[nodiscard]] Mesh instance(std::span<const float> alpha, std::span<const float> psi = {},
                                std::span<const float> beta = {}) const;
    // The expression offsets (3V) for psi; zero when psi is empty.
    [[nodiscard]] Eigen::VectorXf expression_offsets(std::span<const float> psi) const;
    // Landmark positions (3 x L) on the given vertices.
    [[nodiscard]] Eigen::Matrix3Xf landmark_positions(const Eigen::Matrix3Xf& vertices) const;

    // Throws core::Error (prefixed with `context`) if sizes disagree, indices are out of range
    // or values are not finite.
    void validate(const std::string& context) const;

    // Stable checksum over every field but vertex_labels (FNV-1a 64 over the serialised content), as
    // 16 hex digits. The labels are left out so that .fsm readers that predate them (and skip their
    // section) still verify newer files, and checksums recorded before labels existed still hold.
    [[nodiscard]] std::string checksum() const;
};

// View a flat 3V vector as 3 x V columns.
[[nodiscard]] inline Eigen::Map<const Eigen::Matrix3Xf> as_points(const Eigen::VectorXf& stacked) {
    return {stacked.data(), 3, stacked.size() / 3};
}

}  // namespace facesynth::morph
