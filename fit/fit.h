#pragma once
// Landmark-based 3DMM fitting: affine camera (Gold Standard), regularised linear identity fit,
// expression fit and jaw contour correspondences, alternated (docs/fit.md gives the equations).
#include "fit/affine_camera.h"
#include "fit/contour.h"
#include "morph/model.h"

#include <Eigen/Core>

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace facesynth::fit {

enum class JawMode {
    kFixed,    // the 17 jaw landmarks are the model's fixed landmark vertices
    kContour,  // they follow the silhouette: correspondences re-chosen every iteration
};
// "fixed" or "contour"; throws core::Error naming the text otherwise.
[[nodiscard]] JawMode parse_jaw_mode(const std::string& text);

struct FitOptions {
    int iterations = 5;              // camera → contour → identity → expression rounds (at most)
    double convergence_px = 1e-3;    // stop when the reprojection RMS changes less than this
    // Identity prior weight λ in  Σ w_i ‖r_i‖² / σ_i² + λ ‖α‖²  (α in σ units). σ_i is
    // landmark_sigma_px when > 0, otherwise 1 mm at the current camera scale (image-size invariant).
    double lambda = 30.0;            // chosen by `facesynth fit-lambda` (docs/fit.md)
    double expression_lambda = 30.0; // the same for the expression coefficients / blendshape weights
    double landmark_sigma_px = 0;
    int shape_components = 0;        // fit only the first k identity components (0: all)
    bool fit_expression = true;
    JawMode jaw = JawMode::kFixed;
    std::vector<int> subset;         // 0-based iBUG indices to use (empty: all 68); see landmark_subset()
    Eigen::VectorXd weights;         // per iBUG point (68) weight >= 0, 0 = missing; empty: all 1
};

struct FitResult {
    AffineCamera camera;
    ScaledOrthographic pose;
    std::vector<float> alpha;        // identity, σ units, model's component count (unfitted ones 0)
    std::vector<float> psi;          // expression (σ units or blendshape weights), may be empty
    std::vector<morph::SurfacePoint> correspondences;  // model point used for each of the 68 landmarks
    std::vector<int> used;           // 0-based iBUG indices that took part
    Eigen::Matrix2Xd projected;      // 2 x 68 projections of the correspondences (pixels)
    double reprojection_rms_px = 0;  // over the used points
    int iterations = 0;
};

// Holds what depends on the model only (edge topology, mean-shape normals, the landmark basis and
// its Gram blocks), so repeated fits with the same model are cheap. The model must outlive the Fitter.
class Fitter {
public:
    explicit Fitter(const morph::MorphableModel& model);

    // `landmarks`: 2 x 68 iBUG points, 0-based pixels (unused points may be NaN when their weight is
    // 0 or they are outside the subset). Throws core::Error on a wrong count, NaN in a used point,
    // fewer than 4 usable points or a degenerate configuration.
    [[nodiscard]] FitResult fit(const Eigen::Matrix2Xd& landmarks, const FitOptions& options = {}) const;

    [[nodiscard]] const morph::MorphableModel& model() const { return model_; }
    [[nodiscard]] const ContourFinder& contour() const { return contour_; }

    struct LinearCache;  // fit.cpp

private:
    const morph::MorphableModel& model_;
    ContourFinder contour_;
    std::shared_ptr<const LinearCache> linear_;
};

// One-off convenience: Fitter(model).fit(landmarks, options).
[[nodiscard]] FitResult fit_landmarks(const morph::MorphableModel& model, const Eigen::Matrix2Xd& landmarks,
                                      const FitOptions& options = {});

// The linear identity step alone (Eq. 2 in docs/fit.md) for a fixed affine camera and expression:
// returns α (σ units, the model's component count). Uses options.subset/weights/lambda/
// landmark_sigma_px/shape_components; the model's fixed landmark correspondences.
[[nodiscard]] std::vector<float> fit_identity_for_camera(const morph::MorphableModel& model, const AffineCamera& camera,
                                                         const Eigen::Matrix2Xd& landmarks, const FitOptions& options = {},
                                                         std::span<const float> psi = {});

// What one view of a face says about its identity: the linear identity step's normal equations for
// a fixed affine camera and expression, without the prior (H = Σ Bᵢᵀ Mᵀ M Bᵢ wᵢ / σ², g the matching
// gradient; σ = 1 mm at the camera's scale unless options.landmark_sigma_px). Views of one face add
// up, and α = (Σ H + λ I)⁻¹ Σ g is their joint estimate: the prior's weight stays λ while the evidence
// grows, so the fused identity converges as views accumulate (track/ fuses a video's frames so).
struct IdentityEvidence {
    Eigen::MatrixXd h;  // k x k, symmetric (k: the components used)
    Eigen::VectorXd g;  // k
    IdentityEvidence& operator+=(const IdentityEvidence& other);  // empty += e gives e
};
// The model's fixed landmark correspondences (options.subset/weights/shape_components apply).
[[nodiscard]] IdentityEvidence identity_evidence(const morph::MorphableModel& model, const AffineCamera& camera,
                                                 const Eigen::Matrix2Xd& landmarks, const FitOptions& options = {},
                                                 std::span<const float> psi = {});
// α (σ units, `num_components` long: the model's count, unused ones 0) from summed evidence and λ.
[[nodiscard]] std::vector<float> solve_identity(const IdentityEvidence& evidence, double lambda, int num_components);

// The yaw (degrees) of the model fitted to a face's 68 annotated points with the jaw on the silhouette,
// as photographs are annotated: the pose estimate per photograph that reports bin faces by. nullopt
// when the points cannot be fitted (non-finite, degenerate).
[[nodiscard]] std::optional<double> annotated_yaw(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks);

// Shape (3 x V) of a fit with its identity and expression.
[[nodiscard]] Eigen::Matrix3Xf fitted_shape(const morph::MorphableModel& model, const FitResult& result);

}  // namespace facesynth::fit
