#pragma once
// Jaw contour correspondences: on photographs the 17 jaw landmarks lie on the visible outline of the
// face, so their model points change with pose. Candidates are the vertices of the model's contour
// chains and of occluding edges (an edge between a front- and a back-facing triangle, or a mesh
// boundary edge of a front-facing triangle) under the current camera; each jaw landmark takes the
// candidate on its side of the face whose projection is nearest to it (as eos does). O(triangles +
// edges) per update, no ray casting: front/back facing uses the mean shape's triangle normals.
#include "fit/affine_camera.h"
#include "morph/model.h"

#include <Eigen/Core>

#include <vector>

namespace facesynth::fit {

struct Edge {
    int a = 0, b = 0;              // vertex ids, a < b
    int left = -1, right = -1;     // adjacent triangles; right = -1 on a mesh boundary
};

// Unique edges with their adjacent triangles (computed once per model).
[[nodiscard]] std::vector<Edge> edge_topology(const std::vector<Triangle>& triangles, int num_vertices);

class ContourFinder {
public:
    explicit ContourFinder(const MorphableModel& model);

    // Vertices on occluding edges for a rotation R (pose.h convention; the viewer is at +z in
    // camera space after the flip, i.e. a triangle faces the camera when (R n).z > 0).
    [[nodiscard]] std::vector<int> occluding_vertices(const Eigen::Matrix3d& rotation) const;

    // For each jaw landmark j in `jaw_indices` (0-based iBUG ids 0..16 except the chin 8), the vertex
    // among the candidates on that landmark's side whose projection under `camera` (of `vertices`,
    // the current shape) is nearest to landmarks.col(j). Returns 17 vertex ids (-1 where not asked).
    [[nodiscard]] std::vector<int> jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                       const Eigen::Matrix3Xf& vertices,
                                                       const std::vector<int>& jaw_indices) const;
    // The same, reconstructing only candidate vertices from coefficients (faster than a full shape).
    [[nodiscard]] std::vector<int> jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                       const std::vector<float>& alpha, const std::vector<float>& psi,
                                                       const std::vector<int>& jaw_indices) const;

    [[nodiscard]] const std::vector<Edge>& edges() const { return edges_; }

private:
    std::vector<int> candidates(const Eigen::Matrix3d& rotation) const;
    template <class PositionOf>
    std::vector<int> choose(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                            const std::vector<int>& jaw_indices, PositionOf&& position_of) const;

    const MorphableModel& model_;
    std::vector<Edge> edges_;
    Eigen::Matrix3Xf triangle_normals_;   // of the mean shape
    std::vector<signed char> side_;       // per vertex: -1 subject's right (x < 0), +1 left, 0 midline
    std::vector<char> in_face_region_;    // per vertex: front half and at jaw height (mean shape)
};

}  // namespace facesynth::fit
