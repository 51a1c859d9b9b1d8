// `facesynth eval recognition`: the pose-invariant verification experiment (recognition/,
// docs/recognition.md): FRR at a fixed FAR per gallery pose and probe yaw bin, org vs LM.
#include "cli_common.h"
#include "commands.h"

#include "frontal/frontalise.h"
#include "recognition/experiment.h"
#include "morph/landmarks.h"
#include "train/face_box.h"
#include "train/regressor.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/model_io.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace facesynth::cli {
namespace {

struct RecognitionArgs {
    std::string model = "builtin";
    recognition::ExperimentOptions experiment;
    double far = 0.01;
    std::filesystem::path json;
    std::filesystem::path det_csv;
    std::filesystem::path examples;
    std::filesystem::path photos;
    std::string regressor = "dlib";
    bool regressor_given = false;  // synthetic run: also LM probes from this regressor's landmarks
    std::string detector = "auto";
    bool quiet = false;
};

std::string bin_prefix(const recognition::BinScores& bin) {
    return "gallery" + std::to_string(bin.gallery_yaw) + "_yaw_" + std::to_string(bin.low) + "_" + std::to_string(bin.high) + "_";
}

// Photographs in DIR/<identity>/*.{jpg,jpeg,png}: landmarks from IMAGE.pts beside the image, or the
// regressor on the largest Haar face. Images without a face are reported and left out.
void run_eval_recognition_photos(const RecognitionArgs& a) {
    namespace fs = std::filesystem;
    const morph::MorphableModel model = morph::load_model(a.model);
    std::vector<std::pair<std::string, fs::path>> files;  // identity, image
    for (const auto& folder : fs::directory_iterator(a.photos)) {
        if (!folder.is_directory()) continue;
        for (const auto& entry : fs::directory_iterator(folder.path())) {
            if (entry.is_regular_file() && core::is_image_file(entry.path())) files.emplace_back(folder.path().filename().string(), entry.path());
        }
    }
    std::sort(files.begin(), files.end());
    if (files.empty()) throw core::file_error(a.photos.string(), "no <identity>/<image> files with an image extension");

    const std::unique_ptr<train::LandmarkRegressor> regressor = train::open_regressor(a.regressor);
    const train::FaceDetector detector;
    frontal::Frontaliser frontaliser(model);
    frontal::FrontaliseOptions options;
    options.frontal.size = a.experiment.frontal_size;
    options.mirror_fill = a.experiment.mirror_fill;
    std::vector<cv::Mat> org, lm;
    std::vector<int> identity;
    std::vector<std::string> names;
    int skipped = 0, from_pts = 0;
    Progress progress("photos", files.size(), a.quiet);
    for (const auto& [who, path] : files) {
        try {
            const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
            if (image.empty()) throw core::file_error(path.string(), "cannot read image");
            fs::path pts = path;
            pts.replace_extension(".pts");
            Eigen::Matrix2Xd landmarks;
            if (fs::exists(pts)) {
                landmarks = morph::read_pts(pts);
                ++from_pts;
            } else {
                const cv::Mat gray = train::to_gray8(image);
                auto boxes = detector.detect(gray);
                if (boxes.empty()) throw core::file_error(path.string(), "no face found");
                const auto largest = std::max_element(boxes.begin(), boxes.end(), [](const train::FaceBox& x, const train::FaceBox& y) { return x.width < y.width; });
                landmarks = regressor->predict(gray, *largest);
            }
            org.push_back(recognition::eye_aligned_crop(image, landmarks, a.experiment.crop));
            lm.push_back(recognition::frontal_crop(frontaliser.frontalise(image, landmarks, options).frontal.image, a.experiment.crop));
            if (names.empty() || names.back() != who) names.push_back(who);
            identity.push_back(static_cast<int>(names.size()) - 1);
        } catch (const core::Error& e) {
            std::fprintf(stderr, "facesynth: error: %s (left out)\n", e.what());
            ++skipped;
        }
        progress.advance();
    }
    progress.finish();
    if (identity.size() < 2)
        throw core::file_error(a.photos.string(), std::to_string(identity.size()) + " usable photos (" + std::to_string(skipped) + " left out): at least 2 are needed");
    const recognition::MatchScores org_scores = recognition::match_all_pairs(org, identity, a.experiment);
    const recognition::MatchScores lm_scores = recognition::match_all_pairs(lm, identity, a.experiment);
    nlohmann::json j;
    j["model"] = model.name;
    j["photos"] = a.photos.string();
    j["photos_identities"] = names.size();
    j["photos_images"] = identity.size();
    j["photos_skipped"] = skipped;
    j["photos_landmarks_from_pts"] = from_pts;
    j["photos_landmarks_regressor"] = regressor->label();
    j["photos_genuine"] = org_scores.genuine.size();
    j["photos_impostor"] = org_scores.impostor.size();
    j["far"] = a.far;
    j["matcher"] = "lbph";
    j["mirror_fill"] = a.experiment.mirror_fill;
    const bool both = !org_scores.genuine.empty() && !org_scores.impostor.empty();
    if (both) {
        j["photos_frr_org"] = recognition::frr_at_far(org_scores, a.far);
        j["photos_frr_lm"] = recognition::frr_at_far(lm_scores, a.far);
        j["photos_auc_org"] = recognition::separation_auc(org_scores);
        j["photos_auc_lm"] = recognition::separation_auc(lm_scores);
    }
    if (!a.quiet) {
        std::printf("%zu photos of %zu identities (%d left out; landmarks: %d from .pts, the rest from %s): %zu genuine, %zu impostor pairs\n",
                    identity.size(), names.size(), skipped, from_pts, regressor->label().c_str(), org_scores.genuine.size(), org_scores.impostor.size());
        if (both)
            std::printf("FRR at FAR %g: org %.1f%%, LM %.1f%%; separation AUC: org %.3f, LM %.3f\n", a.far, 100 * j["photos_frr_org"].get<double>(),
                        100 * j["photos_frr_lm"].get<double>(), j["photos_auc_org"].get<double>(), j["photos_auc_lm"].get<double>());
    }
    if (!a.json.empty()) write_json_file(a.json, j);
    if (!both) throw core::Error(a.photos.string() + ": the usable photos form no genuine or no impostor pair");
}

void run_eval_recognition(const RecognitionArgs& a) {
    if (!a.photos.empty()) return run_eval_recognition_photos(a);
    const morph::MorphableModel model = morph::load_model(a.model);
    const std::clock_t cpu_start = std::clock();
    std::unique_ptr<train::LandmarkRegressor> regressor;
    std::unique_ptr<train::FaceDetector> detector;
    recognition::LandmarkFinder find_landmarks;
    if (a.regressor_given) {
        regressor = train::open_regressor(a.regressor);
        const train::LandmarkRegressor* const regressors[] = {regressor.get()};
        detector = std::make_unique<train::FaceDetector>(train::choose_detector(a.detector, regressors));
        find_landmarks = [&](const cv::Mat& image, const Eigen::Matrix2Xd& truth) -> std::optional<Eigen::Matrix2Xd> {
            const cv::Mat gray = train::to_gray8(image);
            const auto box = train::match_detection(detector->detect(gray), truth);
            if (!box) return std::nullopt;
            return regressor->predict(gray, *box);
        };
    }
    recognition::ExperimentResult result;
    {
        Progress progress("identities", static_cast<std::size_t>(a.experiment.identities), a.quiet);
        result = recognition::run_experiment(model, a.experiment, [&] { progress.advance(); }, find_landmarks);
        progress.finish();
    }
    const double cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;

    nlohmann::json j;
    j["model"] = model.name;
    j["identities"] = a.experiment.identities;
    j["seed"] = a.experiment.seed;
    j["images"] = result.images;
    j["failed_frontalisations"] = result.failed_frontalisations;
    j["far"] = a.far;
    j["matcher"] = "lbph";
    j["lbph_radius"] = a.experiment.lbph.radius;
    j["lbph_neighbours"] = a.experiment.lbph.neighbours;
    j["lbph_grid"] = a.experiment.lbph.grid;
    j["crop_size"] = a.experiment.crop.size;
    j["landmarks"] = "ground truth";
    j["mirror_fill"] = a.experiment.mirror_fill;
    j["cpu_s"] = cpu_s;
    if (result.detected) {
        j["detected_regressor"] = regressor->label();
        j["detector"] = train::detector_name(detector->kind());
        j["detection_framing"] = a.experiment.detection_framing;
        j["detector_misses"] = result.detector_misses;
    }
    std::string det = "gallery_deg,probe_yaw_low,probe_yaw_high,method,far,frr\n";
    if (!a.quiet) {
        std::printf("%-9s %-9s %9s %9s %12s %8s %8s", "gallery", "probes", "FRR org", "FRR LM", "improvement", "AUC org", "AUC LM");
        if (result.detected) std::printf(" %11s %10s %7s", "FRR LM det", "AUC LM det", "misses");
        std::printf("\n");
    }
    for (const auto& bin : result.bins) {
        const std::string prefix = bin_prefix(bin);
        const double org = recognition::frr_at_far(bin.org, a.far), lm = recognition::frr_at_far(bin.lm, a.far);
        j[prefix + "frr_org"] = org;
        j[prefix + "frr_lm"] = lm;
        j[prefix + "frr_improvement"] = org - lm;
        j[prefix + "auc_org"] = recognition::separation_auc(bin.org);
        j[prefix + "auc_lm"] = recognition::separation_auc(bin.lm);
        j[prefix + "genuine"] = bin.lm.genuine.size();
        j[prefix + "impostor"] = bin.lm.impostor.size();
        if (result.detected) {
            j[prefix + "frr_lm_detected"] = recognition::frr_at_far(bin.lm_detected, a.far);
            j[prefix + "auc_lm_detected"] = recognition::separation_auc(bin.lm_detected);
            j[prefix + "detector_misses"] = bin.detector_misses;
        }
        if (!a.quiet) {
            std::printf("%5d°    %3d-%-3d°  %8.1f%% %8.1f%% %+10.1f pt %8.3f %8.3f", bin.gallery_yaw, bin.low, bin.high, 100 * org, 100 * lm,
                        100 * (org - lm), j[prefix + "auc_org"].get<double>(), j[prefix + "auc_lm"].get<double>());
            if (result.detected)
                std::printf(" %10.1f%% %10.3f %7d", 100 * j[prefix + "frr_lm_detected"].get<double>(), j[prefix + "auc_lm_detected"].get<double>(),
                            bin.detector_misses);
            std::printf("\n");
        }
        std::vector<std::pair<const char*, const recognition::MatchScores*>> methods{{"org", &bin.org}, {"lm", &bin.lm}};
        if (result.detected) methods.emplace_back("lm_detected", &bin.lm_detected);
        for (const auto& [method, scores] : methods)
            for (const auto& point : recognition::det_curve(*scores)) {
                char line[160];
                std::snprintf(line, sizeof line, "%d,%d,%d,%s,%.6g,%.6g\n", bin.gallery_yaw, bin.low, bin.high, method, point.far, point.frr);
                det += line;
            }
    }
    if (!a.quiet) {
        std::printf("%d identities, %d images (%d could not be frontalised), LBPH, FAR = %g; %.1f s CPU\n", a.experiment.identities, result.images,
                    result.failed_frontalisations, a.far, cpu_s);
        if (result.detected)
            std::printf("LM det: probes frontalised from %s landmarks on %s boxes (views at framing %.1f); %d probes not acquired, counted as "
                        "rejected\n",
                        regressor->label().c_str(), train::detector_name(detector->kind()), a.experiment.detection_framing,
                        result.detector_misses);
    }
    if (!a.json.empty()) write_json_file(a.json, j);
    if (!a.det_csv.empty()) core::write_file_atomically(a.det_csv, det);
    if (!a.examples.empty()) {
        std::vector<unsigned char> png;
        if (result.examples.empty() || !cv::imencode(".png", result.examples, png)) throw core::file_error(a.examples.string(), "PNG encoding failed");
        core::write_file_atomically(a.examples, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    }
}

}  // namespace

void register_recognition_commands(CLI::App& app) {
    auto a = std::make_shared<RecognitionArgs>();
    auto* cmd = eval_group(app).add_subcommand(
        "recognition", "Pose-invariant verification on synthetic identities: eye-aligned crops (org) vs frontal renderings (LM), LBPH matcher");
    auto& e = a->experiment;
    cmd->add_option("--model", a->model, "Model: builtin, a model file, or a folder such as shared/data/sfm")->capture_default_str();
    cmd->add_option("--identities,-n", e.identities, "Synthetic identities (one shape and texture each)")->check(CLI::Range(2, 100000))->capture_default_str();
    cmd->add_option("--seed", e.seed, "Random seed (identity i depends only on seed and i)")->capture_default_str();
    cmd->add_option("--gallery", e.gallery_yaws, "Gallery yaws in degrees, one gallery each")->check(CLI::Range(0, 90))->capture_default_str();
    cmd->add_option("--probe-max-yaw", e.probe_max_yaw, "Probe |yaw| bins cover [0, this)")->check(CLI::Range(1, 90))->capture_default_str();
    cmd->add_option("--probe-bin", e.probe_bin_width, "Probe bin width, degrees")->check(CLI::Range(1, 90))->capture_default_str();
    cmd->add_option("--size", e.image_size, "Rendered image side, px")->check(CLI::Range(64, 2048))->capture_default_str();
    cmd->add_option("--crop", e.crop.size, "Side of the matched grey images (org crop and LM rendering), px")->check(CLI::Range(16, 512))->capture_default_str();
    cmd->add_flag("--mirror-fill", e.mirror_fill, "LM: fill hidden texels from the mirror side (the paper's method did not)");
    cmd->add_option("--far", a->far, "False accept rate at which FRR is reported")->check(CLI::Range(0.0, 1.0))->capture_default_str();
    cmd->add_option("--json", a->json, "Write flat JSON results here (keys in docs/recognition.md)");
    cmd->add_option("--det-csv", a->det_csv, "Write the DET curves here (gallery_deg,probe_yaw_low,probe_yaw_high,method,far,frr)");
    cmd->add_option("--examples", a->examples, "Write the first identities' matched images here (PNG: org row over LM row, galleries then probes)");
    cmd->add_option("--photos", a->photos,
                    "Instead of synthetic faces: photographs in DIR/<identity>/, every pair matched (landmarks from IMAGE.pts or --regressor)")
        ->check(CLI::ExistingDirectory);
    auto* regressor = cmd->add_option("--regressor", a->regressor,
                                      "Landmarks found by this regressor (dlib, an .sdm file, ...) on detected boxes: with --photos for images "
                                      "without .pts; otherwise, when given, an extra LM column whose probes are frontalised from them")
                          ->capture_default_str();
    add_detector_option(*cmd, a->detector);
    cmd->add_option("--detection-framing", e.detection_framing,
                    "With --regressor: the detector's probe views show this much around the face (same camera, larger image)")
        ->check(CLI::Range(1.5, 4.0))
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or table");
    cmd->callback([a, regressor] {
        a->regressor_given = regressor->count() > 0;
        run_eval_recognition(*a);
    });
}

}  // namespace facesynth::cli
