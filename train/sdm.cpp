#include "train/sdm.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "core/random.h"
#include "train/feature_pca.h"
#include "train/hog.h"
#include "train/image_copies.h"
#include "train/parallel.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>
#include <functional>
#include <iterator>
#include <numbers>
#include <optional>
#include <utility>
#include <vector>

namespace facesynth::train {
namespace {

// Rng streams local to training initialisations (one per augmentation index).
constexpr std::uint64_t kInitStreamBase = 0x5344'4d00;  // "SDM"
constexpr std::size_t kChunkRows = 1024;
// Added to the seed for the realigned cascade's training starts.
constexpr std::uint64_t kRealignSeedOffset = 0x7265'616c;  // "real"

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Adds L·Lᵀ to the lower triangle of `product` (size × size), where `lines(begin, count)` is the block
// of `count` rows of L from row `begin`. Computed in fixed square tiles of kGramTile rows, one product
// per tile on `threads` threads: each entry's arithmetic, and so the result, is the same for any
// thread count (Eigen's own products run on one thread here). Tiles on the diagonal are filled whole.
constexpr Eigen::Index kGramTile = 512;

template <typename Lines>
void add_lower_gram(Eigen::MatrixXf& product, Eigen::Index size, int threads, const Lines& lines) {
    const Eigen::Index tiles = (size + kGramTile - 1) / kGramTile;
    std::vector<std::pair<Eigen::Index, Eigen::Index>> lower;
    for (Eigen::Index i = 0; i < tiles; ++i)
        for (Eigen::Index j = 0; j <= i; ++j) lower.emplace_back(i, j);
    parallel_for(0, lower.size(), threads, [&](std::size_t t) {
        const Eigen::Index i0 = lower[t].first * kGramTile, j0 = lower[t].second * kGramTile;
        const Eigen::Index ni = std::min(kGramTile, size - i0), nj = std::min(kGramTile, size - j0);
        product.block(i0, j0, ni, nj).noalias() += lines(i0, ni) * lines(j0, nj).transpose();
    });
}

struct Similarity {
    double scale = 1, rotation = 0;  // rotation in radians
    Eigen::Vector2d translation = Eigen::Vector2d::Zero();

    [[nodiscard]] Eigen::Matrix2d linear() const { return scale * Eigen::Rotation2Dd(rotation).toRotationMatrix(); }
    // `shape` turned and scaled about its centroid, then moved.
    [[nodiscard]] Eigen::Matrix2Xd apply_about_centroid(const Eigen::Matrix2Xd& shape) const {
        const Eigen::Vector2d centre = shape.rowwise().mean();
        return (linear() * (shape.colwise() - centre)).colwise() + (centre + translation);
    }
};

// Least-squares similarity taking `from` onto `to` (about their centroids).
Similarity fit_similarity(const Eigen::Matrix2Xd& from, const Eigen::Matrix2Xd& to) {
    const Eigen::Vector2d cf = from.rowwise().mean(), ct = to.rowwise().mean();
    const Eigen::Matrix2Xd f = from.colwise() - cf, t = to.colwise() - ct;
    const double norm = f.squaredNorm();
    const double a = (f.array() * t.array()).sum() / norm;
    const double b = (f.row(0).array() * t.row(1).array() - f.row(1).array() * t.row(0).array()).sum() / norm;
    return {std::hypot(a, b), std::atan2(b, a), ct - cf};
}

// x -> linear·x + offset: the similarity from `from` to `to` as a map of points (fit_similarity turns
// about the centroid of `from`).
struct SimilarityMap {
    Eigen::Matrix2d linear;
    Eigen::Vector2d offset;

    [[nodiscard]] Eigen::Matrix2Xd apply(const Eigen::Matrix2Xd& shape) const { return (linear * shape).colwise() + offset; }
    [[nodiscard]] Eigen::Matrix2Xd apply_inverse(const Eigen::Matrix2Xd& shape) const {
        return linear.inverse() * (shape.colwise() - offset);
    }
    // The crop resampled so that its pixel at x shows what `crop` has at linear·x + offset: a shape that
    // `from` reaches in `crop` through the map sits where `from` is in the result.
    [[nodiscard]] cv::Mat resample(const cv::Mat& crop) const {
        const cv::Mat affine = (cv::Mat_<double>(2, 3) << linear(0, 0), linear(0, 1), offset.x(), linear(1, 0), linear(1, 1), offset.y());
        cv::Mat out;
        cv::warpAffine(crop, out, affine, crop.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
        return out;
    }
};

SimilarityMap similarity_map(const Eigen::Matrix2Xd& from, const Eigen::Matrix2Xd& to) {
    const Similarity s = fit_similarity(from, to);
    SimilarityMap map;
    map.linear = s.linear();
    const Eigen::Vector2d centre = from.rowwise().mean();
    map.offset = centre + s.translation - map.linear * centre;
    return map;
}

// A training start: the cascade's start for the face's view moved by a similarity drawn from the box
// statistics' spreads; depends only on (seed, face, augmentation index).
Eigen::Matrix2Xd perturbed_start(const SdmModel& model, const TrainingFace& face, std::uint64_t seed, std::size_t face_index,
                                 std::size_t augmentation) {
    const BoxStatistics& boxes = model.boxes;
    core::Rng rng(seed, face_index, kInitStreamBase + augmentation);
    Similarity s;
    s.scale = 1 + boxes.init_scale_std * rng.normal();
    s.rotation = boxes.init_rotation_std_deg * rng.normal() * std::numbers::pi / 180.0;
    // One draw per statement, y before x: the order GCC chose when they were one expression (the
    // order of draws within one expression is the compiler's), so GCC builds keep their models.
    const double dy = rng.normal();
    const double dx = rng.normal();
    s.translation = Eigen::Vector2d(dx, dy) * boxes.init_translation_std * kCanonicalBoxWidth;
    return s.apply_about_centroid(model.initial_shape(face.view));
}

double standard_deviation(const std::vector<double>& values) {
    if (values.size() < 2) return 0;
    double mean = 0;
    for (double v : values) mean += v;
    mean /= static_cast<double>(values.size());
    double sum = 0;
    for (double v : values) sum += (v - mean) * (v - mean);
    return std::sqrt(sum / static_cast<double>(values.size() - 1));
}

void apply_update(Eigen::Matrix2Xd& shape, const float* delta, const ShapeUnit& unit) {
    const double length = unit.of(shape);
    for (Eigen::Index i = 0; i < shape.cols(); ++i) {
        shape(0, i) += length * delta[2 * i];
        shape(1, i) += length * delta[2 * i + 1];
    }
}

// Ridge solution X of (S + λI) X = rhs for a centred scatter S (the features' in primal form, the
// rows' Gram matrix in dual form), or on S's leading eigenpairs with feature PCA; λ = factor · ‖S‖ / n,
// with ‖S‖ taken over the kept eigenvalues under PCA.
Eigen::MatrixXd ridge_solution(const Eigen::MatrixXd& scatter, const std::optional<LeadingEigenpairs>& pca,
                               const Eigen::MatrixXd& rhs, double factor, double n, double& lambda) {
    if (pca) {
        lambda = factor * pca->values.norm() / n;
        return projected_ridge(*pca, rhs, lambda);
    }
    lambda = factor * scatter.norm() / n;
    Eigen::MatrixXd regularised = scatter;
    regularised.diagonal().array() += lambda;
    return regularised.llt().solve(rhs);
}

}  // namespace

std::vector<SdmStageSettings> default_stage_settings(int stages, int jaw_features_from, std::span<const double> patch_sides) {
    static constexpr double kRelative[] = {1.0, 0.7, 0.4, 0.25, 0.2, 0.15, 0.12, 0.1};
    static constexpr int kCells[] = {8, 7, 6, 5, 5, 5, 5, 5};
    if (stages < 1 || stages > 8) throw core::Error("SDM: stages must be between 1 and 8, got " + std::to_string(stages));
    std::vector<SdmStageSettings> settings;
    settings.reserve(static_cast<std::size_t>(stages));
    for (int k = 0; k < stages; ++k) settings.push_back({kRelative[k], kCells[k], k + 1 >= jaw_features_from});
    if (patch_sides.empty()) return settings;
    if (patch_sides.size() != settings.size())
        throw core::Error("SDM: --patch-sizes gives " + std::to_string(patch_sides.size()) + " patch sides for " + std::to_string(stages) + " stages");
    for (std::size_t k = 0; k < settings.size(); ++k) {
        if (!(patch_sides[k] > 0 && patch_sides[k] <= 2))
            throw core::Error("SDM: --patch-sizes: stage " + std::to_string(k + 1) + "'s patch side must be in (0, 2] inter-eye-centre distances");
        settings[k].patch_relative = patch_sides[k];
    }
    return settings;
}

int feature_landmark_count(const SdmStageSettings& stage) {
    return stage.jaw_features ? morph::kNumIbugLandmarks : morph::kNumIbugLandmarks - morph::kNumJawLandmarks;
}

double ShapeUnit::of(const Eigen::Matrix2Xd& shape) const {
    return kind == ShapeUnitKind::kFixed ? fixed_length : morph::inter_eye_centre_distance(shape);
}

int SdmModel::feature_dims(const SdmStageSettings& stage) const {
    return feature_landmark_count(stage) * hog.dims();
}

const Eigen::Matrix2Xd& SdmModel::initial_shape(FaceView view) const {
    const auto& own = view_mean_shapes[static_cast<std::size_t>(view)];
    return own.size() ? own : mean_shape;
}

void sdm_features(const cv::Mat& crop, const Eigen::Matrix2Xd& shape, const HogLayout& hog, const SdmStageSettings& stage,
                  const ShapeUnit& unit, std::span<float> out) {
    const int per_landmark = hog.dims();
    const Eigen::Index first = stage.jaw_features ? 0 : morph::kNumJawLandmarks;  // the jaw points are iBUG 1-17
    if (out.size() != static_cast<std::size_t>((shape.cols() - first) * per_landmark))
        throw core::Error("sdm_features: output size mismatch");
    const double side = stage.patch_relative * unit.of(shape);
    cv::Mat patch;
    for (Eigen::Index i = first; i < shape.cols(); ++i) {
        extract_patch(crop, shape.col(i), side, hog.cells, stage.cell_size, patch);
        compute_hog(patch, hog, stage.cell_size,
                    out.subspan(static_cast<std::size_t>(i - first) * per_landmark, static_cast<std::size_t>(per_landmark)));
    }
}

Eigen::Matrix2Xd sdm_refine(std::span<const SdmStage> stages, const HogLayout& hog, const ShapeUnit& unit, const cv::Mat& crop, Eigen::Matrix2Xd shape,
                            std::vector<Eigen::Matrix2Xd>* after_each_stage) {
    Eigen::VectorXf features, reduced, delta;
    for (const auto& stage : stages) {
        features.resize(feature_landmark_count(stage.settings) * hog.dims());
        sdm_features(crop, shape, hog, stage.settings, unit, {features.data(), static_cast<std::size_t>(features.size())});
        reduced.noalias() = stage.weights * features;
        delta.noalias() = stage.basis * reduced;
        delta += stage.bias;
        apply_update(shape, delta.data(), unit);
        if (after_each_stage) after_each_stage->push_back(shape);
    }
    return shape;
}

Eigen::Matrix2Xd sdm_refine(const SdmModel& model, const cv::Mat& crop, Eigen::Matrix2Xd shape,
                            std::vector<Eigen::Matrix2Xd>* after_each_stage) {
    return sdm_refine(model.stages, model.hog, model.unit, crop, std::move(shape), after_each_stage);
}

namespace {

// One view's cascade: its main stages and those of its realigned second pass (empty: none).
struct CascadeStages {
    std::span<const SdmStage> main, realigned;
};
using CascadeRun = std::function<Eigen::Matrix2Xd(const CascadeStages& stages, const cv::Mat& crop, const Eigen::Matrix2Xd& start)>;

// `run` with the cascade and start shape that serve `view`.
Eigen::Matrix2Xd run_for_view(const SdmModel& model, const cv::Mat& crop, FaceView view, const CascadeRun& run) {
    if (!model.profile || view == FaceView::kFrontal) return run({model.stages, model.realigned_stages}, crop, model.initial_shape(view));
    const ProfileCascade& profile = *model.profile;
    const CascadeStages stages{profile.stages, profile.realigned_stages};
    if (view == FaceView::kNoseLeft) return run(stages, crop, profile.mean_shape);
    cv::Mat mirrored;
    cv::flip(crop, mirrored, 1);
    return mirror_canonical_shape(run(stages, mirrored, profile.mean_shape));
}

// SdmInference::realign: `second` runs on the realigned crop (the main cascade again where the model
// has no realigned one).
Eigen::Matrix2Xd refine_realigned(std::span<const SdmStage> stages, std::span<const SdmStage> second, const HogLayout& hog, const ShapeUnit& unit,
                                  const cv::Mat& crop, const Eigen::Matrix2Xd& start) {
    const Eigen::Matrix2Xd first = sdm_refine(stages, hog, unit, crop, start);
    const SimilarityMap to_first = similarity_map(start, first);
    const Eigen::Matrix2Xd realigned = sdm_refine(second.empty() ? stages : second, hog, unit, to_first.resample(crop), start);
    return 0.5 * (first + to_first.apply(realigned));
}

}  // namespace

Eigen::Matrix2Xd sdm_refine_view(const SdmModel& model, const cv::Mat& crop, FaceView view, const SdmInference& inference) {
    const CascadeRun run = [&](const CascadeStages& stages, const cv::Mat& c, const Eigen::Matrix2Xd& start) {
        return inference.realign ? refine_realigned(stages.main, stages.realigned, model.hog, model.unit, c, start)
                                 : sdm_refine(stages.main, model.hog, model.unit, c, start);
    };
    Eigen::Matrix2Xd direct = run_for_view(model, crop, view, run);
    if (!inference.mirror || (model.profile && view != FaceView::kFrontal)) return direct;
    cv::Mat mirrored;
    cv::flip(crop, mirrored, 1);
    const Eigen::Matrix2Xd from_mirror =
        mirror_canonical_shape(run({model.stages, model.realigned_stages}, mirrored, mirror_canonical_shape(model.initial_shape(view))));
    return 0.5 * (direct + from_mirror);
}

Eigen::Matrix2Xd sdm_detect(const SdmModel& model, const cv::Mat& gray, const FaceBox& box, const SdmInference& inference) {
    const FaceFrame frame{box};
    return frame.to_image(sdm_refine_view(model, canonical_crop(gray, frame), box.view, inference));
}

Eigen::Matrix2Xd mirror_canonical_shape(const Eigen::Matrix2Xd& shape) {
    const auto partner = morph::ibug_mirror_pairs();
    if (shape.cols() != static_cast<Eigen::Index>(partner.size()))
        throw core::Error("mirror_canonical_shape: expected " + std::to_string(partner.size()) + " points, got " +
                    std::to_string(shape.cols()));
    Eigen::Matrix2Xd mirrored(2, shape.cols());
    for (Eigen::Index i = 0; i < shape.cols(); ++i) {
        const Eigen::Index from = partner[static_cast<std::size_t>(i)];
        mirrored(0, i) = (kCanonicalCropSide - 1) - shape(0, from);
        mirrored(1, i) = shape(1, from);
    }
    return mirrored;
}

TrainingFace mirror_training_face(const TrainingFace& face) {
    TrainingFace mirrored;
    cv::flip(face.crop, mirrored.crop, 1);
    mirrored.truth = mirror_canonical_shape(face.truth);
    mirrored.box_from_detector = face.box_from_detector;
    mirrored.photograph = face.photograph;
    mirrored.view = face.view == FaceView::kNoseLeft    ? FaceView::kNoseRight
                    : face.view == FaceView::kNoseRight ? FaceView::kNoseLeft
                                                        : FaceView::kFrontal;
    if (face.yaw_deg) mirrored.yaw_deg = -*face.yaw_deg;
    return mirrored;
}

double landmark_nme(const Eigen::Matrix2Xd& predicted, const Eigen::Matrix2Xd& truth) {
    return (predicted - truth).colwise().norm().mean() / morph::inter_ocular_distance(truth);
}

namespace {

void validate_options(const SdmTrainOptions& options) {
    if (options.augment < 1) throw core::Error("SDM training: --augment must be at least 1");
    if (options.image_copies < 0 || options.image_copies > kMaxImageCopies)
        throw core::Error("SDM training: --image-copies must be between 0 and " + std::to_string(kMaxImageCopies) + ", got " +
                          std::to_string(options.image_copies));
    if (options.lambda_factors.empty()) throw core::Error("SDM training: no λ factor given");
    if (options.hog.cells < 1 || options.hog.cells > kMaxHogCells || options.hog.orientations < 1 ||
        options.hog.orientations > kMaxHogOrientations)
        throw core::Error("SDM training: HOG cells must be 1-" + std::to_string(kMaxHogCells) + " and orientations 1-" +
                          std::to_string(kMaxHogOrientations) + ", got " + std::to_string(options.hog.cells) + " and " +
                          std::to_string(options.hog.orientations));
    for (double f : options.lambda_factors)
        if (!(f > 0) || !std::isfinite(f)) throw core::Error("SDM training: λ factors must be positive");
    if (options.ranks.empty()) throw core::Error("SDM training: no rank candidate given");
    if (options.feature_components < 0 || options.feature_components > morph::kNumIbugLandmarks * options.hog.dims())
        throw core::Error("SDM training: --feature-pca must be between 0 and the feature dimension " +
                    std::to_string(morph::kNumIbugLandmarks * options.hog.dims()) + ", got " +
                    std::to_string(options.feature_components));
    for (int r : options.ranks)
        if (r < 1 || r > 2 * morph::kNumIbugLandmarks)
            throw core::Error("SDM training: ranks must be between 1 and " + std::to_string(2 * morph::kNumIbugLandmarks));
    if (options.validation_share < 0 || options.validation_share >= 1)
        throw core::Error("SDM training: the validation share must be in [0, 1)");
}

// Held-out validation faces: every k-th one.
TrainingRows split_faces(std::size_t count, const SdmTrainOptions& options) {
    TrainingRows split;
    const std::size_t stride =
        options.validation_share > 0 ? static_cast<std::size_t>(std::max(2.0, std::round(1 / options.validation_share))) : 0;
    for (std::size_t f = 0; f < count; ++f) (stride && f % stride == stride - 1 ? split.validation : split.train).push_back(f);
    if (split.train.size() < 2)
        throw core::Error("SDM training needs at least 2 training faces, got " + std::to_string(split.train.size()));
    const bool choose = options.lambda_factors.size() > 1 || options.ranks.size() > 1;
    if (choose && split.validation.empty())
        throw core::Error("SDM training: choosing among " + std::to_string(options.lambda_factors.size()) + " λ factors and " +
                    std::to_string(options.ranks.size()) +
                    " ranks needs validation faces (more faces or a larger validation share)");
    return split;
}

// The mean shape in the box frame is the learned box-to-shape alignment: averaged over the training
// faces whose box came from the detector (all training faces if there are none), overall and per
// detector view. The spread of the true shapes around their start (detector faces only) becomes the
// initialisation noise in model.boxes.
void learn_starts(std::span<const TrainingFace> faces, std::span<const std::size_t> train_faces, const BoxStatistics& boxes,
                  SdmModel& model) {
    model.boxes = boxes;
    const bool have_detector_faces =
        std::any_of(train_faces.begin(), train_faces.end(), [&](std::size_t f) { return faces[f].box_from_detector; });
    const auto shapes_the_mean = [&](std::size_t f) { return !have_detector_faces || faces[f].box_from_detector; };
    const auto view_index = [&](std::size_t f) { return static_cast<std::size_t>(faces[f].view); };
    model.mean_shape = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks);
    std::array<Eigen::Matrix2Xd, kFaceViews> view_sums;
    view_sums.fill(Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks));
    std::array<int, kFaceViews> view_used{};
    int used = 0;
    for (std::size_t f : train_faces) {
        ++model.view_faces[view_index(f)];
        if (!shapes_the_mean(f)) continue;
        model.mean_shape += faces[f].truth;
        view_sums[view_index(f)] += faces[f].truth;
        ++view_used[view_index(f)];
        ++used;
    }
    model.mean_shape /= used;
    for (std::size_t v = 0; v < kFaceViews; ++v)
        if (view_used[v] >= kMinViewFaces && view_used[v] < used) model.view_mean_shapes[v] = view_sums[v] / view_used[v];

    std::vector<double> dx, dy, scales, rotations;
    for (std::size_t f : train_faces) {
        if (!shapes_the_mean(f)) continue;
        const Similarity s = fit_similarity(model.initial_shape(faces[f].view), faces[f].truth);
        dx.push_back(s.translation.x() / kCanonicalBoxWidth);
        dy.push_back(s.translation.y() / kCanonicalBoxWidth);
        scales.push_back(s.scale);
        rotations.push_back(s.rotation * 180.0 / std::numbers::pi);
    }
    if (used >= 10) {
        model.boxes.init_translation_std = std::sqrt(0.5 * (std::pow(standard_deviation(dx), 2) + std::pow(standard_deviation(dy), 2)));
        model.boxes.init_scale_std = standard_deviation(scales);
        model.boxes.init_rotation_std_deg = standard_deviation(rotations);
    }
}

// One (λ factor, rank) pair of a stage and its validation NME.
struct Candidate {
    double nme;
    std::size_t factor_index;
    int rank;
};

// The smallest rank within `tolerance` (relative) of the best validation NME, the lower NME among equals.
const Candidate& choose_candidate(std::span<const Candidate> candidates, double tolerance) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& c : candidates) best = std::min(best, c.nme);
    const Candidate* chosen = nullptr;
    for (const auto& c : candidates) {
        if (c.nme > best * (1 + tolerance)) continue;
        if (!chosen || c.rank < chosen->rank || (c.rank == chosen->rank && c.nme < chosen->nme)) chosen = &c;
    }
    return *chosen;
}

// The cascade's training rows (`augment` perturbed starts per face, training faces first, then
// validation faces) and the stages learned on them, one after the other.
class CascadeTrainer {
public:
    CascadeTrainer(std::span<const TrainingFace> faces, const TrainingRows& split, const SdmTrainOptions& options, SdmModel& model,
                   std::span<const SdmStageSettings> settings)
        : faces_(faces), options_(options), model_(model) {
        // A start depends only on (seed, face index, augmentation index).
        const auto augment = static_cast<std::size_t>(options.augment);
        train_rows_ = split.train.size() * augment;
        validation_rows_ = split.validation.size() * augment;
        const std::size_t rows = train_rows_ + validation_rows_;
        row_face_.resize(rows);
        for (std::size_t r = 0; r < rows; ++r)
            row_face_[r] = r < train_rows_ ? split.train[r / augment] : split.validation[(r - train_rows_) / augment];
        shapes_.resize(rows);
        for (std::size_t r = 0; r < rows; ++r)
            shapes_[r] = perturbed_start(model, faces[row_face_[r]], options.seed, row_face_[r], r % augment);
        for (const auto& stage : settings)
            total_feature_rows_ +=
                train_rows_ * (train_rows_ < static_cast<std::size_t>(model.feature_dims(stage)) ? 1 : 2) + validation_rows_;
    }

    // Learns stage k (0-based) with `settings`, applies it to every row and appends it to the model.
    void train_stage(std::size_t k, const SdmStageSettings& settings);

private:
    // The full-rank ridge solution for one λ factor: W (2L x D) and b.
    struct FullSolution {
        Eigen::MatrixXf weights;
        Eigen::VectorXf bias;
    };

    // One stage's ridge regression from the training rows' features to their targets, reduced to what
    // solving it for a λ factor needs: in dual form (fewer rows than features) or primal form.
    struct RidgeProblem {
        bool dual = false;
        double rows = 0;
        RowMatrixXf features;               // dual: the centred training features, kept for the update
        Eigen::RowVectorXf feature_offset;  // dual: the features' mean; primal: the first chunk's (the shift)
        Eigen::MatrixXd scatter;            // dual: A_c A_cᵀ; primal: A_cᵀ A_c (centred)
        Eigen::MatrixXd right_side;         // dual: Y_c; primal: A_cᵀ Y_c
        Eigen::VectorXd feature_mean;       // primal: the shifted features' mean
        Eigen::RowVectorXd target_mean;
        Eigen::MatrixXd target_scatter;     // centred Yᵀ Y of the training rows, 2L x 2L
        std::optional<LeadingEigenpairs> feature_pca;

        [[nodiscard]] FullSolution solve(double factor, double& lambda) const;
    };

    // The chosen stage (λ factor and rank by held-out NME when there is a choice) and its report fields.
    struct ChosenStage {
        SdmStage stage;
        double lambda_factor = 0, lambda = 0;
        int rank = 0;
    };

    [[nodiscard]] RidgeProblem dual_problem(const SdmStageSettings& settings, std::uint64_t pca_seed);
    [[nodiscard]] RidgeProblem primal_problem(const SdmStageSettings& settings, std::uint64_t pca_seed);
    [[nodiscard]] ChosenStage choose_stage(std::size_t k, const RidgeProblem& problem, const RowMatrixXf& validation_features,
                                           const SdmStageSettings& settings) const;
    // Moves every row's shape by the stage (the training rows' features recomputed chunk by chunk in primal form).
    void apply_stage(const SdmStage& stage, RidgeProblem& problem, const RowMatrixXf& validation_features, const SdmStageSettings& settings);

    [[nodiscard]] const TrainingFace& face_of(std::size_t row) const { return faces_[row_face_[row]]; }

    [[nodiscard]] double mean_nme(std::size_t first, std::size_t count) const {
        double sum = 0;
        for (std::size_t r = first; r < first + count; ++r) sum += landmark_nme(shapes_[r], face_of(r).truth);
        return count ? sum / static_cast<double>(count) : 0.0;
    }

    void extract_rows(std::size_t first, std::size_t count, const SdmStageSettings& stage, RowMatrixXf& out) {
        out.resize(static_cast<Eigen::Index>(count), dims_);
        parallel_for(0, count, options_.threads, [&](std::size_t i) {
            sdm_features(face_of(first + i).crop, shapes_[first + i], model_.hog, stage, model_.unit,
                         {out.row(static_cast<Eigen::Index>(i)).data(), static_cast<std::size_t>(dims_)});
        });
        feature_rows_done_ += count;
        if (options_.on_progress) options_.on_progress(feature_rows_done_, total_feature_rows_);
    }

    // Normalised shape updates (truth − start) / the shape unit of rows [first, first + count).
    [[nodiscard]] Eigen::MatrixXd targets(std::size_t first, std::size_t count) const {
        Eigen::MatrixXd y(static_cast<Eigen::Index>(count), kOutputs);
        for (std::size_t i = 0; i < count; ++i) {
            const auto& shape = shapes_[first + i];
            const Eigen::Matrix2Xd delta = (face_of(first + i).truth - shape) / model_.unit.of(shape);
            y.row(static_cast<Eigen::Index>(i)) = Eigen::Map<const Eigen::RowVectorXd>(delta.data(), kOutputs);
        }
        return y;
    }

    // Applies a stage to rows [first, first + features.rows()).
    void update_rows(std::size_t first, const RowMatrixXf& features, const SdmStage& stage) {
        const RowMatrixXf delta = ((features * stage.weights.transpose()) * stage.basis.transpose()).rowwise() + stage.bias.transpose();
        for (Eigen::Index i = 0; i < delta.rows(); ++i) apply_update(shapes_[first + static_cast<std::size_t>(i)], delta.row(i).data(), model_.unit);
    }

    // Held-out NME after applying the (centred, projected) predictions to the validation starts.
    [[nodiscard]] double validation_nme(const RowMatrixXf& delta) const {
        double sum = 0;
        for (std::size_t i = 0; i < validation_rows_; ++i) {
            Eigen::Matrix2Xd shape = shapes_[train_rows_ + i];
            apply_update(shape, delta.row(static_cast<Eigen::Index>(i)).data(), model_.unit);
            sum += landmark_nme(shape, face_of(train_rows_ + i).truth);
        }
        return sum / static_cast<double>(validation_rows_);
    }

    static constexpr int kOutputs = 2 * morph::kNumIbugLandmarks;

    std::span<const TrainingFace> faces_;
    const SdmTrainOptions& options_;
    SdmModel& model_;
    std::vector<std::size_t> row_face_;
    std::vector<Eigen::Matrix2Xd> shapes_;  // every row's current shape
    std::size_t train_rows_ = 0, validation_rows_ = 0;
    int dims_ = 0;  // of the current stage's features
    std::size_t total_feature_rows_ = 0, feature_rows_done_ = 0;
};

CascadeTrainer::FullSolution CascadeTrainer::RidgeProblem::solve(double factor, double& lambda) const {
    FullSolution full;
    if (dual) {
        const Eigen::MatrixXd alpha = ridge_solution(scatter, feature_pca, right_side, factor, rows, lambda);
        full.weights = (features.transpose() * alpha.cast<float>()).transpose();
        full.bias = target_mean.transpose().cast<float>() - full.weights * feature_offset.transpose();
    } else {
        const Eigen::MatrixXd w = ridge_solution(scatter, feature_pca, right_side, factor, rows, lambda);
        full.weights = w.transpose().cast<float>();
        full.bias = (target_mean.transpose() - w.transpose() * (feature_mean + feature_offset.transpose().cast<double>())).cast<float>();
    }
    return full;
}

// Dual form: W = A_cᵀ (A_c A_cᵀ + λI)⁻¹ Y_c, cheaper when there are fewer rows than features.
CascadeTrainer::RidgeProblem CascadeTrainer::dual_problem(const SdmStageSettings& settings, std::uint64_t pca_seed) {
    RidgeProblem p;
    p.dual = true;
    p.rows = static_cast<double>(train_rows_);
    extract_rows(0, train_rows_, settings, p.features);
    const Eigen::MatrixXd y = targets(0, train_rows_);
    p.feature_offset = p.features.colwise().mean();
    p.target_mean = y.colwise().mean();
    p.features.rowwise() -= p.feature_offset;
    Eigen::MatrixXf gram = Eigen::MatrixXf::Zero(p.features.rows(), p.features.rows());
    add_lower_gram(gram, p.features.rows(), options_.threads,
                   [&](Eigen::Index begin, Eigen::Index n) { return p.features.middleRows(begin, n); });
    p.scatter = gram.cast<double>().selfadjointView<Eigen::Lower>();
    p.right_side = y.rowwise() - p.target_mean;
    p.target_scatter = p.right_side.transpose() * p.right_side;
    // The Gram matrix's leading eigenvectors are the features' principal components seen
    // from the rows, with the same eigenvalues (docs/train.md, "Feature PCA").
    if (options_.feature_components > 0)
        p.feature_pca = leading_eigenpairs(p.scatter, std::min<int>(options_.feature_components, static_cast<int>(train_rows_)), pca_seed);
    return p;
}

// Primal form, streamed in chunks: (A_cᵀA_c + λI) W = A_cᵀ Y_c. Features are shifted by the first
// chunk's mean before accumulating so that float sums keep their precision.
CascadeTrainer::RidgeProblem CascadeTrainer::primal_problem(const SdmStageSettings& settings, std::uint64_t pca_seed) {
    RidgeProblem p;
    p.rows = static_cast<double>(train_rows_);
    const double n = p.rows;
    Eigen::MatrixXf gram = Eigen::MatrixXf::Zero(dims_, dims_);
    Eigen::VectorXd sum_x = Eigen::VectorXd::Zero(dims_);
    p.right_side = Eigen::MatrixXd::Zero(dims_, kOutputs);
    Eigen::RowVectorXd sum_y = Eigen::RowVectorXd::Zero(kOutputs);
    p.target_scatter = Eigen::MatrixXd::Zero(kOutputs, kOutputs);
    RowMatrixXf a;
    for (std::size_t first = 0; first < train_rows_; first += kChunkRows) {
        const std::size_t count = std::min(kChunkRows, train_rows_ - first);
        extract_rows(first, count, settings, a);
        if (first == 0) p.feature_offset = a.colwise().mean();
        a.rowwise() -= p.feature_offset;
        const Eigen::MatrixXd y = targets(first, count);
        add_lower_gram(gram, dims_, options_.threads, [&](Eigen::Index begin, Eigen::Index n) { return a.middleCols(begin, n).transpose(); });
        sum_x += a.colwise().sum().transpose().cast<double>();
        p.right_side.noalias() += a.transpose().cast<double>() * y;
        sum_y += y.colwise().sum();
        p.target_scatter.noalias() += y.transpose() * y;
    }
    p.feature_mean = sum_x / n;
    p.target_mean = sum_y / n;
    p.target_scatter.noalias() -= n * p.target_mean.transpose() * p.target_mean;
    p.scatter = gram.cast<double>().selfadjointView<Eigen::Lower>();
    gram.resize(0, 0);
    p.scatter.noalias() -= n * p.feature_mean * p.feature_mean.transpose();
    p.right_side.noalias() -= n * p.feature_mean * p.target_mean;
    if (options_.feature_components > 0) p.feature_pca = leading_eigenpairs(p.scatter, std::min(options_.feature_components, dims_), pca_seed);
    return p;
}

CascadeTrainer::ChosenStage CascadeTrainer::choose_stage(std::size_t k, const RidgeProblem& problem, const RowMatrixXf& validation_features,
                                                         const SdmStageSettings& settings) const {
    const bool choose = options_.lambda_factors.size() > 1 || options_.ranks.size() > 1;
    // Principal directions of the targets, largest variance first.
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(problem.target_scatter);
    const Eigen::MatrixXf principal = eigen.eigenvectors().rowwise().reverse().cast<float>();
    const Eigen::RowVectorXf target_mean = problem.target_mean.cast<float>();
    std::vector<Candidate> candidates;
    // The λ candidates' solves (one Cholesky factorisation of the D×D system each) are independent:
    // one per training thread, each with its own copy of the system.
    const std::size_t factors = options_.lambda_factors.size();
    std::vector<FullSolution> solutions(factors);
    std::vector<double> lambdas(factors, 0.0);
    parallel_for(0, factors, options_.threads,
                 [&](std::size_t f) { solutions[f] = problem.solve(options_.lambda_factors[f], lambdas[f]); });
    for (std::size_t f = 0; f < factors; ++f) {
        const FullSolution& full = solutions[f];
        if (!full.weights.allFinite() || !full.bias.allFinite()) continue;
        if (!choose) {
            candidates.push_back({0.0, f, options_.ranks.front()});
            continue;
        }
        const RowMatrixXf predicted =
            ((validation_features * full.weights.transpose()).rowwise() + full.bias.transpose()).rowwise() - target_mean;
        for (int rank : options_.ranks) {
            const auto p = principal.leftCols(rank);
            const RowMatrixXf delta = ((predicted * p) * p.transpose()).rowwise() + target_mean;
            candidates.push_back({validation_nme(delta), f, rank});
        }
    }
    if (candidates.empty()) throw core::Error("SDM training: stage " + std::to_string(k + 1) + " produced non-finite weights");
    const Candidate& chosen = choose_candidate(candidates, options_.rank_tolerance);
    const FullSolution& full = solutions[chosen.factor_index];
    ChosenStage out;
    out.stage.settings = settings;
    out.stage.basis = principal.leftCols(chosen.rank);
    out.stage.weights = out.stage.basis.transpose() * full.weights;
    // b_r = ȳ − P Pᵀ (ȳ − b), so that b_r + W_r x = ȳ + P Pᵀ (W x + b − ȳ).
    out.stage.bias = target_mean.transpose() - out.stage.basis * (out.stage.basis.transpose() * (target_mean.transpose() - full.bias));
    out.lambda_factor = options_.lambda_factors[chosen.factor_index];
    out.lambda = lambdas[chosen.factor_index];
    out.rank = chosen.rank;
    return out;
}

void CascadeTrainer::apply_stage(const SdmStage& stage, RidgeProblem& problem, const RowMatrixXf& validation_features,
                                 const SdmStageSettings& settings) {
    if (problem.dual) {
        problem.features.rowwise() += problem.feature_offset;  // the features themselves again
        update_rows(0, problem.features, stage);
    } else {
        RowMatrixXf a;
        for (std::size_t first = 0; first < train_rows_; first += kChunkRows) {
            const std::size_t count = std::min(kChunkRows, train_rows_ - first);
            extract_rows(first, count, settings, a);
            update_rows(first, a, stage);
        }
    }
    if (validation_rows_) update_rows(train_rows_, validation_features, stage);
}

void CascadeTrainer::train_stage(std::size_t k, const SdmStageSettings& settings) {
    const auto start = std::chrono::steady_clock::now();
    dims_ = model_.feature_dims(settings);
    SdmStageReport report;
    report.stage = static_cast<int>(k + 1);
    report.nme_before = mean_nme(0, train_rows_);
    report.validation_nme_before = mean_nme(train_rows_, validation_rows_);

    RowMatrixXf validation_features;
    if (validation_rows_) extract_rows(train_rows_, validation_rows_, settings, validation_features);
    const std::uint64_t pca_seed = options_.seed + k;
    RidgeProblem problem = train_rows_ < static_cast<std::size_t>(dims_) ? dual_problem(settings, pca_seed) : primal_problem(settings, pca_seed);
    ChosenStage chosen = choose_stage(k, problem, validation_features, settings);
    report.lambda_factor = chosen.lambda_factor;
    report.lambda = chosen.lambda;
    report.rank = chosen.rank;
    report.feature_components = problem.feature_pca ? static_cast<int>(problem.feature_pca->values.size()) : 0;
    apply_stage(chosen.stage, problem, validation_features, settings);

    report.nme_after = mean_nme(0, train_rows_);
    report.validation_nme_after = mean_nme(train_rows_, validation_rows_);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    model_.stages.push_back(std::move(chosen.stage));
    if (options_.on_stage) options_.on_stage(report);
}

}  // namespace

TrainingRows training_rows(std::span<const TrainingFace> faces, const SdmTrainOptions& options) {
    validate_options(options);
    TrainingRows rows = split_faces(faces.size(), options);
    if (!options.mirror && options.image_copies == 0) return rows;
    rows.extended.assign(faces.begin(), faces.end());
    const std::vector<std::size_t> originals = rows.train;
    const auto add = [&rows](TrainingFace face) {
        rows.extended.push_back(std::move(face));
        rows.train.push_back(rows.extended.size() - 1);
    };
    if (options.mirror)
        for (const std::size_t f : originals) add(mirror_training_face(faces[f]));
    std::vector<std::size_t> photographs;
    std::copy_if(originals.begin(), originals.end(), std::back_inserter(photographs), [&](std::size_t f) { return faces[f].photograph; });
    const auto copies_per_face = static_cast<std::size_t>(options.image_copies);
    std::vector<TrainingFace> copies(photographs.size() * copies_per_face);
    parallel_for(0, copies.size(), options.threads, [&](std::size_t i) {
        const std::size_t f = photographs[i % photographs.size()];
        copies[i] = moved_and_degraded_copy(faces[f], options.seed, f, static_cast<int>(i / photographs.size()));
    });
    for (TrainingFace& copy : copies) add(std::move(copy));
    return rows;
}

SdmModel train_sdm(std::span<const TrainingFace> faces, const BoxStatistics& boxes, const SdmTrainOptions& options) {
    for (const auto& f : faces)
        if (f.truth.cols() != morph::kNumIbugLandmarks) throw core::Error("SDM training needs 68-point landmarks");
    validate_options(options);
    const auto settings = options.stage_settings.empty() ? default_stage_settings(options.stages, options.jaw_features_from)
                                                         : options.stage_settings;
    const TrainingRows training = training_rows(faces, options);
    const TrainingRows& split = training;
    const std::span<const TrainingFace> rows = training.faces(faces);

    SdmModel model;
    model.num_landmarks = morph::kNumIbugLandmarks;
    model.hog = options.hog;
    model.training_faces = static_cast<std::uint32_t>(faces.size());
    model.augment = static_cast<std::uint32_t>(options.augment);
    learn_starts(rows, split.train, boxes, model);
    model.unit.kind = options.unit;
    if (options.unit == ShapeUnitKind::kFixed)
        model.unit.fixed_length = options.fixed_unit_length > 0 ? options.fixed_unit_length : morph::inter_eye_centre_distance(model.mean_shape);

    CascadeTrainer trainer(rows, split, options, model, settings);
    for (std::size_t k = 0; k < settings.size(); ++k) trainer.train_stage(k, settings[k]);
    return model;
}

RealignResidual train_realigned_cascade(std::span<const TrainingFace> faces, const SdmTrainOptions& options, SdmModel& model) {
    validate_options(options);
    if (options.realign_stages < 1 || options.realign_stages > static_cast<int>(model.stages.size()))
        throw core::Error("SDM training: the realigned cascade's stages must be between 1 and the main cascade's " +
                          std::to_string(model.stages.size()) + ", got " + std::to_string(options.realign_stages));
    if (!(options.realign_spread > 0) || !std::isfinite(options.realign_spread))
        throw core::Error("SDM training: the realigned cascade's start spread must be positive");
    const TrainingRows training = training_rows(faces, options);
    const std::span<const TrainingFace> rows = training.faces(faces);

    // The main cascade's residual as a similarity in the realigned frame, from the starts it trained on.
    const std::vector<std::size_t>& measured = training.validation.empty() ? training.train : training.validation;
    const auto augment = static_cast<std::size_t>(options.augment);
    std::vector<double> dx(measured.size() * augment), dy(dx.size()), scales(dx.size()), rotations(dx.size());
    parallel_for(0, dx.size(), options.threads, [&](std::size_t i) {
        const std::size_t f = measured[i / augment];
        const TrainingFace& face = rows[f];
        const Eigen::Matrix2Xd& start = model.initial_shape(face.view);
        const Eigen::Matrix2Xd first = sdm_refine(model, face.crop, perturbed_start(model, face, options.seed, f, i % augment));
        const Similarity residual = fit_similarity(start, similarity_map(start, first).apply_inverse(face.truth));
        dx[i] = residual.translation.x() / kCanonicalBoxWidth;
        dy[i] = residual.translation.y() / kCanonicalBoxWidth;
        scales[i] = residual.scale;
        rotations[i] = residual.rotation * 180.0 / std::numbers::pi;
    });
    RealignResidual spread;
    spread.faces = static_cast<int>(measured.size());
    spread.translation_std = std::sqrt(0.5 * (std::pow(standard_deviation(dx), 2) + std::pow(standard_deviation(dy), 2)));
    spread.scale_std = standard_deviation(scales);
    spread.rotation_std_deg = standard_deviation(rotations);

    // Every face upright where the start expects it: the similarity from the start to the truth undone.
    std::vector<TrainingFace> upright(rows.begin(), rows.end());
    parallel_for(0, upright.size(), options.threads, [&](std::size_t f) {
        const SimilarityMap to_truth = similarity_map(model.initial_shape(upright[f].view), upright[f].truth);
        upright[f].crop = to_truth.resample(upright[f].crop);
        upright[f].truth = to_truth.apply_inverse(upright[f].truth);
    });

    SdmModel second = model;
    second.stages.clear();
    second.realigned_stages.clear();
    second.boxes.init_translation_std = options.realign_spread * spread.translation_std;
    second.boxes.init_scale_std = options.realign_spread * spread.scale_std;
    second.boxes.init_rotation_std_deg = options.realign_spread * spread.rotation_std_deg;
    SdmTrainOptions second_options = options;
    second_options.seed = options.seed + kRealignSeedOffset;  // starts drawn apart from the main cascade's
    std::vector<SdmStageSettings> settings(static_cast<std::size_t>(options.realign_stages));
    for (std::size_t k = 0; k < settings.size(); ++k) settings[k] = model.stages[k].settings;
    CascadeTrainer trainer(upright, training, second_options, second, settings);
    for (std::size_t k = 0; k < settings.size(); ++k) trainer.train_stage(k, settings[k]);
    model.realigned_stages = std::move(second.stages);
    return spread;
}

}  // namespace facesynth::train
