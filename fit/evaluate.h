#pragma once
// Accuracy of one fit against known ground truth (docs/conventions.md, Metrics), and synthetic validation cases for
// choosing the regularisation (docs/fit.md, "Choosing λ"). `facesynth eval fit` is a loop over these.
#include "fit/fit.h"
#include "fit/refine.h"
#include "morph/camera.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace facesynth::fit {

struct FitTruth {
    std::vector<float> alpha;      // identity, σ units (missing trailing components count as 0)
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // pose.h convention
};

struct EvalOptions {
    FitOptions fit;
    bool refine = false;
    RefineOptions refine_options;  // its intrinsics are the true ones when known
};

struct FitMetrics {
    morph::EulerAngles fitted, truth;
    double yaw_error_deg = 0, pitch_error_deg = 0, roll_error_deg = 0;  // absolute, wrapped to [0, 180]
    double yaw_signed_error_deg = 0, pitch_signed_error_deg = 0, roll_signed_error_deg = 0;  // fitted - true, wrapped to [-180, 180)
    double vertex_rmse_mm = 0;            // fitted vs true identity shape, model space, expression zero
    double vertex_rmse_mm_meanshape = 0;  // the model's mean vs the true identity (the baseline)
    double alpha_rmse = 0;                // over the model's components, σ units
    double reprojection_px = 0;           // RMS over the used landmarks
    double ms = 0;                        // wall time of the fit (and refinement)
    double cpu_ms = 0;                    // CPU time of the calling thread for the same (robust on a loaded machine)
};

// Fits `landmarks` (2 x 68, 0-based pixels; the jaw mode in options.fit.jaw says how they were made)
// and compares with the truth.
[[nodiscard]] FitMetrics evaluate_fit(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const FitTruth& truth,
                                      const EvalOptions& options = {});

// A random face seen by a random perspective camera, with landmarks at the model's fixed
// correspondences plus Gaussian pixel noise: the validation data for choosing λ.
struct SyntheticCase {
    FitTruth truth;
    std::vector<float> psi;
    morph::Intrinsics intrinsics;
    morph::CameraPose pose;
    Eigen::Matrix2Xd landmarks;  // 2 x 68 (NaN where the model has no landmark)
};
struct SyntheticOptions {
    double noise_px = 0;        // σ of the Gaussian landmark noise
    double max_yaw_deg = 60, max_pitch_deg = 20, max_roll_deg = 15;  // uniform ranges ±
    double expression_scale = 0.5;  // blendshape weights U(0, scale) / PCA coefficients N(0, scale²)
    int image_size = 512;
    double fov_deg = 30;
};
// Case `index` of the set `seed`: identity, expression, pose and noise each from their own stream of
// make_rng(seed, index, ·), so sets are reproducible and independent of order.
[[nodiscard]] SyntheticCase make_synthetic_case(const morph::MorphableModel& model, std::uint64_t seed, std::uint64_t index,
                                                const SyntheticOptions& options = {});

struct LambdaScore {
    double lambda = 0;
    double vertex_rmse_mm = 0;  // mean over the validation cases
    double vertex_rmse_mm_meanshape = 0;
    double alpha_rmse = 0;
};
// Fits `count` synthetic cases (seed `seed`, which must differ from any test set) with each candidate λ
// (identity and expression alike) and returns the scores; the best is the lowest mean vertex RMSE.
[[nodiscard]] std::vector<LambdaScore> score_lambdas(const Fitter& fitter, const std::vector<double>& candidates, int count,
                                                     std::uint64_t seed, const SyntheticOptions& synthetic,
                                                     const FitOptions& base = {});

}  // namespace facesynth::fit
