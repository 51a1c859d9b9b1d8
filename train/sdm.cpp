#include "train/sdm.h"

#include "morph/error.h"
#include "morph/landmarks.h"
#include "morph/random.h"
#include "train/hog.h"
#include "train/parallel.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include <chrono>
#include <cmath>
#include <numbers>

namespace facesynth::train {
namespace {

// Rng streams local to training initialisations (one per augmentation index).
constexpr std::uint64_t kInitStreamBase = 0x5344'4d00;  // "SDM"
constexpr std::size_t kChunkRows = 1024;

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Similarity {
    double scale = 1, rotation = 0;  // rotation in radians
    Eigen::Vector2d translation = Eigen::Vector2d::Zero();
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

Eigen::Matrix2Xd apply_similarity(const Eigen::Matrix2Xd& shape, const Similarity& s) {
    const Eigen::Vector2d centre = shape.rowwise().mean();
    Eigen::Matrix2d r;
    r << std::cos(s.rotation), -std::sin(s.rotation), std::sin(s.rotation), std::cos(s.rotation);
    return ((s.scale * r) * (shape.colwise() - centre)).colwise() + (centre + s.translation);
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

void apply_update(Eigen::Matrix2Xd& shape, const float* delta) {
    const double ied = inter_eye_centre_distance(shape);
    for (Eigen::Index i = 0; i < shape.cols(); ++i) {
        shape(0, i) += ied * delta[2 * i];
        shape(1, i) += ied * delta[2 * i + 1];
    }
}

}  // namespace

std::vector<SdmStageSettings> default_stage_settings(int stages) {
    static constexpr double kRelative[] = {1.0, 0.7, 0.4, 0.25, 0.2, 0.15, 0.12, 0.1};
    static constexpr int kCells[] = {8, 7, 6, 5, 5, 5, 5, 5};
    if (stages < 1 || stages > 8) throw Error("SDM: stages must be between 1 and 8, got " + std::to_string(stages));
    std::vector<SdmStageSettings> settings;
    for (int k = 0; k < stages; ++k) settings.push_back({kRelative[k], kCells[k]});
    return settings;
}

int SdmModel::feature_dims() const { return num_landmarks * hog_dims(hog_cells); }

void sdm_features(const cv::Mat& crop, const Eigen::Matrix2Xd& shape, int hog_cells, const SdmStageSettings& stage,
                  std::span<float> out) {
    const int per_landmark = hog_dims(hog_cells);
    const double side = stage.patch_relative * inter_eye_centre_distance(shape);
    cv::Mat patch;
    for (Eigen::Index i = 0; i < shape.cols(); ++i) {
        extract_patch(crop, shape.col(i), side, hog_cells, stage.cell_size, patch);
        compute_hog(patch, hog_cells, stage.cell_size,
                    out.subspan(static_cast<std::size_t>(i) * per_landmark, static_cast<std::size_t>(per_landmark)));
    }
}

Eigen::Matrix2Xd sdm_refine(const SdmModel& model, const cv::Mat& crop, Eigen::Matrix2Xd shape,
                            std::vector<Eigen::Matrix2Xd>* after_each_stage) {
    Eigen::VectorXf features(model.feature_dims());
    Eigen::VectorXf delta;
    for (const auto& stage : model.stages) {
        sdm_features(crop, shape, model.hog_cells, stage.settings, {features.data(), static_cast<std::size_t>(features.size())});
        delta.noalias() = stage.weights * features;
        delta += stage.bias;
        apply_update(shape, delta.data());
        if (after_each_stage) after_each_stage->push_back(shape);
    }
    return shape;
}

Eigen::Matrix2Xd sdm_detect(const SdmModel& model, const cv::Mat& gray, const FaceBox& box) {
    const FaceFrame frame{box};
    return frame.to_image(sdm_refine(model, canonical_crop(gray, frame), model.mean_shape));
}

double landmark_nme(const Eigen::Matrix2Xd& predicted, const Eigen::Matrix2Xd& truth) {
    return (predicted - truth).colwise().norm().mean() / inter_ocular_distance(truth);
}

SdmModel train_sdm(std::span<const TrainingFace> faces, BoxStatistics boxes, const SdmTrainOptions& options) {
    if (faces.size() < 2) throw Error("SDM training needs at least 2 faces, got " + std::to_string(faces.size()));
    for (const auto& f : faces)
        if (f.truth.cols() != kNumIbugLandmarks) throw Error("SDM training needs 68-point landmarks");
    if (options.augment < 1) throw Error("SDM training: --augment must be at least 1");
    const auto settings = options.stage_settings.empty() ? default_stage_settings(options.stages) : options.stage_settings;

    SdmModel model;
    model.num_landmarks = kNumIbugLandmarks;
    model.hog_cells = options.hog_cells;
    model.training_faces = static_cast<std::uint32_t>(faces.size());
    model.augment = static_cast<std::uint32_t>(options.augment);

    // The mean shape in the box frame is the learned box-to-shape alignment: averaged over the faces
    // whose box came from the detector (all faces if there are none).
    model.mean_shape = Eigen::Matrix2Xd::Zero(2, kNumIbugLandmarks);
    int used = 0;
    const bool have_detector_faces = boxes.detector_matched > 0;
    for (const auto& f : faces) {
        if (have_detector_faces && !f.box_from_detector) continue;
        model.mean_shape += f.truth;
        ++used;
    }
    model.mean_shape /= used;

    // Spread of the true shapes around the mean (detector faces only): the initialisation noise.
    std::vector<double> dx, dy, scales, rotations;
    for (const auto& f : faces) {
        if (have_detector_faces && !f.box_from_detector) continue;
        const Similarity s = fit_similarity(model.mean_shape, f.truth);
        dx.push_back(s.translation.x() / kCanonicalBoxWidth);
        dy.push_back(s.translation.y() / kCanonicalBoxWidth);
        scales.push_back(s.scale);
        rotations.push_back(s.rotation * 180.0 / std::numbers::pi);
    }
    if (used >= 10) {
        boxes.init_translation_std = std::sqrt(0.5 * (std::pow(standard_deviation(dx), 2) + std::pow(standard_deviation(dy), 2)));
        boxes.init_scale_std = standard_deviation(scales);
        boxes.init_rotation_std_deg = standard_deviation(rotations);
    }
    model.boxes = boxes;

    const std::size_t augment = static_cast<std::size_t>(options.augment);
    const std::size_t rows = faces.size() * augment;
    std::vector<Eigen::Matrix2Xd> shapes(rows);
    for (std::size_t f = 0; f < faces.size(); ++f) {
        for (std::size_t a = 0; a < augment; ++a) {
            Rng rng(options.seed, f, kInitStreamBase + a);
            Similarity s;
            s.scale = 1 + boxes.init_scale_std * rng.normal();
            s.rotation = boxes.init_rotation_std_deg * rng.normal() * std::numbers::pi / 180.0;
            s.translation = Eigen::Vector2d(rng.normal(), rng.normal()) * boxes.init_translation_std * kCanonicalBoxWidth;
            shapes[f * augment + a] = apply_similarity(model.mean_shape, s);
        }
    }
    const auto face_of = [&](std::size_t row) -> const TrainingFace& { return faces[row / augment]; };
    const auto mean_nme = [&] {
        double sum = 0;
        for (std::size_t r = 0; r < rows; ++r) sum += landmark_nme(shapes[r], face_of(r).truth);
        return sum / static_cast<double>(rows);
    };

    const int outputs = 2 * kNumIbugLandmarks;
    const int dims = model.feature_dims();
    const std::size_t total_feature_rows = rows * settings.size() * (rows < static_cast<std::size_t>(dims) ? 1 : 2);
    std::size_t feature_rows_done = 0;
    const auto extract_rows = [&](std::size_t first, std::size_t count, const SdmStageSettings& stage, RowMatrixXf& out) {
        out.resize(static_cast<Eigen::Index>(count), dims);
        parallel_for(0, count, options.threads, [&](std::size_t i) {
            sdm_features(face_of(first + i).crop, shapes[first + i], model.hog_cells, stage,
                         {out.row(static_cast<Eigen::Index>(i)).data(), static_cast<std::size_t>(dims)});
        });
        feature_rows_done += count;
        if (options.on_progress) options.on_progress(feature_rows_done, total_feature_rows);
    };
    const auto targets = [&](std::size_t first, std::size_t count) {
        Eigen::MatrixXd y(static_cast<Eigen::Index>(count), outputs);
        for (std::size_t i = 0; i < count; ++i) {
            const auto& shape = shapes[first + i];
            const Eigen::Matrix2Xd delta = (face_of(first + i).truth - shape) / inter_eye_centre_distance(shape);
            y.row(static_cast<Eigen::Index>(i)) = Eigen::Map<const Eigen::RowVectorXd>(delta.data(), outputs);
        }
        return y;
    };

    for (std::size_t k = 0; k < settings.size(); ++k) {
        const auto start = std::chrono::steady_clock::now();
        SdmStage stage;
        stage.settings = settings[k];
        SdmStageReport report;
        report.stage = static_cast<int>(k + 1);
        report.nme_before = mean_nme();
        const double n = static_cast<double>(rows);

        if (rows < static_cast<std::size_t>(dims)) {
            // Dual form: W = A_cᵀ (A_c A_cᵀ + λI)⁻¹ Y_c, cheaper when there are fewer rows than features.
            RowMatrixXf a;
            extract_rows(0, rows, stage.settings, a);
            const Eigen::MatrixXd y = targets(0, rows);
            const Eigen::RowVectorXf mean_x = a.colwise().mean();
            const Eigen::RowVectorXd mean_y = y.colwise().mean();
            a.rowwise() -= mean_x;
            const Eigen::MatrixXd gram = (a * a.transpose()).cast<double>();
            report.lambda = options.lambda_factor * gram.norm() / n;
            Eigen::MatrixXd regularised = gram;
            regularised.diagonal().array() += report.lambda;
            const Eigen::MatrixXd alpha = regularised.llt().solve(y.rowwise() - mean_y);
            stage.weights = (a.transpose() * alpha.cast<float>()).transpose();
            stage.bias = mean_y.transpose().cast<float>() - stage.weights * mean_x.transpose();
            const RowMatrixXf delta = (a * stage.weights.transpose()).rowwise() + mean_y.cast<float>();
            for (std::size_t r = 0; r < rows; ++r) apply_update(shapes[r], delta.row(static_cast<Eigen::Index>(r)).data());
        } else {
            // Primal form, streamed in chunks: (A_cᵀA_c + λI) W = A_cᵀ Y_c. Features are shifted by the
            // first chunk's mean before accumulating so that float sums keep their precision.
            Eigen::MatrixXf gram = Eigen::MatrixXf::Zero(dims, dims);
            Eigen::VectorXd sum_x = Eigen::VectorXd::Zero(dims);
            Eigen::MatrixXd xty = Eigen::MatrixXd::Zero(dims, outputs);
            Eigen::RowVectorXd sum_y = Eigen::RowVectorXd::Zero(outputs);
            Eigen::RowVectorXf shift;
            RowMatrixXf a;
            for (std::size_t first = 0; first < rows; first += kChunkRows) {
                const std::size_t count = std::min(kChunkRows, rows - first);
                extract_rows(first, count, stage.settings, a);
                if (first == 0) shift = a.colwise().mean();
                a.rowwise() -= shift;
                const Eigen::MatrixXd y = targets(first, count);
                gram.selfadjointView<Eigen::Lower>().rankUpdate(a.transpose());
                sum_x += a.colwise().sum().transpose().cast<double>();
                xty.noalias() += a.transpose().cast<double>() * y;
                sum_y += y.colwise().sum();
            }
            const Eigen::VectorXd mean_x = sum_x / n;
            const Eigen::RowVectorXd mean_y = sum_y / n;
            Eigen::MatrixXd centred = gram.cast<double>().selfadjointView<Eigen::Lower>();
            gram.resize(0, 0);
            centred.noalias() -= n * mean_x * mean_x.transpose();
            xty.noalias() -= n * mean_x * mean_y;
            report.lambda = options.lambda_factor * centred.norm() / n;
            centred.diagonal().array() += report.lambda;
            const Eigen::MatrixXd w = centred.llt().solve(xty);
            stage.weights = w.transpose().cast<float>();
            stage.bias = (mean_y.transpose() - w.transpose() * (mean_x + shift.transpose().cast<double>())).cast<float>();
            for (std::size_t first = 0; first < rows; first += kChunkRows) {
                const std::size_t count = std::min(kChunkRows, rows - first);
                extract_rows(first, count, stage.settings, a);
                const RowMatrixXf delta = (a * stage.weights.transpose()).rowwise() + stage.bias.transpose();
                for (std::size_t i = 0; i < count; ++i)
                    apply_update(shapes[first + i], delta.row(static_cast<Eigen::Index>(i)).data());
            }
        }
        if (!stage.weights.allFinite() || !stage.bias.allFinite())
            throw Error("SDM training: stage " + std::to_string(k + 1) + " produced non-finite weights");
        report.nme_after = mean_nme();
        report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        model.stages.push_back(std::move(stage));
        if (options.on_stage) options.on_stage(report);
    }
    return model;
}

}  // namespace facesynth::train
