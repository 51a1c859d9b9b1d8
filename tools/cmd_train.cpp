// facesynth train / detect / eval landmarks: the landmark regressor's command line (train/).
#include "cli_common.h"
#include "commands.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "fit/fit.h"
#include "morph/builtin.h"
#include "morph/landmarks.h"
#include "report/svg_plot.h"
#include "train/dataset.h"
#include "train/dlib_baseline.h"
#include "train/evaluate.h"
#include "train/face_box.h"
#include "train/hog.h"
#include "train/image_copies.h"
#include "train/lbf_baseline.h"
#include "train/model_file.h"
#include "train/regressor.h"
#include "train/training.h"
#include "train/training_data.h"
#include "train/view_baselines.h"
#include "train/view_cascades.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <thread>

namespace facesynth::cli {
namespace {

using namespace facesynth::train;

int default_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

double json_number(double value) { return std::isfinite(value) ? value : -1.0; }

struct TrainArgs {
    std::string data;
    std::filesystem::path out;
    std::string method = "sdm";
    int stages = 4;
    int augment = 10;
    int threads = default_threads();
    std::uint64_t seed = 1;
    HogLayout hog;
    std::vector<double> lambda_factors = SdmTrainOptions{}.lambda_factors;
    double validation_share = SdmTrainOptions{}.validation_share;
    std::vector<int> ranks = SdmTrainOptions{}.ranks;
    int jaw_features_from = SdmTrainOptions{}.jaw_features_from;
    std::vector<double> patch_sizes;  // empty: the defaults
    std::string shape_unit = "eyes";
    int feature_pca = SdmTrainOptions{}.feature_components;
    bool mirror = false;
    int image_copies = 0;
    int realign_stages = SdmTrainOptions{}.realign_stages;
    double realign_spread = SdmTrainOptions{}.realign_spread;
    std::filesystem::path base;
    std::string detector = "dlib";
    std::string cascades = "auto";  // auto, views or single
    std::vector<double> view_overlap;  // frontal max |yaw|, profile min |yaw|
    LbfTrainOptions lbf;
    std::filesystem::path label_offsets;  // eval conventions --json
    std::filesystem::path json;
    bool quiet = false;
};

struct MergeArgs {
    std::vector<std::string> models;
    std::filesystem::path out;
    bool quiet = false;
};

void run_merge(const MergeArgs& args) {
    std::vector<SdmModel> members;
    for (const auto& path : args.models) {
        auto read = read_sdm_members(path);
        for (auto& m : read) members.push_back(std::move(m));
    }
    if (members.size() < 2) throw CLI::ValidationError("models", "an ensemble needs at least two models");
    write_sdm_ensemble(args.out, members);
    if (!args.quiet) std::printf("train merge: %zu models in %s\n", members.size(), args.out.c_str());
}

void run_train(const TrainArgs& args) {
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    if (args.cascades == "views" && !detector_has_views(parse_detector_kind(args.detector)))
        throw CLI::ValidationError("--cascades", "views needs a detector with views (not frontal)");
    if (!args.view_overlap.empty() && args.method != "sdm")
        throw CLI::ValidationError("--view-overlap", "only applies to --method sdm");
    if (!args.view_overlap.empty() && args.cascades == "single")
        throw CLI::ValidationError("--view-overlap", "only applies to view-specific cascades");
    if (args.feature_pca > 0 && args.method != "sdm") throw CLI::ValidationError("--feature-pca", "only applies to --method sdm");
    if (args.mirror && args.method != "sdm") throw CLI::ValidationError("--mirror", "only applies to --method sdm");
    if (args.image_copies > 0 && args.method != "sdm") throw CLI::ValidationError("--image-copies", "only applies to --method sdm");
    if (args.realign_stages > 0 && args.method != "sdm") throw CLI::ValidationError("--realign-stages", "only applies to --method sdm");
    if (args.realign_stages > args.stages && args.base.empty())
        throw CLI::ValidationError("--realign-stages", "is more than --stages " + std::to_string(args.stages));
    if (!args.base.empty() && args.realign_stages == 0) throw CLI::ValidationError("--base", "needs --realign-stages (it trains only those)");
    if (args.hog.orientations != kDefaultHogOrientations && args.method != "sdm")
        throw CLI::ValidationError("--hog-orientations", "only applies to --method sdm");
    if (const int dims = morph::kNumIbugLandmarks * args.hog.dims(); args.feature_pca > dims)
        throw CLI::ValidationError("--feature-pca", std::to_string(args.feature_pca) + " is more than the feature dimension " +
                                                        std::to_string(dims) + " (68 * " + std::to_string(args.hog.cells) +
                                                        "^2 cells * " + std::to_string(args.hog.dims_per_cell()) + ")");
    TrainingRequest request;
    request.method = args.method == "ert" ? TrainingMethod::kErt : args.method == "lbf" ? TrainingMethod::kLbf : TrainingMethod::kSdm;
    request.cascades = args.cascades == "views" ? CascadeChoice::kViews : args.cascades == "single" ? CascadeChoice::kSingle : CascadeChoice::kAuto;
    if (!args.view_overlap.empty()) {
        request.split.frontal_max_yaw_deg = args.view_overlap[0];
        request.split.profile_min_yaw_deg = args.view_overlap[1];
    }
    request.out = args.out;
    request.prepare.threads = args.threads;
    request.prepare.seed = args.seed;
    request.prepare.detector = parse_detector_kind(args.detector);
    if (!args.label_offsets.empty()) request.prepare.label_offsets = read_label_offsets(args.label_offsets);
    SdmTrainOptions& sdm = request.sdm;
    sdm.stages = args.stages;
    sdm.augment = args.augment;
    sdm.threads = args.threads;
    sdm.seed = args.seed;
    sdm.hog = args.hog;
    sdm.lambda_factors = args.lambda_factors;
    sdm.validation_share = args.validation_share;
    sdm.ranks = args.ranks;
    sdm.jaw_features_from = args.jaw_features_from;
    if (!args.patch_sizes.empty()) sdm.stage_settings = default_stage_settings(args.stages, args.jaw_features_from, args.patch_sizes);
    sdm.unit = args.shape_unit == "box" ? ShapeUnitKind::kFixed : ShapeUnitKind::kInterEyeCentres;
    sdm.feature_components = args.feature_pca;
    sdm.mirror = args.mirror;
    sdm.image_copies = args.image_copies;
    sdm.realign_stages = args.realign_stages;
    sdm.realign_spread = args.realign_spread;
    request.base = args.base;
    request.ert.threads = args.threads;
    request.ert.oversampling = args.augment;
    request.ert.seed = args.seed;
    request.lbf = args.lbf;
    request.lbf.augment = args.augment;
    request.lbf.seed = args.seed;

    const auto images = list_labelled_images(split_folder_list(args.data));
    Progress faces_progress("faces", images.size(), args.quiet);
    std::size_t faces_reported = 0;
    request.prepare.on_progress = [&](std::size_t done, std::size_t) {
        faces_progress.advance(done - faces_reported);
        faces_reported = done;
    };
    std::unique_ptr<Progress> features_progress;
    std::size_t features_reported = 0;
    sdm.on_progress = [&](std::size_t done, std::size_t total) {
        if (features_progress && done < features_reported) {  // the next cascade (view-specific cascades) counts from 0 again
            features_progress->finish();
            features_progress.reset();
            features_reported = 0;
        }
        if (!features_progress) features_progress = std::make_unique<Progress>("features", total, args.quiet);
        features_progress->advance(done - features_reported);
        features_reported = done;
    };
    TrainingObserver observer;
    observer.on_warning = [&](const std::string& warning) {
        faces_progress.finish();
        std::fprintf(stderr, "facesynth: warning: %s\n", warning.c_str());
    };
    observer.on_message = [&](const std::string& message) {
        faces_progress.finish();
        if (features_progress) features_progress->finish();  // messages after preparation come after training
        if (!args.quiet) std::printf("%s\n", message.c_str());
    };
    observer.on_stage = [&](const std::string& cascade, const SdmStageReport& r) {
        if (args.quiet) return;
        const bool realigned = cascade.ends_with("_realigned");
        const std::string name = cascade == "single" || cascade == "frontal" ? "" : cascade + " cascade ";
        std::fprintf(stderr,
                     "\n%sstage %d/%d: training NME %.4f -> %.4f, validation NME %.4f -> %.4f (lambda factor %g, "
                     "lambda %.4g, rank %d, feature components %d, %.1f s)\n",
                     name.c_str(), r.stage, realigned ? args.realign_stages : args.stages, r.nme_before, r.nme_after,
                     r.validation_nme_before, r.validation_nme_after, r.lambda_factor, r.lambda, r.rank, r.feature_components, r.seconds);
    };
    nlohmann::json report = train_regressor(images, request, observer);
    faces_progress.finish();
    if (features_progress) features_progress->finish();
    report["label_offsets"] = args.label_offsets.string();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    report["seconds"] = seconds;
    report["cpu_seconds"] = cpu_seconds;
    if (!args.quiet) std::printf("wrote %s (%.1f s, %.1f s CPU)\n", args.out.string().c_str(), seconds, cpu_seconds);
    if (!args.json.empty()) write_json_file(args.json, report);
}

struct DetectArgs {
    std::string regressor;
    std::string detector = "auto";
    std::vector<std::filesystem::path> images;
    std::filesystem::path out;
    bool quiet = false;
};

void run_detect(const DetectArgs& args) {
    const auto regressor = open_regressor(args.regressor);
    const LandmarkRegressor* const regressors[] = {regressor.get()};
    const FaceDetector detector(choose_detector(args.detector, regressors));
    create_output_folder(args.out);
    int failed = 0, faces_total = 0;
    Progress progress("images", args.images.size(), args.quiet);
    for (const auto& path : args.images) {
        try {
            if (!std::filesystem::is_regular_file(path)) throw core::file_error(path.string(), "file not found");
            core::check_image_not_too_large(path);
            const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
            if (image.empty()) throw core::file_error(path.string(), "cannot read image");
            const cv::Mat gray = to_gray8(image);
            const auto boxes = detector.detect(gray);
            if (boxes.empty()) throw core::file_error(path.string(), "no face found");
            const std::string stem = path.stem().string();
            cv::Mat overlay = image.clone();
            nlohmann::json faces = nlohmann::json::array();
            const int thickness = std::max(1, image.cols / 400);
            for (std::size_t k = 0; k < boxes.size(); ++k) {
                const Eigen::Matrix2Xd points = regressor->predict(gray, boxes[k]);
                morph::write_pts(args.out / (stem + "_" + std::to_string(k) + ".pts"), points);
                const cv::Rect2d rect = rect_from_face_box(boxes[k]);
                cv::rectangle(overlay, rect, cv::Scalar(255, 160, 0), thickness);
                nlohmann::json landmarks = nlohmann::json::array();
                for (Eigen::Index i = 0; i < points.cols(); ++i) {
                    cv::circle(overlay, cv::Point2d(points(0, i), points(1, i)), 2 * thickness, cv::Scalar(0, 255, 0),
                               cv::FILLED, cv::LINE_AA);
                    landmarks.push_back({points(0, i), points(1, i)});
                }
                faces.push_back({{"box", {rect.x, rect.y, rect.width, rect.height}},
                                 {"view", view_name(boxes[k].view)},
                                 {"pts", stem + "_" + std::to_string(k) + ".pts"},
                                 {"landmarks", landmarks}});
            }
            write_png_file(args.out / (stem + "_overlay.png"), overlay);
            const nlohmann::json record = {{"image", path.string()},
                                           {"regressor", regressor->label()},
                                           {"detector", detector_name(detector.kind())},
                                           {"coordinates", "0-based pixels; box = [x, y, width, height]"},
                                           {"faces", faces}};
            core::write_file_atomically(args.out / (stem + ".json"), record.dump(2) + "\n");
            faces_total += static_cast<int>(boxes.size());
        } catch (const core::Error& e) {
            ++failed;
            std::fprintf(stderr, "facesynth: error: %s\n", e.what());
        } catch (const cv::Exception& e) {  // an OpenCV failure on this image only: the batch goes on
            ++failed;
            std::fprintf(stderr, "facesynth: error: %s: %s\n", path.string().c_str(), e.what());
        }
        progress.advance();
    }
    progress.finish();
    if (!args.quiet)
        std::printf("%d faces in %zu images written to %s\n", faces_total, args.images.size() - failed,
                    args.out.string().c_str());
    if (failed) throw core::Error(std::to_string(failed) + " of " + std::to_string(args.images.size()) + " images failed");
}

struct LandmarkEvalArgs {
    std::vector<std::string> regressors;
    std::string detector = "auto";
    std::string data;
    std::filesystem::path json;
    std::filesystem::path ced;
    std::filesystem::path nme_csv;
    bool quiet = false;
};

// RFC 4180: a field with a comma, quote or line break is quoted, its quotes doubled.
std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

// One row per face: its key, true yaw (empty when unknown), whether the detector found it and with
// which view (empty for a miss), and the NME of each regressor in --regressor order (inf for a miss).
// The report draws CED curves from it.
std::string per_face_nme_csv(const Evaluation& evaluation) {
    std::string csv = "key,yaw_deg,detected,view";
    for (std::size_t r = 0; r < evaluation.regressors.size(); ++r) csv += ",regressor" + std::to_string(r + 1);
    csv += "\n";
    char number[32];
    for (std::size_t f = 0; f < evaluation.faces.size(); ++f) {
        const auto& face = evaluation.faces[f];
        csv += csv_field(face.key) + ",";
        if (face.yaw_deg) {
            std::snprintf(number, sizeof number, "%.3f", *face.yaw_deg);
            csv += number;
        }
        csv += face.detected ? std::string(",1,") + view_name(face.view) : std::string(",0,");
        for (const auto& reg : evaluation.regressors) {
            std::snprintf(number, sizeof number, "%.6g", reg.nmes[f]);
            csv += std::string(",") + (std::isfinite(reg.nmes[f]) ? number : "inf");
        }
        csv += "\n";
    }
    return csv;
}

// Which view found the faces, and the detector's misses per 10° |yaw| bin (where the data has yaw):
// printed, and as JSON keys detector_view_<view>, detector_misses_yaw_<lo>_<hi>, faces_yaw_<lo>_<hi>.
void add_detector_breakdown(const Evaluation& evaluation, nlohmann::json& report) {
    std::array<int, kFaceViews> views{};
    constexpr int kBins = 9;  // 0-10 ... 80-90
    std::array<int, kBins> faces{}, misses{};
    for (const auto& face : evaluation.faces) {
        if (face.detected) ++views[static_cast<std::size_t>(face.view)];
        if (!face.yaw_deg) continue;
        const auto bin = static_cast<std::size_t>(std::clamp(static_cast<int>(std::abs(*face.yaw_deg) / 10), 0, kBins - 1));
        ++faces[bin];
        if (!face.detected) ++misses[bin];
    }
    std::printf("detections by view:");
    for (std::size_t v = 0; v < kFaceViews; ++v) {
        const char* name = view_name(static_cast<FaceView>(v));
        report[std::string("detector_view_") + name] = views[v];
        std::printf(" %s %d", name, views[v]);
    }
    std::printf("\n");
    for (std::size_t b = 0; b < kBins; ++b) {
        if (!faces[b]) continue;
        char suffix[32];
        std::snprintf(suffix, sizeof suffix, "yaw_%02zu_%02zu", 10 * b, 10 * b + 10);
        report[std::string("detector_misses_") + suffix] = misses[b];
        report[std::string("faces_") + suffix] = faces[b];
        std::printf("    |yaw| %2zu-%2zu: detector missed %3d of %3d\n", 10 * b, 10 * b + 10, misses[b], faces[b]);
    }
}

// Photographs have no meta with their pose: their yaw (for the per-|yaw| tables) is the fitted
// built-in model's. Returns how many were fitted.
int add_fitted_yaws(const std::vector<LabelledImage>& images, Evaluation& evaluation) {
    std::unique_ptr<morph::MorphableModel> model;
    std::unique_ptr<fit::Fitter> fitter;
    int fitted = 0;
    for (std::size_t f = 0; f < evaluation.faces.size() && f < images.size(); ++f) {
        if (evaluation.faces[f].yaw_deg) continue;
        if (!fitter) {
            model = std::make_unique<morph::MorphableModel>(morph::builtin_model());
            fitter = std::make_unique<fit::Fitter>(*model);
        }
        try {
            evaluation.faces[f].yaw_deg = fit::annotated_yaw(*fitter, morph::read_pts(images[f].pts));
        } catch (const core::Error&) {
            // an unreadable .pts is already counted among the warnings; the face stays out of the bins
        }
        fitted += evaluation.faces[f].yaw_deg.has_value();
    }
    return fitted;
}

void run_eval_landmarks(const LandmarkEvalArgs& args) {
    std::vector<std::unique_ptr<LandmarkRegressor>> owned;
    std::vector<const LandmarkRegressor*> regressors;
    for (const auto& spec : args.regressors) {
        owned.push_back(open_regressor(spec));
        regressors.push_back(owned.back().get());
    }
    const auto images = list_labelled_images(split_folder_list(args.data));
    Evaluation evaluation;
    {
        Progress progress("faces", images.size(), args.quiet);
        evaluation = evaluate_landmarks(images, regressors, choose_detector(args.detector, regressors), [&] { progress.advance(); });
        progress.finish();
    }
    for (const auto& w : evaluation.warnings) std::fprintf(stderr, "facesynth: warning: %s\n", w.c_str());
    const int fitted_yaws = add_fitted_yaws(images, evaluation);
    if (fitted_yaws > 0) std::printf("%d faces without meta: yaw from fitting the built-in model to their annotations\n", fitted_yaws);
    std::printf("%zu faces, %d detector misses (counted as failures), %s detector %.2f ms per image\n", images.size(),
                evaluation.detector_misses, detector_name(evaluation.detector), evaluation.detector_ms_per_image);
    std::printf("%-40s %9s %9s %8s %9s %9s\n", "regressor", "NME mean", "median", "AUC@.08", "fail@.08", "ms/face");
    nlohmann::json report = {{"count", static_cast<int>(images.size())},
                             {"detector_misses", evaluation.detector_misses},
                             {"detector_ms_per_image", evaluation.detector_ms_per_image},
                             {"unreadable", static_cast<int>(evaluation.warnings.size())},
                             {"detector", detector_name(evaluation.detector)}};
    add_detector_breakdown(evaluation, report);
    for (std::size_t r = 0; r < evaluation.regressors.size(); ++r) {
        const auto& reg = evaluation.regressors[r];
        const auto& s = reg.summary;
        std::printf("%-40s %9.4f %9.4f %8.4f %9.4f %9.3f\n", reg.label.c_str(), s.mean, s.median, s.auc_008,
                    s.failure_rate_008, reg.ms_per_face);
        // Keys stay stable whatever the file names: the first regressor's metrics are unprefixed,
        // each further one's are prefixed by its position (regressor2_nme_mean, ...), and
        // regressorN names its spec.
        const std::string position = "regressor" + std::to_string(r + 1);
        report[position] = args.regressors[r];
        const std::string prefix = r == 0 ? "" : position + "_";
        const auto put = [&](const std::string& key, double value) { report[prefix + key] = json_number(value); };
        put("nme_mean", s.mean);
        put("nme_median", s.median);
        put("auc_008", s.auc_008);
        put("failure_rate_008", s.failure_rate_008);
        put("ms_per_face", reg.ms_per_face);
        for (const auto& [low, high] : yaw_bins()) {
            std::vector<double> in_bin;
            for (std::size_t f = 0; f < evaluation.faces.size(); ++f) {
                const auto& yaw = evaluation.faces[f].yaw_deg;
                if (yaw && std::abs(*yaw) >= low && (std::abs(*yaw) < high || high == 90)) in_bin.push_back(reg.nmes[f]);
            }
            if (in_bin.empty()) continue;
            const auto bin = summarise_nme(in_bin);
            char key[64];
            std::snprintf(key, sizeof(key), "yaw_%02d_%02d_", low, high);
            put(std::string(key) + "nme_mean", bin.mean);
            put(std::string(key) + "failure_rate_008", bin.failure_rate_008);
            put(std::string(key) + "count", bin.count);
            std::printf("    |yaw| %2d-%2d: %4d faces, NME mean %.4f, failure rate %.3f\n", low, high, bin.count,
                        bin.mean, bin.failure_rate_008);
        }
    }
    if (!args.json.empty()) write_json_file(args.json, report);
    if (!args.ced.empty()) {
        std::vector<CedCurve> curves;
        for (std::size_t r = 0; r < evaluation.regressors.size(); ++r)
            curves.push_back({args.regressors[r], evaluation.regressors[r].nmes});
        if (args.ced.extension() == ".png") {
            core::write_file_atomically(args.ced, ced_png(curves));
        } else {
            report::LinePlot plot = report::ced_plot("CED");
            for (std::size_t r = 0; r < curves.size(); ++r) {
                plot.series.push_back(report::cumulative_series(curves[r].label, curves[r].nmes, plot.x.max));
                plot.series.back().dashed = r > 0;
            }
            core::write_file_atomically(args.ced, report::line_plot_svg(plot));
        }
    }
    if (!args.nme_csv.empty()) core::write_file_atomically(args.nme_csv, per_face_nme_csv(evaluation));
    // The report counts unreadable items as misses; the exit code still says that some failed.
    if (!evaluation.warnings.empty())
        throw core::Error(std::to_string(evaluation.warnings.size()) + " of " + std::to_string(images.size()) +
                    " images or landmark files could not be read (counted as misses)");
}

}  // namespace

void register_train_commands(CLI::App& app) {
    {
        auto args = std::make_shared<TrainArgs>();
        auto* cmd = app.add_subcommand("train", "Train a 68-point landmark regressor on folders of images with .pts files");
        // Required unless `train merge` runs instead (checked in the callback: a parent's required options
        // would also be demanded of its subcommand).
        cmd->add_option("--data", args->data, "Training folders, comma-separated (X.png + X.pts, or images/ + landmarks/); required");
        cmd->add_option("--out", args->out, "Model file to write; required");
        cmd->add_option("--method", args->method, "sdm (our HOG cascade), ert (dlib's trainer) or lbf (OpenCV FacemarkLBF)")
            ->check(CLI::IsMember({"sdm", "ert", "lbf"}))
            ->capture_default_str();
        cmd->add_option("--stages", args->stages, "SDM cascade stages")->check(CLI::Range(1, 8))->capture_default_str();
        cmd->add_option("--augment", args->augment, "Perturbed initialisations per face (LBF: initial shapes, initShape_n)")
            ->check(CLI::Range(1, 1000))
            ->capture_default_str();
        cmd->add_option("--threads", args->threads, "Worker threads (results do not depend on it)")
            ->check(CLI::Range(1, 256))
            ->capture_default_str();
        cmd->add_option("--seed", args->seed, "Random seed")->capture_default_str();
        cmd->add_option("--hog-cells", args->hog.cells, "SDM: HOG cells per patch side")
            ->check(CLI::Range(1, 8))
            ->capture_default_str();
        cmd->add_option("--hog-orientations", args->hog.orientations,
                        "SDM: HOG orientations O (3·O + 4 values per cell: 2·O signed, O unsigned, 4 texture)")
            ->check(CLI::Range(1, kMaxHogOrientations))
            ->capture_default_str();
        cmd->add_option("--lambda-factors", args->lambda_factors,
                        "SDM: ridge lambda = factor * ||A'A||_F / N; with several (comma-separated), each stage keeps "
                        "the one with the lowest validation NME")
            ->delimiter(',')
            ->check(CLI::PositiveNumber)
            ->capture_default_str();
        cmd->add_option("--validation-share", args->validation_share,
                        "SDM: share of faces held out to choose lambda (every k-th face; 0 = none, needs one factor)")
            ->check(CLI::Range(0.0, 0.5))
            ->capture_default_str();
        cmd->add_option("--jaw-features-from", args->jaw_features_from,
                        "SDM: first stage (1-based) whose features include the 17 jaw points' HOG")
            ->check(CLI::Range(1, 9))
            ->capture_default_str();
        cmd->add_option("--patch-sizes", args->patch_sizes,
                        "SDM: each stage's patch side in inter-eye-centre distances, one per stage, comma-separated "
                        "(default 1,0.7,0.4,0.25,0.2,0.15,...)")
            ->delimiter(',');
        cmd->add_option("--shape-unit", args->shape_unit,
                        "SDM: the length patches and updates are measured in: eyes (the current shape's inter-eye-centre "
                        "distance, which shrinks with yaw) or box (fixed in the detector's box)")
            ->check(CLI::IsMember({"eyes", "box"}))
            ->capture_default_str();
        cmd->add_option("--feature-pca", args->feature_pca,
                        "SDM: regress each stage on this many leading principal components of its features (folded "
                        "into the stored weights; at most 68 * hog-cells^2 * (3 * hog-orientations + 4)); 0 = off")
            ->check(CLI::NonNegativeNumber)
            ->capture_default_str();
        cmd->add_flag("--mirror", args->mirror,
                      "SDM: every training face also trains as its mirror image (the frontal cascade's faces with view "
                      "cascades; validation faces are not mirrored)");
        cmd->add_option("--image-copies", args->image_copies,
                        "SDM: every training photograph (an image beside its .pts, not a dataset's render; validation faces "
                        "not) also trains as this many copies, turned up to 10 deg, scaled up to 7 %, shifted up to 3 crop "
                        "px, then degraded (gamma, gain, blur, noise, JPEG), each with --augment starts")
            ->check(CLI::Range(0, kMaxImageCopies))
            ->capture_default_str();
        cmd->add_option("--realign-stages", args->realign_stages,
                        "SDM: also train a cascade of this many stages for the realigned second pass (regressor spec "
                        "realign:), on crops turned upright by the truth with starts spread as the main cascade's residual; "
                        "0 = none (realign: then runs the main cascade twice)")
            ->check(CLI::Range(0, 8))
            ->capture_default_str();
        cmd->add_option("--realign-spread", args->realign_spread,
                        "SDM: the realigned cascade's training starts are spread this many times the main cascade's "
                        "residual on the validation faces")
            ->check(CLI::Range(0.1, 10.0))
            ->capture_default_str();
        cmd->add_option("--base", args->base,
                        "SDM with --realign-stages: keep this model's main cascades instead of training them and train only "
                        "the realigned ones (it must have been trained on the same --data, --detector, --seed, --augment, "
                        "--validation-share, --mirror, --image-copies and --view-overlap)");
        cmd->add_option("--ranks", args->ranks,
                        "SDM: candidate ranks of each stage's update (1-136, comma-separated); validation keeps the "
                        "smallest within 1% of the best NME")
            ->delimiter(',')
            ->check(CLI::Range(1, 136))
            ->capture_default_str();
        cmd->add_option("--detector", args->detector,
                        "Face detector for the training boxes, recorded in the model: frontal (Haar frontal cascade), "
                        "multiview (frontal + profile cascades, one mean shape per view), dlib (dlib's HOG detector, "
                        "views from its filters) or dlib+profile (dlib, plus the Haar profile cascades where dlib "
                        "finds nothing)")
            ->check(CLI::IsMember({"frontal", "multiview", "dlib", "dlib+profile"}))
            ->capture_default_str();
        cmd->add_option("--cascades", args->cascades,
                        "views (one cascade, or ERT/LBF model, for the frontal view and one for the profile views, "
                        "nose-right faces mirrored, chosen at detection by the detector's view; needs a "
                        "detector with views, not frontal), single (one for all views), or auto (views with such a "
                        "detector when each view gets at least 100 faces)")
            ->check(CLI::IsMember({"auto", "views", "single"}))
            ->capture_default_str();
        cmd->add_option("--view-overlap", args->view_overlap,
                        "SDM, view-specific cascades: FRONTAL_MAX,PROFILE_MIN true |yaw| in degrees: profile-view faces with "
                        "|yaw| <= FRONTAL_MAX also train the frontal cascade, frontal-view faces with |yaw| >= PROFILE_MIN "
                        "the profile one (needs synth meta files; default: no overlap)")
            ->delimiter(',')
            ->expected(2)
            ->check(CLI::Range(0.0, 90.0));
        cmd->add_option("--lbf-stages", args->lbf.stages, "LBF: cascade stages (stages_n)")
            ->check(CLI::Range(1, 20))
            ->capture_default_str();
        cmd->add_option("--lbf-trees", args->lbf.trees, "LBF: trees per landmark and stage (tree_n)")
            ->check(CLI::Range(1, 100))
            ->capture_default_str();
        cmd->add_option("--lbf-depth", args->lbf.depth, "LBF: tree depth (tree_depth; 2^(depth-1) leaves)")
            ->check(CLI::Range(2, 12))
            ->capture_default_str();
        cmd->add_option("--lbf-features", args->lbf.features,
                        "LBF: candidate pixel-difference features per split, one per stage (feats_m)")
            ->delimiter(',')
            ->check(CLI::Range(1, 100000))
            ->capture_default_str();
        cmd->add_option("--lbf-radii", args->lbf.radii,
                        "LBF: feature sampling radius per stage, in box half-widths (radius_m)")
            ->delimiter(',')
            ->check(CLI::Range(0.001, 2.0))
            ->capture_default_str();
        cmd->add_flag("--lbf-verbose", args->lbf.verbose,
                      "LBF: OpenCV's own print-out (per-stage forest and regression times, liblinear iterations)");
        cmd->add_option("--label-offsets", args->label_offsets,
                        "Label adaptation: move every training label by the per-landmark mean offsets (face frame) of an "
                        "`eval conventions --json` file before training (the regressor then predicts the annotators' convention)")
            ->check(CLI::ExistingFile);
        cmd->add_option("--json", args->json, "Write a JSON summary here");
        cmd->add_flag("-q,--quiet", args->quiet, "No progress output");
        cmd->require_subcommand(0, 1);
        cmd->callback([args, cmd] {
            if (!cmd->get_subcommands().empty()) return;
            if (args->data.empty()) throw CLI::RequiredError("--data");
            if (args->out.empty()) throw CLI::RequiredError("--out");
            run_train(*args);
        });

        auto merge = std::make_shared<MergeArgs>();
        auto* merge_cmd = cmd->add_subcommand(
            "merge", "Join SDM models into one ensemble file whose regressor averages their landmarks (for example models trained on renders of different seeds)");
        merge_cmd->add_option("models", merge->models, "SDM model files (an ensemble's members join as members)")->required()->check(CLI::ExistingFile);
        merge_cmd->add_option("--out", merge->out, "Ensemble file to write")->required();
        merge_cmd->add_flag("-q,--quiet", merge->quiet, "No summary line");
        merge_cmd->callback([merge] { run_merge(*merge); });
    }
    {
        auto args = std::make_shared<DetectArgs>();
        auto* cmd = app.add_subcommand("detect", "Find faces (cascade detector) and their 68 landmarks in images");
        cmd->add_option("--regressor", args->regressor, "MODEL (SDM file), sdm@K:MODEL, mean:MODEL, mirror:MODEL, realign:MODEL, dlib, dlib:FILE, ert:FILE or lbf:FILE")
            ->required();
        cmd->add_option("images", args->images, "Images")->required();
        cmd->add_option("--out", args->out, "Output folder: <stem>_<k>.pts, <stem>_overlay.png, <stem>.json")->required();
        add_detector_option(*cmd, args->detector);
        cmd->add_flag("-q,--quiet", args->quiet, "No progress output");
        cmd->callback([args] { run_detect(*args); });
    }
    {
        auto args = std::make_shared<LandmarkEvalArgs>();
        auto* cmd = eval_group(app).add_subcommand("landmarks", "Landmark NME on labelled images (inter-ocular)");
        cmd->add_option("--regressor", args->regressors,
                        "MODEL (SDM file), mean:MODEL (its mean shape only), sdm@K:MODEL (its first K stages), mirror:MODEL (run on the face and its mirror image, averaged), realign:MODEL (run again on the crop realigned by the first run, averaged; the two prefixes combine), dlib, dlib:FILE, ert:FILE "
                        "or lbf:FILE; repeat to compare on the same boxes")
            ->required();
        cmd->add_option("--data", args->data, "Folders with images and .pts, comma-separated")->required();
        add_detector_option(*cmd, args->detector);
        cmd->add_option("--json", args->json, "Write flat JSON results here");
        cmd->add_option("--ced", args->ced, "Write the CED curves (NME 0-0.08) here: .svg, or .png");
        cmd->add_option("--nme-csv", args->nme_csv, "Write every face's NME per regressor here (key,yaw_deg,detected,view,regressor1,...)");
        cmd->add_flag("-q,--quiet", args->quiet, "No progress output");
        cmd->callback([args] { run_eval_landmarks(*args); });
    }
}

}  // namespace facesynth::cli
