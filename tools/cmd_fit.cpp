// `facesynth fit` (fit the 3DMM to one face's landmarks) and `facesynth fit-lambda` (choose the
// regularisation on synthetic validation fits). The algorithms live in fit/.
#include "cli_common.h"
#include "commands.h"

#include "fit/conventions.h"
#include "fit/dataset_eval.h"
#include "fit/evaluate.h"
#include "fit/fit.h"
#include "fit/fit_record.h"
#include "fit/overlay.h"
#include "fit/refine.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"
#include "morph/mesh_io.h"
#include "morph/model_io.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <numeric>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>

namespace facesynth::cli {
namespace {

struct FitArgs {
    std::string model = "builtin";
    std::string landmarks;
    std::string image;
    std::string out;
    std::string json;
    std::string landmark_set = "68";
    std::string jaw = "contour";
    bool refine = false;
    bool no_expression = false;
    double lambda = fit::FaceFitChoices{}.lambda;
    int iterations = fit::FaceFitChoices{}.iterations;
    int components = 0;
    double focal = 0;
    double sigma = fit::FaceFitChoices{}.landmark_sigma_px;
    bool quiet = false;
};

void run_fit(const FitArgs& a) {
    const auto start = std::chrono::steady_clock::now();
    const morph::MorphableModel model = morph::load_model(a.model);
    const Eigen::Matrix2Xd landmarks = morph::read_pts(a.landmarks);
    if (landmarks.cols() != morph::kNumIbugLandmarks)
        throw core::file_error(a.landmarks, "has " + std::to_string(landmarks.cols()) + " points, expected 68 (iBUG)");
    cv::Mat image;
    if (!a.image.empty()) {
        core::check_image_not_too_large(a.image);
        image = cv::imread(a.image, cv::IMREAD_COLOR);
        if (image.empty()) throw core::file_error(a.image, "cannot read the image");
    }

    fit::FaceFitChoices choices;
    const auto subset = morph::landmark_subset(morph::parse_landmark_subset(a.landmark_set));
    choices.subset.assign(subset.begin(), subset.end());
    choices.jaw = fit::parse_jaw_mode(a.jaw);
    choices.lambda = a.lambda;
    choices.iterations = a.iterations;
    choices.shape_components = a.components;
    choices.fit_expression = !a.no_expression;
    choices.refine = a.refine;
    choices.landmark_sigma_px = a.sigma;
    choices.focal_px = a.focal;
    choices.image_width = image.cols;
    choices.image_height = image.rows;
    const fit::LandmarkFitOptions options = fit::landmark_fit_options(choices);

    const fit::Fitter fitter(model);
    fit::LandmarkFit fitted;
    try {
        fitted = fit::fit_face(fitter, landmarks, options);
    } catch (const core::Error& e) {
        throw core::file_error(a.landmarks, e.what());
    }
    nlohmann::json j;
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["landmarks_file"] = a.landmarks;
    j["landmark_set"] = a.landmark_set;
    j["jaw"] = a.jaw;
    fit::write_json(j, fitted);
    const std::filesystem::path out(a.out);
    create_output_folder(out);
    morph::write_obj(fitted.mesh, out / "mesh.obj");
    morph::write_glb(fitted.mesh, out / "mesh.glb");
    if (!image.empty())
        write_png_file(out / "overlay.png", fit::draw_fit_overlay(image, fitted.vertices_px, fitted.mesh.triangles, landmarks, fitted.projected()));
    j["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    write_json_file(out / "fit.json", j);
    if (!a.json.empty()) write_json_file(a.json, j);
    if (!a.quiet)
        std::printf("yaw %.1f pitch %.1f roll %.1f deg, reprojection %.2f px (%zu landmarks) -> %s\n", fitted.angles().yaw, fitted.angles().pitch,
                    fitted.angles().roll, fitted.reprojection_rms_px(), fitted.linear.used.size(), out.string().c_str());
}

struct LambdaArgs {
    std::string model = "builtin";
    std::vector<double> lambdas{0.03, 0.1, 0.3, 1, 3, 10, 30, 100};
    std::vector<double> noise{0, 2};
    int count = 200;
    std::int64_t seed = 900001;
    std::string landmark_set = "68";
    std::string json;
    bool quiet = false;
};

void run_lambda(const LambdaArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    const fit::Fitter fitter(model);
    fit::FitOptions base;
    const auto subset = morph::landmark_subset(morph::parse_landmark_subset(a.landmark_set));
    base.subset.assign(subset.begin(), subset.end());
    base.jaw = fit::JawMode::kFixed;
    nlohmann::json j;
    j["model"] = model.name;
    j["count"] = a.count;
    j["seed"] = a.seed;
    Progress progress("fit-lambda", a.noise.size(), a.quiet);
    std::ostringstream table;
    table << "noise_px  lambda  vertex_rmse_mm  meanshape_mm  alpha_rmse\n";
    for (double noise : a.noise) {
        fit::SyntheticOptions s;
        s.noise_px = noise;
        const auto scores = fit::score_lambdas(fitter, a.lambdas, a.count, static_cast<std::uint64_t>(a.seed), s, base);
        const fit::LambdaScore* best = &scores.front();
        for (const auto& sc : scores) {
            if (sc.vertex_rmse_mm < best->vertex_rmse_mm) best = &sc;
            char line[128];
            std::snprintf(line, sizeof line, "%8.1f %7.3g %15.3f %13.3f %11.3f\n", noise, sc.lambda, sc.vertex_rmse_mm,
                          sc.vertex_rmse_mm_meanshape, sc.alpha_rmse);
            table << line;
            char key[96];
            std::snprintf(key, sizeof key, "noise%g_lambda%g_vertex_rmse_mm", noise, sc.lambda);
            j[key] = sc.vertex_rmse_mm;
        }
        char key[64];
        std::snprintf(key, sizeof key, "noise%g_best_lambda", noise);
        j[key] = best->lambda;
        progress.advance();
    }
    progress.finish();
    std::fputs(table.str().c_str(), stdout);
    if (!a.json.empty()) write_json_file(a.json, j);
}

struct FitEvalArgs {
    std::string model = "builtin";
    std::string data;  // a `facesynth synth` dataset folder; empty: cases generated in code
    std::string mode = "contour";
    int count = 300;
    std::int64_t seed = 424242;  // the test set: never the validation seed of fit-lambda
    double noise = 0;
    std::string landmark_set = "68";
    bool refine = false;
    bool visible_only = false;
    double lambda = fit::FitOptions{}.lambda;
    double sigma = fit::RefineOptions{}.landmark_sigma_px;
    double max_yaw = 60;
    bool max_yaw_given = false;
    std::string json;
    bool quiet = false;
};

void print_summary_row(const std::string& label, const fit::MetricsSummary& s) {
    const double n = std::max(s.count, 1);
    std::printf("%-12s %5d %7.2f %7.2f %7.2f %+7.2f %+7.2f %+7.2f %9.2f %10.2f %7.3f %7.2f %7.3f %7.3f\n", label.c_str(), s.count, s.yaw / n,
                s.pitch / n, s.roll / n, s.yaw_bias / n, s.pitch_bias / n, s.roll_bias / n, s.vertex / n, s.meanshape / n, s.alpha / n,
                s.reprojection / n, s.ms / n, s.cpu_ms / n);
}

void print_summary(const fit::YawBinnedSummary& summary, bool skip_empty) {
    std::printf("%-12s %5s %7s %7s %7s %7s %7s %7s %9s %10s %7s %7s %7s %7s\n", "yaw bin", "n", "yaw", "pitch", "roll", "yaw_b", "pitch_b",
                "roll_b", "rmse_mm", "mean_mm", "alpha", "repr_px", "ms", "cpu_ms");
    for (std::size_t b = 0; b < summary.bins.size(); ++b)
        if (!skip_empty || summary.bins[b].count > 0) print_summary_row(summary.label(b), summary.bins[b]);
    print_summary_row("all", summary.all);
}

// `eval fit`: generated cases, or a synth dataset (--data); the loop is fit::evaluate_fit_set. A
// sample whose meta file is missing or corrupt, or whose fit fails, is reported on one line and
// skipped; the command then exits 1 saying how many failed.
void run_eval(const FitEvalArgs& a) {
    fit::FitSetEvalSettings s;
    s.data = a.data;
    s.mode = a.mode;
    s.count = a.count;
    s.seed = a.seed;
    s.noise_px = a.noise;
    s.landmark_set = a.landmark_set;
    s.refine = a.refine;
    s.visible_only = a.visible_only;
    s.lambda = a.lambda;
    s.sigma_px = a.sigma;
    if (a.data.empty() || a.max_yaw_given) s.max_yaw_deg = a.max_yaw;
    const morph::MorphableModel model = morph::load_model(a.model);
    const fit::Fitter fitter(model);
    std::optional<Progress> progress;
    const fit::FitSetEvaluation evaluation = fit::evaluate_fit_set(fitter, a.model, s, [&](std::size_t total) {
        if (!progress) progress.emplace("eval fit", total, a.quiet);
        progress->advance();
    });
    if (progress) progress->finish();
    for (const std::string& error : evaluation.errors) std::fprintf(stderr, "facesynth: error: %s\n", error.c_str());
    if (!a.quiet) print_summary(evaluation.summary, !a.data.empty());
    if (!a.json.empty()) write_json_file(a.json, evaluation.json);
    if (const std::string failure = fit::fit_set_failure(s, evaluation); !failure.empty()) throw core::Error(failure);
}

namespace fs = std::filesystem;

struct ConventionsArgs {
    std::string photos;
    std::string model = "builtin";
    std::string jaw = "contour";
    double max_yaw = 30;
    double lambda = fit::FitOptions{}.lambda;
    std::string json;
    bool quiet = false;
};

void run_conventions(const ConventionsArgs& a) {
    const fs::path dir(a.photos);
    if (!fs::is_directory(dir)) throw core::file_error(a.photos, "folder not found");
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(dir))
        if (entry.is_regular_file() && entry.path().extension() == ".pts") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    std::vector<Eigen::Matrix2Xd> annotations;
    int unreadable = 0;
    for (const fs::path& file : files) {
        try {
            Eigen::Matrix2Xd points = morph::read_pts(file);
            if (points.cols() != morph::kNumIbugLandmarks) throw core::file_error(file.string(), "expected 68 points");
            annotations.push_back(std::move(points));
        } catch (const core::Error& e) {
            ++unreadable;
            std::fprintf(stderr, "facesynth: warning: %s (skipped)\n", e.what());
        }
    }
    if (annotations.empty()) throw core::file_error(a.photos, "no readable 68-point .pts files");
    const morph::MorphableModel model = morph::load_model(a.model);
    const fit::Fitter fitter(model);
    fit::FitOptions options;
    options.jaw = a.jaw == "fixed" ? fit::JawMode::kFixed : fit::JawMode::kContour;
    options.lambda = a.lambda;
    const fit::ConventionStudy study = fit::study_conventions(fitter, annotations, options, a.max_yaw);
    if (study.faces == 0) throw core::file_error(a.photos, "no annotation fitted within |yaw| <= " + std::to_string(a.max_yaw) + "°");
    if (!a.quiet) {
        std::printf("%s fitted to %d annotations (|yaw| <= %.0f°; %d turned further, %d failed, %d unreadable), %s jaw\n", model.name.c_str(),
                    study.faces, a.max_yaw, study.skipped_pose, study.failed, unreadable, a.jaw.c_str());
        std::printf("mean (annotation - model point), face frame, inter-ocular distances; largest first:\n");
        std::vector<int> order(morph::kNumIbugLandmarks);
        for (int i = 0; i < morph::kNumIbugLandmarks; ++i) order[static_cast<std::size_t>(i)] = i;
        std::sort(order.begin(), order.end(), [&](int x, int y) { return study.mean.col(x).norm() > study.mean.col(y).norm(); });
        for (int k = 0; k < 12; ++k) {
            const int i = order[static_cast<std::size_t>(k)];
            std::printf("  iBUG %2d: x %+.3f (sd %.3f), y %+.3f (sd %.3f)\n", i + 1, study.mean(0, i), study.stddev(0, i), study.mean(1, i), study.stddev(1, i));
        }
        if (study.depth.size() == 0) {
            std::printf("depth: not measured (%d faces, sin(yaw) spreads %.3f: it takes 3 faces and a spread of %.2f)\n", study.faces,
                        study.sin_yaw_stddev, fit::kMinDepthYawSpread);
        } else {
            // The jaw points are on the outline, whose surface point changes with the yaw: no depth of their own.
            std::printf("depth of points 18-68 (annotated point in front of the model's: x offset against sin(yaw)), inter-ocular distances; largest first:\n");
            std::vector<int> inner(morph::kNumIbugLandmarks - 17);
            std::iota(inner.begin(), inner.end(), 17);
            std::sort(inner.begin(), inner.end(), [&](int x, int y) { return std::abs(study.depth(x)) > std::abs(study.depth(y)); });
            for (int k = 0; k < 12; ++k) std::printf("  iBUG %2d: %+.3f\n", inner[static_cast<std::size_t>(k)] + 1, study.depth(inner[static_cast<std::size_t>(k)]));
        }
    }
    if (!a.json.empty()) {
        nlohmann::json j;
        j["model"] = model.name;
        j["jaw"] = a.jaw;
        j["max_yaw_deg"] = a.max_yaw;
        j["lambda"] = a.lambda;
        j["faces"] = study.faces;
        j["skipped_pose"] = study.skipped_pose;
        j["failed"] = study.failed;
        j["unreadable"] = unreadable;
        for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
            char key[32];
            for (int axis = 0; axis < 2; ++axis) {
                std::snprintf(key, sizeof key, "mean_%c_%02d", axis == 0 ? 'x' : 'y', i + 1);
                j[key] = study.mean(axis, i);
                std::snprintf(key, sizeof key, "sd_%c_%02d", axis == 0 ? 'x' : 'y', i + 1);
                j[key] = study.stddev(axis, i);
            }
            std::snprintf(key, sizeof key, "depth_%02d", i + 1);
            j[key] = study.depth.size() == 0 ? nlohmann::json(nullptr) : nlohmann::json(study.depth(i));
        }
        j["depth_measured"] = study.depth.size() != 0;
        j["sin_yaw_sd"] = study.sin_yaw_stddev;
        write_json_file(a.json, j);
    }
}

}  // namespace

void register_fit_commands(CLI::App& app) {
    auto fit_args = std::make_shared<FitArgs>();
    auto* cmd = app.add_subcommand("fit", "Fit the 3DMM (pose, identity, expression) to one face's 68 landmarks");
    cmd->add_option("--model", fit_args->model, "Model: builtin, a model file, or a folder such as shared/data/sfm")->capture_default_str();
    cmd->add_option("--landmarks", fit_args->landmarks, "iBUG .pts file with 68 points (1-based pixels)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--image", fit_args->image, "The photograph, for the overlay PNG (and the principal point)")->check(CLI::ExistingFile);
    cmd->add_option("--out", fit_args->out, "Output folder: fit.json, mesh.obj, mesh.glb, overlay.png")->required();
    cmd->add_option("--json", fit_args->json, "Also write the result JSON here");
    cmd->add_flag("--refine", fit_args->refine, "Refine with Ceres: perspective camera, robust loss, priors");
    cmd->add_option("--landmark-set", fit_args->landmark_set, "Landmark subset: 7, 13, 49 or 68")->capture_default_str()->check(CLI::IsMember({"7", "13", "49", "68"}));
    cmd->add_option("--jaw", fit_args->jaw, "Jaw landmarks: contour (follow the silhouette, photos) or fixed (model vertices)")->capture_default_str()->check(CLI::IsMember({"fixed", "contour"}));
    cmd->add_option("--lambda", fit_args->lambda, "Regularisation of identity and expression (see docs/fit.md)")->capture_default_str()->check(CLI::NonNegativeNumber);
    cmd->add_option("--iterations", fit_args->iterations, "Linear alternation rounds (at most)")->capture_default_str()->check(CLI::PositiveNumber);
    cmd->add_option("--components", fit_args->components, "Fit only the first K identity components (0: all)")->capture_default_str()->check(CLI::NonNegativeNumber);
    cmd->add_flag("--no-expression", fit_args->no_expression, "Keep the expression neutral");
    cmd->add_option("--focal", fit_args->focal, "Known focal length in pixels for --refine (0: estimate)")->capture_default_str()->check(CLI::NonNegativeNumber);
    cmd->add_option("--sigma", fit_args->sigma, "Landmark noise sigma in pixels for --refine")->capture_default_str()->check(CLI::PositiveNumber);
    cmd->add_flag("-q,--quiet", fit_args->quiet, "Print nothing on success");
    cmd->callback([fit_args] { run_fit(*fit_args); });

    auto lambda_args = std::make_shared<LambdaArgs>();
    auto* lam = app.add_subcommand("fit-lambda", "Choose the fit's regularisation lambda on synthetic validation fits");
    lam->add_option("--model", lambda_args->model, "Model: builtin, a model file, or a folder")->capture_default_str();
    lam->add_option("--lambdas", lambda_args->lambdas, "Candidate lambdas")->capture_default_str()->delimiter(',');
    lam->add_option("--noise", lambda_args->noise, "Landmark noise levels (pixels, 512x512 image)")->capture_default_str()->delimiter(',');
    lam->add_option("--count", lambda_args->count, "Validation cases per noise level")->capture_default_str()->check(CLI::PositiveNumber);
    lam->add_option("--seed", lambda_args->seed, "Seed of the validation set (keep it apart from test sets)")->capture_default_str();
    lam->add_option("--landmark-set", lambda_args->landmark_set, "Landmark subset: 7, 13, 49 or 68")->capture_default_str()->check(CLI::IsMember({"7", "13", "49", "68"}));
    lam->add_option("--json", lambda_args->json, "Write the scores (flat keys) here");
    lam->add_flag("-q,--quiet", lambda_args->quiet, "No progress output");
    lam->callback([lambda_args] { run_lambda(*lambda_args); });

    CLI::App* eval = &eval_group(app);
    auto eval_args = std::make_shared<FitEvalArgs>();
    auto* ev = eval->add_subcommand("fit", "Fit accuracy against ground truth: on a `synth` dataset (--data) or on cases generated in code");
    ev->add_option("--model", eval_args->model, "Model: builtin, a model file, or a folder (must be the dataset's model)")->capture_default_str();
    ev->add_option("--data", eval_args->data, "A `facesynth synth` dataset folder (manifest.jsonl, meta/); without it, --count cases are generated in code")->check(CLI::ExistingDirectory);
    ev->add_option("--mode", eval_args->mode, "With --data: fit the contour jaw labels with contour correspondences, or the fixed ones with fixed vertices")->capture_default_str()->check(CLI::IsMember({"fixed", "contour"}));
    ev->add_flag("--visible-only", eval_args->visible_only, "With --data: ignore landmarks flagged not visible in the chosen mode");
    ev->add_option("--count", eval_args->count, "Test cases generated in code (without --data)")->capture_default_str()->check(CLI::PositiveNumber);
    ev->add_option("--seed", eval_args->seed, "Seed of the generated test set, and of the --noise draws with --data")->capture_default_str();
    ev->add_option("--noise", eval_args->noise, "Gaussian landmark noise sigma (pixels)")->capture_default_str()->check(CLI::NonNegativeNumber);
    ev->add_option("--landmarks", eval_args->landmark_set, "Landmark subset: 7, 13, 49 or 68")->capture_default_str()->check(CLI::IsMember({"7", "13", "49", "68"}));
    ev->add_flag("--refine", eval_args->refine, "Refine with Ceres (true intrinsics)");
    ev->add_option("--lambda", eval_args->lambda, "Linear fit regularisation")->capture_default_str()->check(CLI::NonNegativeNumber);
    ev->add_option("--sigma", eval_args->sigma, "Landmark sigma (pixels) of the refinement")->capture_default_str()->check(CLI::PositiveNumber);
    auto* max_yaw = ev->add_option("--max-yaw", eval_args->max_yaw, "Yaw range +-degrees of the generated cases and of the yaw bins (with --data default 90)")->capture_default_str()->check(CLI::Range(1.0, 90.0));
    ev->add_option("--json", eval_args->json, "Write the flat metrics here");
    ev->add_flag("-q,--quiet", eval_args->quiet, "Only the JSON, no table or progress");
    ev->callback([eval_args, max_yaw] {
        eval_args->max_yaw_given = max_yaw->count() > 0;
        run_eval(*eval_args);
    });

    auto conventions_args = std::make_shared<ConventionsArgs>();
    auto* conventions = eval->add_subcommand("conventions", "Where annotators put each landmark against the model's definition: the model fitted to manual .pts files, mean residual per landmark and its depth (x offset against sin(yaw))");
    conventions->add_option("--photos", conventions_args->photos, "Folder of manual 68-point .pts files (images are not read)")->required();
    conventions->add_option("--model", conventions_args->model, "Model: builtin, a model file or folder")->capture_default_str();
    conventions->add_option("--jaw", conventions_args->jaw, "Jaw correspondences: contour (the outline, as 300-W annotates) or fixed vertices")
        ->capture_default_str()
        ->check(CLI::IsMember({"contour", "fixed"}));
    conventions->add_option("--max-yaw", conventions_args->max_yaw, "Only faces whose fitted |yaw| is at most this, degrees")->capture_default_str()->check(finite_range(0.0, 90.0));
    conventions->add_option("--lambda", conventions_args->lambda, "Identity prior weight of the fits (as textures' --fit-lambda)")
        ->capture_default_str()
        ->check(finite_range(0.0, 1e6));
    conventions->add_option("--json", conventions_args->json, "Write counts and per-landmark mean_<x|y>_NN, sd_<x|y>_NN, depth_NN (null unless depth_measured) as flat JSON");
    conventions->add_flag("-q,--quiet", conventions_args->quiet, "Only the JSON");
    conventions->callback([conventions_args] { run_conventions(*conventions_args); });
}

}  // namespace facesynth::cli
