#pragma once
// Jaw contour correspondences: on photographs the jaw landmarks on the side turned away from the camera
// lie on the face's occluding contour, so their model points change with pose. The definition is the
// one synth's contour labels use (morph/jaw_contour.h): under the current affine camera and shape, the
// far-side jaw landmark corresponds to the outermost point (in the far direction) of the face region
// on the line through it along the face's horizontal image direction; near-side landmarks and the
// chin keep the model's fixed jaw landmarks. Landmarks whose fixed point the model lacks fall back to
// the nearest candidate among contour-chain vertices and face-region occluding-edge vertices (eos).
#include "fit/affine_camera.h"
#include "morph/jaw_contour.h"
#include "morph/model.h"

#include <Eigen/Core>

#include <functional>
#include <optional>
#include <vector>

namespace facesynth::fit {

struct Edge {
    int a = 0, b = 0;              // vertex ids, a < b
    int left = -1, right = -1;     // adjacent triangles; right = -1 on a mesh boundary
};

// Unique edges with their adjacent triangles (computed once per model).
[[nodiscard]] std::vector<Edge> edge_topology(const std::vector<morph::Triangle>& triangles, int num_vertices);

// A pinhole camera for the contour step of the perspective refinement: x_cam = flip · R · X + t,
// pixel = focal · x_cam.xy / x_cam.z + (cx, cy) (as render's camera and fit/refine.h).
struct PinholeView {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    double focal = 1, cx = 0, cy = 0;
};

class ContourFinder {
public:
    explicit ContourFinder(const morph::MorphableModel& model);

    // Vertices on occluding edges for a rotation R (pose.h convention; the viewer is at +z in
    // camera space after the flip, i.e. a triangle faces the camera when (R n).z > 0).
    [[nodiscard]] std::vector<int> occluding_vertices(const Eigen::Matrix3d& rotation) const;

    // For each jaw landmark j in `jaw_indices` (0-based iBUG ids 0..16 except the chin 8), its model
    // point under `camera` and `vertices` (the current shape), as described above. Returns 17 entries
    // (nullopt where not asked or not found).
    [[nodiscard]] std::vector<std::optional<morph::SurfacePoint>> jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                       const Eigen::Matrix3Xf& vertices,
                                                       const std::vector<int>& jaw_indices) const;
    // The same, reconstructing only candidate vertices from coefficients (faster than a full shape).
    [[nodiscard]] std::vector<std::optional<morph::SurfacePoint>> jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                       const std::vector<float>& alpha, const std::vector<float>& psi,
                                                       const std::vector<int>& jaw_indices) const;

    // The same under a pinhole camera (the perspective refinement: the same projection synth uses).
    [[nodiscard]] std::vector<std::optional<morph::SurfacePoint>> jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const PinholeView& camera,
                                                       const std::vector<float>& alpha, const std::vector<float>& psi,
                                                       const std::vector<int>& jaw_indices) const;

    [[nodiscard]] const std::vector<Edge>& edges() const { return edges_; }

private:
    std::vector<int> candidates(const Eigen::Matrix3d& rotation) const;
    template <class Project, class PositionOf>
    std::vector<std::optional<morph::SurfacePoint>> choose(const Eigen::Matrix2Xd& landmarks, const Eigen::Matrix3d& rotation,
                                                    Project&& project, const std::vector<int>& jaw_indices,
                                                    PositionOf&& position_of,
                                                    const Eigen::Matrix3Xf* region_positions = nullptr) const;
    // The face region's vertices for coefficients alpha, psi (3 x region size), as one matrix product.
    [[nodiscard]] Eigen::Matrix3Xf region_positions(const std::vector<float>& alpha, const std::vector<float>& psi) const;
    [[nodiscard]] std::function<Eigen::Vector3d(int)> position_function(const std::vector<float>& alpha,
                                                                        const std::vector<float>& psi) const;

    const morph::MorphableModel& model_;
    std::vector<Edge> edges_;
    Eigen::Matrix3Xf triangle_normals_;   // of the mean shape
    std::vector<signed char> side_;       // per vertex: -1 subject's right (x < 0), +1 left, 0 midline
    std::vector<char> in_face_region_;    // per vertex: front half and at jaw height (mean shape)
    morph::JawContourRegion region_;             // the shared definition's face region
    // The shape and expression models restricted to the region's vertices (3R rows), so that the
    // contour step reconstructs them with one matrix-vector product per round.
    Eigen::VectorXf region_mean_;
    Eigen::MatrixXf region_shape_basis_;       // rescaled: columns × sqrt(eigenvalue)
    Eigen::MatrixXf region_expression_basis_;  // rescaled PCA columns, or blendshape offsets
};

}  // namespace facesynth::fit
