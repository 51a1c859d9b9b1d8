#pragma once
// Supervised Descent Method (Xiong & De la Torre 2013) as a cascade of linear regressors on HOG
// features, following the superviseddescent recipe (Xiong & De la Torre, CVPR 2013; docs/train.md): at stage k, features φ_k(x) are
// HOG descriptors of square patches around the current landmarks x (patch side = a fixed fraction
// of the current inter-eye-centre distance d(x)), and the update is
//     x ← x + d(x) · (W_k φ_k(x) + b_k),
// with W_k, b_k from ridge regression on perturbed training initialisations. All shapes here are in
// canonical crop coordinates (train/face_box.h).
#include "train/face_box.h"
#include "train/hog.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace facesynth::train {

struct SdmStageSettings {
    double patch_relative = 1.0;  // patch side / inter-eye-centre distance
    int cell_size = 8;            // pixels per HOG cell after resampling the patch
    // Whether the 17 jaw points' HOG enters the features. Renders have no neck, ears or hair, so the
    // jaw line is a clean face/background edge there and not in photographs: early, coarse stages
    // can leave it out and move the jaw points from the inner features alone (docs/train.md).
    bool jaw_features = true;
};

// Landmarks whose HOG a stage uses: all 68, or the 51 non-jaw ones (iBUG 18-68).
[[nodiscard]] int feature_landmark_count(const SdmStageSettings& stage);

// 1.0, 0.7, 0.4, 0.25 (extended by 0.2, 0.15, ... for more stages) with cells 8, 7, 6, 5, 5, ...;
// jaw features from stage `jaw_features_from` (1-based) on. Non-empty `patch_sides` replaces the
// patch sides (one per stage, each in (0, 2]; core::Error naming `--patch-sizes` otherwise).
[[nodiscard]] std::vector<SdmStageSettings> default_stage_settings(int stages, int jaw_features_from = 1,
                                                                   std::span<const double> patch_sides = {});

// The length a cascade measures shapes in: patch sides and updates are multiples of it. The
// inter-eye-centre distance of the current shape (the SDM papers' choice) shrinks with |yaw| and
// vanishes in profile, which makes the targets of turned faces huge; a fixed length in the canonical
// crop (whose box is the detector's, so the face's size is fixed there) does not depend on pose.
enum class ShapeUnitKind : std::uint32_t { kInterEyeCentres = 0, kFixed = 1 };
struct ShapeUnit {
    ShapeUnitKind kind = ShapeUnitKind::kInterEyeCentres;
    double fixed_length = 0;  // kFixed: canonical crop pixels
    [[nodiscard]] double of(const Eigen::Matrix2Xd& shape) const;
};

// One linear stage of reduced rank r: update = basis · (weights · φ) + bias. The basis columns are the
// leading principal directions of the training targets (orthonormal), so updates stay in the span of
// the displacements seen in training and the cost per face is r·(D + 2L) instead of 2L·D.
struct SdmStage {
    SdmStageSettings settings;
    Eigen::MatrixXf basis;    // 2L x r
    Eigen::MatrixXf weights;  // r x D
    Eigen::VectorXf bias;     // 2L, as (x0, y0, x1, y1, ...)
};

// How detector boxes relate to the faces, measured on the training data.
struct BoxStatistics {
    DetectorKind detector = DetectorKind::kFrontal;  // the face detector used (and to use with the model)
    std::array<int, kFaceViews> view_matched{};      // detector-matched training faces per view
    int detector_matched = 0;  // training faces with a matching detection
    int detector_missed = 0;   // faces that got a synthesised box instead
    // Detector box relative to the landmarks' bounding box (width ratio; centre offset / landmark width).
    double width_ratio_mean = 1.0, width_ratio_std = 0.04;
    Eigen::Vector2d offset_mean = Eigen::Vector2d::Zero(), offset_std = Eigen::Vector2d::Constant(0.04);
    // Spread of the true shape around the mean shape in the box frame (similarity parameters), used
    // to perturb training initialisations: translation in box widths, scale factor, rotation in degrees.
    double init_translation_std = 0.04, init_scale_std = 0.04, init_rotation_std_deg = 3.0;
};

// The cascade of the profile views when the model has view-specific cascades (format version 4): trained
// on the faces the profile cascade found with the nose to the image's left, and on nose-right faces
// mirrored (image flipped, points permuted), so that one cascade serves both sides. Detection mirrors
// nose-right crops, runs it, and mirrors the result back.
struct ProfileCascade {
    Eigen::Matrix2Xd mean_shape;  // nose-left orientation, canonical crop coordinates
    std::vector<SdmStage> stages;
    std::vector<SdmStage> realigned_stages;  // as SdmModel::realigned_stages
    int faces = 0;  // training faces (held-out validation faces included), mirrored ones counted once
    double init_translation_std = 0, init_scale_std = 0, init_rotation_std_deg = 0;
};

struct SdmModel {
    int num_landmarks = 68;
    HogLayout hog;                     // HOG cells per patch side and orientations
    // The learned box-to-shape alignment: the mean shape (canonical crop coordinates) of the training
    // faces whose box came from the detector, and per detector view (train/face_box.h) the mean of
    // that view's faces: the pose-indexed initialisation. A view with too few training faces
    // (kMinViewFaces) has an empty matrix and starts from `mean_shape`.
    Eigen::Matrix2Xd mean_shape;
    std::array<Eigen::Matrix2Xd, kFaceViews> view_mean_shapes;
    std::array<int, kFaceViews> view_faces{};  // training faces (all boxes) per view
    std::vector<SdmStage> stages;  // with a profile cascade: the frontal view's cascade
    // The cascade of the realigned second pass (SdmInference::realign; format version 6), trained on crops
    // turned upright by the truth: empty where the model has none, and the second pass runs `stages` again.
    std::vector<SdmStage> realigned_stages;
    std::optional<ProfileCascade> profile;
    ShapeUnit unit;                // of every cascade (format version 5; earlier files: inter-eye centres)
    BoxStatistics boxes;
    std::uint64_t training_checksum = 0;  // of the training keys and landmarks
    std::uint32_t training_faces = 0;
    std::uint32_t augment = 0;

    [[nodiscard]] int feature_dims(const SdmStageSettings& stage) const;
    // Where the cascade starts for a box found by `view`.
    [[nodiscard]] const Eigen::Matrix2Xd& initial_shape(FaceView view) const;
};

// Fewest detector-boxed training faces of one view for that view to get its own mean shape.
inline constexpr int kMinViewFaces = 10;

// Features of one shape for one stage: feature_landmark_count(stage) · hog.dims() floats.
void sdm_features(const cv::Mat& crop, const Eigen::Matrix2Xd& shape, const HogLayout& hog, const SdmStageSettings& stage,
                  const ShapeUnit& unit, std::span<float> out);

// Runs `stages` from `shape` on a canonical crop; `after_each_stage` (optional) receives the shape
// after every stage.
[[nodiscard]] Eigen::Matrix2Xd sdm_refine(std::span<const SdmStage> stages, const HogLayout& hog, const ShapeUnit& unit, const cv::Mat& crop,
                                          Eigen::Matrix2Xd shape, std::vector<Eigen::Matrix2Xd>* after_each_stage = nullptr);
// The same with the model's main (single or frontal) cascade.
[[nodiscard]] Eigen::Matrix2Xd sdm_refine(const SdmModel& model, const cv::Mat& crop, Eigen::Matrix2Xd shape,
                                          std::vector<Eigen::Matrix2Xd>* after_each_stage = nullptr);

// How a cascade is run at test time (regressor specs `mirror:` and `realign:`, train/regressor.h).
struct SdmInference {
    // Also run on the mirror image of the crop (from the mirrored start shape, the result mirrored
    // back) and average the two. Where the model has a profile cascade, profile-view crops are not
    // mirrored: that cascade reads one orientation only. Twice the cost per face.
    bool mirror = false;
    // A second pass on the crop resampled by the similarity that takes the start shape onto the first
    // pass's result (the face moved, scaled and turned upright to where the start expects it, which the
    // detector's box does only roughly), mapped back and averaged with the first. The second pass runs the
    // model's realigned cascade where it has one (1.7 x one pass with four of six stages), else the same
    // cascade again (twice the cost).
    bool realign = false;
};

// The landmarks (canonical crop coordinates) of the face in a canonical crop found by `view`: the
// cascade that serves that view from its start shape (a nose-right crop is mirrored for the profile
// cascade and the result mirrored back).
[[nodiscard]] Eigen::Matrix2Xd sdm_refine_view(const SdmModel& model, const cv::Mat& crop, FaceView view,
                                               const SdmInference& inference = {});

// Landmarks (0-based image pixels) of the face in `box` of an 8-bit grey image, starting from the
// initial shape of the box's view; profile views go through the profile cascade where the model has
// one (nose-right crops mirrored).
[[nodiscard]] Eigen::Matrix2Xd sdm_detect(const SdmModel& model, const cv::Mat& gray, const FaceBox& box,
                                          const SdmInference& inference = {});

// One training face, already cut out around its box.
struct TrainingFace {
    cv::Mat crop;               // kCanonicalCropSide² 8-bit grey
    Eigen::Matrix2Xd truth;     // canonical crop coordinates
    bool box_from_detector = false;
    FaceView view = FaceView::kFrontal;  // the view that found it (for synthesised boxes: the view assigned)
    std::optional<double> yaw_deg;       // ground truth where the data has it (synth meta)
    // From a folder of photographs (LabelledImage::photograph): the faces SdmTrainOptions::image_copies copies.
    bool photograph = true;
};

// The iBUG mirror of a shape in canonical crop coordinates: x -> side - 1 - x (the pixel centres of a
// horizontally flipped crop) and each point takes its left/right partner's place
// (morph ibug_mirror_pairs), so that the result is again a valid 68-point shape of the flipped crop.
// Mirroring twice gives the shape back exactly.
[[nodiscard]] Eigen::Matrix2Xd mirror_canonical_shape(const Eigen::Matrix2Xd& shape);
// The flipped crop with the mirrored shape; nose-left and nose-right views swap, the yaw changes sign.
[[nodiscard]] TrainingFace mirror_training_face(const TrainingFace& face);

struct SdmStageReport {
    int stage = 0;           // 1-based
    double nme_before = 0;   // mean training NME (inter-ocular) before and after this stage
    double nme_after = 0;
    double validation_nme_before = 0;  // the same on the held-out validation faces (0 without any)
    double validation_nme_after = 0;
    double lambda_factor = 0;          // the candidates chosen (by validation when there are several)
    int rank = 0;
    double lambda = 0;
    int feature_components = 0;  // principal components of the features regressed on (0: PCA off)
    double seconds = 0;
};

struct SdmTrainOptions {
    int stages = 4;
    int augment = 10;        // perturbed initialisations per face
    // Each training face also trains as its mirror image (mirror_training_face; validation faces are
    // not mirrored, so λ and the rank are still chosen on faces no row has seen).
    bool mirror = false;
    // Each training photograph (TrainingFace::photograph; validation faces and renders not) also trains as
    // this many moved and degraded copies (train/image_copies.h), each with `augment` starts.
    int image_copies = 0;
    int threads = 1;
    std::uint64_t seed = 1;
    HogLayout hog;
    // Ridge λ = factor · ‖A_cᵀA_c‖_F / N (A_c: centred features). With several candidates each stage
    // keeps the one with the lowest NME on the validation faces after the update.
    std::vector<double> lambda_factors = {3.0, 10.0, 30.0, 100.0};
    // Every round(1 / share)-th face (indices k-1, 2k-1, ...) is held out: it never enters a regression
    // or the mean shape and only chooses λ and reports validation NME. 0: no validation (needs a
    // single λ candidate).
    double validation_share = 0.1;
    // Candidate ranks of each stage's update (at most 2L = 136), chosen with λ on the validation faces:
    // the smallest rank whose validation NME is within `rank_tolerance` (relative) of the best pair.
    std::vector<int> ranks = {8, 16, 24, 32, 48, 136};
    double rank_tolerance = 0.01;
    // Feature PCA: each stage regresses on this many leading principal components of its centred
    // training features (capped at the stage's feature dimension D and, in the dual form, at the
    // training rows) and folds the projection into its weights; 0: off (plain ridge on all D features).
    int feature_components = 0;
    int jaw_features_from = 3;  // first stage (1-based) whose features include the jaw points
    ShapeUnitKind unit = ShapeUnitKind::kInterEyeCentres;
    // kFixed: the unit's length in canonical crop pixels; 0: the inter-eye-centre distance of the
    // training faces' mean shape (view cascades give the profile cascade the frontal one's).
    double fixed_unit_length = 0;
    std::vector<SdmStageSettings> stage_settings;  // empty: default_stage_settings(stages, jaw_features_from)
    // train_realigned_cascade: its stages (the first `realign_stages` of the main cascade's settings), and
    // its starts' spread as a multiple of the main cascade's residual similarity on the validation faces.
    int realign_stages = 0;
    double realign_spread = 1.5;
    std::function<void(const SdmStageReport&)> on_stage;
    std::function<void(std::size_t rows_done, std::size_t rows_total)> on_progress;  // feature extraction
};

// The faces a cascade trains and validates on. Every round(1 / validation_share)-th face (indices k-1,
// 2k-1, ...) is held out for validation; after the faces given come, as further training faces, the
// training faces' mirror images (options.mirror) and then the training photographs' copies
// (options.image_copies, copy-major: train/image_copies.h). Validation faces are never mirrored or copied.
// Throws core::Error for fewer than 2 training faces, or several λ or rank candidates without validation.
struct TrainingRows {
    std::vector<std::size_t> train, validation;  // indices into faces(originals)
    std::vector<TrainingFace> extended;          // with mirrors or copies: the faces given, then the added ones

    [[nodiscard]] std::span<const TrainingFace> faces(std::span<const TrainingFace> originals) const {
        return extended.empty() ? originals : std::span<const TrainingFace>(extended);
    }
};
[[nodiscard]] TrainingRows training_rows(std::span<const TrainingFace> faces, const SdmTrainOptions& options);

// Trains the cascade. `boxes` carries the detector statistics measured while preparing the faces;
// the perturbation spreads are measured here from the faces whose box came from the detector.
// Deterministic for a given seed whatever the thread count. Throws core::Error for fewer than
// 2 training faces, landmark counts other than 68, or several λ or rank candidates without validation
// faces.
[[nodiscard]] SdmModel train_sdm(std::span<const TrainingFace> faces, const BoxStatistics& boxes,
                                 const SdmTrainOptions& options);

// The spread of the main cascade's result around the truth as a similarity (translation in box widths,
// scale factor, rotation in degrees), measured on the validation faces from perturbed starts: where the
// realigned second pass starts.
struct RealignResidual {
    int faces = 0;
    double translation_std = 0, scale_std = 0, rotation_std_deg = 0;
};

// Trains `model.realigned_stages` (options.realign_stages of them) on `faces`, which must be the faces
// (and `options` the options) that trained the model's main cascade: each crop is resampled so that the
// similarity from the model's start shape to the truth becomes the identity (the face upright where the
// start expects it), and training starts are spread by the main cascade's residual (measured here)
// times options.realign_spread. Ignores the model's profile cascade (train_view_cascades trains both).
RealignResidual train_realigned_cascade(std::span<const TrainingFace> faces, const SdmTrainOptions& options, SdmModel& model);

// Point-to-point error / inter-ocular distance (outer eye corners) of 68-point shapes.
[[nodiscard]] double landmark_nme(const Eigen::Matrix2Xd& predicted, const Eigen::Matrix2Xd& truth);

}  // namespace facesynth::train
