#pragma once
// Nonlinear refinement of a linear fit (Ceres): perspective camera (pinhole, morph/camera.h) with a
// known or estimated focal length; pose, identity and expression optimised jointly; robust (Huber)
// loss on the landmark residuals; Gaussian priors on the coefficients (docs/fit.md, Eq. 5).
#include "fit/fit.h"
#include "morph/camera.h"

#include <Eigen/Core>

#include <vector>

namespace facesynth::fit {

struct RefineOptions {
    // Known intrinsics (fx > 0) are kept fixed. With fx <= 0 the focal length is estimated, starting
    // from 1.5 · max(width, height) when the image size is known, otherwise from a head 80 cm away,
    // with a weak log-normal prior (σ = ln 2) around that start. The principal point is (cx, cy) when
    // width > 0, otherwise the centre of the landmarks' bounding box.
    morph::Intrinsics intrinsics;
    double landmark_sigma_px = 1.0;  // σ of the landmark noise: residuals are divided by it
    double huber_px = 3.0;           // Huber threshold (pixels)
    double identity_prior = 1.0;     // weight of ‖α‖² (1: the model's N(0, I) prior at the given σ)
    double expression_prior = 1.0;   // the same for ψ (blendshape weights stay >= 0)
    int max_iterations = 30;         // Levenberg-Marquardt iterations per round
    int contour_rounds = 2;          // in contour mode: re-choose jaw correspondences, solve again
};

struct RefineResult {
    morph::Intrinsics intrinsics;           // fx = fy = the (known or estimated) focal length
    morph::CameraPose pose;                 // x_cam = flip · R · X + t (morph/camera.h)
    morph::EulerAngles angles;
    std::vector<float> alpha;
    std::vector<float> psi;
    std::vector<morph::SurfacePoint> correspondences;
    Eigen::Matrix2Xd projected;      // 2 x 68 (NaN where the model has no correspondence)
    double reprojection_rms_px = 0;  // over the used points
    int iterations = 0;              // Levenberg-Marquardt iterations, all rounds
};

// Refines `initial` (a result of Fitter::fit with the same landmarks and fit options). Throws
// core::Error on invalid input (as Fitter::fit) or a failed solve.
[[nodiscard]] RefineResult refine(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const FitResult& initial,
                                  const FitOptions& fit_options = {}, const RefineOptions& options = {});

// Linear fit followed by refinement.
[[nodiscard]] RefineResult fit_and_refine(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks,
                                          const FitOptions& fit_options = {}, const RefineOptions& options = {});

}  // namespace facesynth::fit
