#pragma once
// One face fitted to its landmarks as the `fit` command does it (linear fit, optionally refined with a
// perspective camera), the projection of the fitted instance, and the flat JSON keys of fit results,
// written in one place for every command that reports a fit (docs/cli.md).
#include "fit/fit.h"
#include "fit/refine.h"
#include "morph/mesh.h"

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <string>
#include <vector>

namespace facesynth::fit {

struct LandmarkFitOptions {
    FitOptions fit;
    bool refine = false;
    RefineOptions refine_options;  // with refine: the known image size and focal length, if any
};

struct LandmarkFit {
    FitResult linear;
    std::optional<RefineResult> refined;
    morph::Mesh mesh;              // the fitted instance in model space
    Eigen::Matrix2Xd vertices_px;  // its vertices in the image, through the final camera

    // The final fit: the refined one when there is one, else the linear one.
    [[nodiscard]] const std::vector<float>& alpha() const { return refined ? refined->alpha : linear.alpha; }
    [[nodiscard]] const std::vector<float>& psi() const { return refined ? refined->psi : linear.psi; }
    [[nodiscard]] const morph::EulerAngles& angles() const { return refined ? refined->angles : linear.pose.angles; }
    [[nodiscard]] const Eigen::Matrix3d& rotation() const { return refined ? refined->pose.rotation : linear.pose.rotation; }
    [[nodiscard]] double reprojection_rms_px() const { return refined ? refined->reprojection_rms_px : linear.reprojection_rms_px; }
    [[nodiscard]] const Eigen::Matrix2Xd& projected() const { return refined ? refined->projected : linear.projected; }  // the 68 landmarks
};

// What a caller of the `fit` command chooses (its options and defaults; docs/cli.md).
struct FaceFitChoices {
    JawMode jaw = JawMode::kContour;
    std::vector<int> subset;            // 0-based iBUG indices (empty: all 68)
    double lambda = FitOptions{}.lambda;  // identity and expression prior weight
    int iterations = FitOptions{}.iterations;
    int shape_components = 0;           // 0: all
    bool fit_expression = true;
    bool refine = false;
    double landmark_sigma_px = 3.0;     // annotation noise on photographs (docs/fit.md)
    double focal_px = 0;                // with refine: a known focal length (0: estimated)
    int image_width = 0, image_height = 0;  // with refine: the image size, when known (0: unknown)
};
[[nodiscard]] LandmarkFitOptions landmark_fit_options(const FaceFitChoices& choices);

// Throws core::Error (as Fitter::fit and refine) on unusable landmarks or a failed solve.
[[nodiscard]] LandmarkFit fit_face(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const LandmarkFitOptions& options);

// A matrix as rows of numbers.
[[nodiscard]] nlohmann::json matrix_json(const Eigen::MatrixXd& m);

// The keys of the `fit` command's fit.json that describe the fit: landmarks_used, refined, the linear
// fit (linear_reprojection_rms_px, linear_scale_px_per_mm, linear_translation_px, affine_camera,
// iterations), the refined camera (focal_px, cx, cy, translation_mm, refine_iterations) when refined,
// and the final yaw_deg, pitch_deg, roll_deg, rotation, alpha, psi, reprojection_rms_px.
void write_json(nlohmann::json& j, const LandmarkFit& fit);

// The keys of a linear fit as the frontalisation records have them: yaw_deg, pitch_deg, roll_deg,
// rotation, scale_px_per_mm, translation_px, affine_camera, alpha, psi, reprojection_rms_px.
void write_json(nlohmann::json& j, const FitResult& fit);

}  // namespace facesynth::fit
