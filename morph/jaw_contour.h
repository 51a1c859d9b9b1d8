#pragma once
// The jaw contour definition shared by rendering (synth labels) and fitting (contour correspondences).
//
// A 300-W annotator marks the 17 jaw points on the visible face outline. As the face turns, only the
// points on the side turned AWAY from the camera move onto the face's occluding contour (cheek and jaw
// outline); the side turned toward the camera keeps them on the jaw line, i.e. the fixed jaw landmarks,
// and the chin (iBUG 9) never moves (landmark marching, Zhu et al. CVPR 2015).
//
// Definition: for a jaw point j on the far side, draw the line through its projected fixed point
// along the face's horizontal image direction (the projected model x axis). The contour point is the
// intersection of that line with an edge of the face region's triangles that lies furthest out in
// the far direction: a point of the face region's projected outline, i.e. of its true occluding
// contour (where the surface normal is perpendicular to the view) or of the region's border.
// The face region (jaw_contour_region) is the part of the mean shape inside the fixed jaw line:
// between the left and right jaw lines at each height, above the chin, in front of the jaw points
// and no higher than the contour chains' top (plus 5% of the model's size). Its border is the fixed
// jaw line itself, so at frontal pose the contour points are the fixed points, and ears, neck, the
// back of the head and the hair never take part. A model without the 17 fixed jaw points has none.
#include "morph/model.h"

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace facesynth::morph {

struct JawContourRegion {
    std::vector<int> vertices;                 // face-region vertex ids (global)
    std::vector<std::array<int, 2>> edges;     // unique edges of face-region triangles, as indices into `vertices`
};

// The height and depth band of the mean shape where jaw outline points can lie: spanned by the
// contour chains and the fixed jaw landmarks, widened by 5% of the model's size. The face region
// below and the fitter's fallback for models without fixed jaw points both use it.
struct JawBand {
    float y_low = 0, y_high = 0, z_low = 0, margin = 0;
    float midline = 0;  // |x| below this counts as the midline
    bool empty = true;  // no anchors: nothing is in the band

    [[nodiscard]] bool contains(const Eigen::Vector3f& p) const {
        return !empty && p.y() >= y_low - margin && p.y() <= y_high + margin && p.z() >= z_low - margin;
    }
    // -1 subject's right (x < 0), +1 left, 0 midline.
    [[nodiscard]] signed char side(const Eigen::Vector3f& p) const {
        return static_cast<signed char>(p.x() < -midline ? -1 : (p.x() > midline ? 1 : 0));
    }
};
[[nodiscard]] JawBand jaw_band(const MorphableModel& model);

// The face region of a model (computed once per model). Empty when the model lacks fixed jaw points.
[[nodiscard]] JawContourRegion jaw_contour_region(const MorphableModel& model);

// The side turned away from the camera for a rotation R (pose.h convention, viewer at +z before the
// flip): +1 the subject's left (model +x, iBUG 10-17; yaw > 0), -1 the right (iBUG 1-8; yaw < 0),
// 0 at exactly frontal.
[[nodiscard]] int far_side(const Eigen::Matrix3d& rotation);

// Whether 0-based jaw landmark j (0..16) lies on side `side` (-1: 0..7, +1: 9..16; the chin is on none).
[[nodiscard]] inline bool jaw_on_side(int j, int side) {
    return side != 0 && j != 8 && j >= 0 && j < 17 && ((j < 8) == (side < 0));
}

// The contour point of a far-side jaw point: `projected` holds the image positions of
// region.vertices (2 × region.vertices.size()), `fixed_pixel` the projected fixed jaw point and
// `outward` the image direction pointing away from the face on that side. Returns the surface point
// on the chosen edge (two vertices with weights) and its image position; nullopt when the line meets
// no region edge.
struct JawContourHit {
    SurfacePoint point;
    Eigen::Vector2d pixel;
};
[[nodiscard]] std::optional<JawContourHit> jaw_contour_point(const JawContourRegion& region, const Eigen::Matrix2Xd& projected,
                                                             const Eigen::Vector2d& fixed_pixel,
                                                             const Eigen::Vector2d& outward);

// Several far-side jaw points in one pass over the region's edges: the same hits, bit for bit, as
// jaw_contour_point for each query (an edge is tested exactly only when a cheap bound says that the
// query's line may cross it). The fitter asks for up to 8 per round.
struct JawContourQuery {
    Eigen::Vector2d fixed_pixel;
    Eigen::Vector2d outward;
};
[[nodiscard]] std::vector<std::optional<JawContourHit>> jaw_contour_points(const JawContourRegion& region,
                                                                           const Eigen::Matrix2Xd& projected,
                                                                           const std::vector<JawContourQuery>& queries);

}  // namespace facesynth::morph
