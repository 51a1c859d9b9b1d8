#pragma once
// A triangle mesh instance: what a model produces for given coefficients and what renderers,
// exporters and fitters consume.
#include <Eigen/Core>

#include <array>
#include <vector>

namespace facesynth::morph {

using Triangle = std::array<int, 3>;  // 0-based vertex ids, counter-clockwise seen from outside

struct Mesh {
    Eigen::Matrix3Xf vertices;        // model space, mm
    std::vector<Triangle> triangles;
    Eigen::Matrix3Xf colours;         // per-vertex linear RGB in [0, 1]; empty when absent
    Eigen::Matrix2Xf uv;              // per-vertex texture coordinates (v = 0 at the top); empty when absent

    [[nodiscard]] int num_vertices() const { return static_cast<int>(vertices.cols()); }
    [[nodiscard]] int num_triangles() const { return static_cast<int>(triangles.size()); }
};

// Area-weighted unit vertex normals (outward for counter-clockwise triangles).
[[nodiscard]] Eigen::Matrix3Xf vertex_normals(const Eigen::Matrix3Xf& vertices,
                                              const std::vector<Triangle>& triangles);

}  // namespace facesynth::morph
