#pragma once
// Landmark conventions against annotators (docs/results.md, "Landmark conventions"): the model fitted to
// manual annotations, and per landmark the mean of (annotation - fitted model point) in the face
// frame. The fit spreads random annotation noise over every point; what stays in the mean is where
// annotators put a point systematically elsewhere than the model's definition of it can reach.
// A point annotated in front of (or behind) the model's moves sideways with the head's yaw: the slope of
// its x offset against sin(fitted yaw) over the faces is that depth difference (`depth`), which
// near-frontal means cannot show.
#include "fit/fit.h"

#include <Eigen/Core>

#include <vector>

namespace facesynth::fit {

struct ConventionStudy {
    int faces = 0;             // annotations fitted (|yaw| within the limit)
    int skipped_pose = 0;      // fitted, but turned further than the limit
    int failed = 0;            // the fit threw (degenerate annotation)
    // Mean and standard deviation over the faces of (annotation - model point) in the annotation's face
    // frame (morph/landmarks.h face_frame_offsets), inter-ocular distances: 2 x 68 each.
    Eigen::Matrix2Xd mean;
    Eigen::Matrix2Xd stddev;
    // Per landmark, the least-squares slope of the x offset against sin(yaw): how far in front of the
    // model's point (toward the camera at yaw 0) annotators put it, inter-ocular distances. Empty when
    // the faces' yaws spread less than kMinDepthYawSpread (the slope would be noise).
    Eigen::RowVectorXd depth;
    double sin_yaw_stddev = 0;
};

// Standard deviation of sin(yaw) over the faces below which `depth` is not measured (about 3°).
inline constexpr double kMinDepthYawSpread = 0.05;

// Fits each annotation (68 points, 0-based pixels) with `options` and accumulates the offsets of the
// faces whose fitted |yaw| is at most `max_abs_yaw_deg`.
[[nodiscard]] ConventionStudy study_conventions(const Fitter& fitter, const std::vector<Eigen::Matrix2Xd>& annotations,
                                                const FitOptions& options, double max_abs_yaw_deg);

}  // namespace facesynth::fit
