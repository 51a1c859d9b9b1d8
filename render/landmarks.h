#pragma once
// Landmarks of a rendered image: exact 2D positions with the render's camera, 3D positions, and
// visibility from the rendered depth buffer; the 17 jaw points also in `contour` mode (moved to the
// visible face outline, as 300-W annotators click them). docs/conventions.md, Landmarks.
#include "morph/jaw_contour.h"
#include "morph/mesh.h"
#include "morph/model.h"
#include "render/renderer.h"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace facesynth::render {

struct LandmarkOptions {
    // A landmark is hidden when the rendered surface in the window around its pixel lies more than
    // this in front everywhere (a window touching the background counts as visible: the outline).
    double depth_tolerance_mm = 2.0;
    int neighbourhood_px = 1;  // half-size of the depth window searched around the landmark's pixel
    // Jaw points (with a contour region): how much of the face's own outline may cover them, in mm
    // at the point's depth (see is_outline_visible); a fixed size in the image would change with it.
    double outline_tolerance_mm = 3.0;
    // Points but the jaw (is_unoccluded): a surface crossing the camera ray less than this before the
    // point is the point's own (float rounding where the ray meets its triangles), not an occluder.
    double occlusion_margin_mm = 0.1;
    // Half-size of the window of the triangle-id buffer whose triangles are the ray's candidates.
    int occluder_window_px = 2;
};

struct ProjectedLandmarks {
    // `fixed` mode: the model's landmark points.
    Eigen::Matrix2Xd pixels;          // 0-based pixel coordinates (2 x L)
    Eigen::Matrix3Xd model_points;    // model space, mm
    Eigen::Matrix3Xd camera_points;   // OpenCV camera space, mm
    std::vector<std::uint8_t> visible;
    // `contour` mode: identical except the jaw points on the side turned away from the camera (0-7 at
    // yaw < 0, 9-16 at yaw > 0; 68-point sets only), which lie on the face's occluding contour at the
    // height of their fixed point (morph/jaw_contour.h); their 3D points are on that contour's surface.
    // The near side and the chin keep the fixed points. Without a contour region all are fixed.
    Eigen::Matrix2Xd contour_pixels;
    Eigen::Matrix3Xd contour_model_points;
    std::vector<std::uint8_t> contour_visible;
};

// What project_landmarks derives from a mesh's triangles alone: the triangles around each vertex (the
// exact ray test's candidates) and, with a contour region, which triangles touch the face region
// (outline visibility). Callers that project many instances of one model build it once.
struct LandmarkTopology {
    std::vector<int> first;   // around[first[v] .. first[v + 1]): the triangles around vertex v
    std::vector<int> around;
    std::vector<char> face_triangles;  // per triangle, 1 = has a vertex in the contour region; empty without one
};
// Throws core::Error when the contour region names a vertex outside the mesh.
[[nodiscard]] LandmarkTopology landmark_topology(const std::vector<morph::Triangle>& triangles, int num_vertices,
                                                 const morph::JawContourRegion* contour_region = nullptr);

// Needs frame.depth (settings.geometry) and frame.mask from a render of `mesh` with `camera`.
// `contour_region` (jaw_contour_region of the model `mesh` is an instance of) enables contour mode.
// `topology`, when given, is landmark_topology of the mesh's triangles and the same contour region
// (the result is the same as without it; a topology of another size is an error).
[[nodiscard]] ProjectedLandmarks project_landmarks(std::span<const morph::SurfacePoint> landmarks, const morph::Mesh& mesh,
                                                   const Camera& camera, const Frame& frame,
                                                   const LandmarkOptions& options = {},
                                                   const morph::JawContourRegion* contour_region = nullptr,
                                                   const LandmarkTopology* topology = nullptr);

// Whether a camera-space depth `camera_z` at `pixel` is unoccluded in the frame's depth buffer.
[[nodiscard]] bool is_visible(const Frame& frame, const Eigen::Vector2d& pixel, double camera_z,
                              const LandmarkOptions& options = {});

// Whether the camera ray to `camera_point` (camera space, at `pixel`) reaches it: an exact ray cast
// against the triangles seen in the (2 occluder_window_px + 1)² pixels of frame.triangle_ids around
// it, the only surfaces that can stand in front of it (a surface covering the point covers the pixel
// centres next to it, unless it is thinner than a pixel there). A depth tolerance cannot decide next
// to an outline: beside the nose's edge the far eye's corners have, within a pixel, both the nose
// 10-20 mm in front and their own surface. False outside the image.
[[nodiscard]] bool is_unoccluded(const morph::Mesh& mesh, const Camera& camera, const Frame& frame, const Eigen::Vector2d& pixel,
                                 const Eigen::Vector3d& camera_point, const LandmarkOptions& options = {});

// Visibility of a point on the face's outline (the jaw points, fixed and contour). At a silhouette the
// depth buffer cannot decide alone: the surface there is seen at a grazing angle, so a pixel next to
// an outline point can lie tens of mm in front of it (the Surrey jaw at frontal pose), and the
// background next to an outline says nothing about whether the nose or the lips stand in front of
// it (their own outline is there too). So a point is visible when the depth test of is_visible
// without its background rule passes, or when
//   - within options.outline_tolerance_mm of it (times `pixels_per_mm` at its depth, at least
//     options.neighbourhood_px) there is background or a surface behind it (it lies on an outline), and
//   - the surface seen least in front of it in the 3x3 window belongs to the face itself
//     (`face_triangles[t]` != 0 for the triangle ids of frame.triangle_ids): it is hidden by at most
//     that much of its own outline, not by the nose, the lips, the ears or the hair.
[[nodiscard]] bool is_outline_visible(const Frame& frame, const Eigen::Vector2d& pixel, double camera_z,
                                      double pixels_per_mm, std::span<const char> face_triangles,
                                      const LandmarkOptions& options = {});

// Barycentric weights of the camera ray through `pixel` on triangle `triangle` (may lie outside
// [0, 1] when the ray misses it); nullopt when the ray is parallel to the triangle's plane.
[[nodiscard]] std::optional<Eigen::Vector3d> ray_barycentrics(const morph::Mesh& mesh, const Camera& camera, int triangle,
                                                              const Eigen::Vector2d& pixel);

// The model-space surface point seen at pixel (x, y)'s centre (frame.triangle_ids), or nullopt on background.
[[nodiscard]] std::optional<Eigen::Vector3d> surface_point_at(const morph::Mesh& mesh, const Camera& camera,
                                                              const Frame& frame, int x, int y);

// The face inside its landmarks: 255 where the convex hull of the finite `points` (0-based px, rounded)
// meets pixels that `coverage` (the frame's mask, same size) covers fully, 0 elsewhere; all 0 with fewer
// than three finite points.
[[nodiscard]] cv::Mat landmark_hull_mask(const cv::Mat& coverage, const Eigen::Matrix2Xd& points);

// Jaw points as 300-W annotators space them (synth's `landmarks.mode = even`): annotators click the 17
// jaw points at nearly even steps along the face's outline, while the model's jaw points (and the
// contour mode's) are anatomical vertices at uneven steps. The 17 jaw points of `pixels` (2 x 68,
// the contour mode's) move along the outline through them so that 1-9 and 9-17 are each evenly
// spaced by arc length in the image; the ends (1, 17) and the chin (9) stay, and the 51 other points
// are unchanged. Between two points the outline is the Catmull-Rom curve through the 17 (smooth across
// the chin); the 3D points
// follow the same curve parameters (between two of the model's points such a point is off its
// surface by the curve's sag) and take the visibility of the nearer of the two. A half with a
// non-finite point (its own or the neighbour across the chin) or no length is left as it is; fewer than 68 points are returned unchanged.
struct RespacedJaw {
    Eigen::Matrix2Xd pixels;
    Eigen::Matrix3Xd model_points;
    std::vector<std::uint8_t> visible;
};
[[nodiscard]] RespacedJaw space_jaw_evenly(const Eigen::Matrix2Xd& pixels, const Eigen::Matrix3Xd& model_points,
                                           std::span<const std::uint8_t> visible);

}  // namespace facesynth::render
