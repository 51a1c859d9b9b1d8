#pragma once
// Ground-truth fit evaluation on a rendered `facesynth synth` dataset (docs/fit.md, "eval fit on a
// dataset"): reading the manifest and the per-sample meta JSON (docs/synth.md), preparing each
// sample's landmarks (jaw mode, visibility, seeded pixel noise) and summarising FitMetrics overall and
// per yaw bin under the flat keys `facesynth eval fit --json` writes.
#include "fit/evaluate.h"
#include "morph/camera.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::fit {

// One line of DIR/manifest.jsonl.
struct DatasetEntry {
    std::int64_t index = 0;
    std::string key;
    std::filesystem::path meta;  // DIR/meta/KEY.json
};

// Every sample DIR/manifest.jsonl lists, in file order. Throws core::Error naming the file (and
// line) when the manifest is missing or a line is not a manifest entry.
[[nodiscard]] std::vector<DatasetEntry> read_dataset_manifest(const std::filesystem::path& dir);

// The `model_checksum` recorded in DIR/dataset.json; empty when the dataset has no dataset.json.
// Throws core::Error naming the file when it exists but cannot be parsed.
[[nodiscard]] std::string dataset_model_checksum(const std::filesystem::path& dir);

// The ground truth of one sample, as in meta/KEY.json.
struct DatasetSample {
    std::string key;
    std::int64_t index = 0;
    std::string model_checksum;
    FitTruth truth;                           // alpha (σ units) and R
    std::vector<float> psi;
    morph::Intrinsics intrinsics;                    // the renderer's camera
    Eigen::Matrix2Xd landmarks_fixed;         // 2 x 68, 0-based pixels (NaN where the file has null)
    Eigen::Matrix2Xd landmarks_contour;
    std::vector<int> visibility_fixed;        // 68 x 0/1
    std::vector<int> visibility_contour;
};

// Reads and validates meta/KEY.json. Throws core::Error naming the file and the offending key.
[[nodiscard]] DatasetSample read_sample_meta(const std::filesystem::path& path);

struct DatasetEvalOptions {
    // The fit and refinement settings; fit.jaw chooses which labels are fitted: kFixed the
    // `landmarks_fixed` (fixed jaw vertices), kContour the `landmarks_contour` (silhouette points, the
    // fitter re-chooses the jaw correspondences). refine_options.intrinsics is replaced by the
    // sample's true intrinsics.
    EvalOptions eval;
    double noise_px = 0;              // σ of Gaussian noise added to x and y of every landmark
    std::uint64_t noise_seed = 0;     // noise of sample i: make_rng(noise_seed, i, RandomStream::kNoise)
    bool visible_only = false;        // weight 0 for landmarks flagged not visible in the chosen mode
};

// The landmarks `options` fits for `sample` (labels of the chosen jaw mode plus the seeded noise).
[[nodiscard]] Eigen::Matrix2Xd dataset_sample_landmarks(const DatasetSample& sample, const DatasetEvalOptions& options);

// Fits one sample and compares with its truth. Throws core::Error when the fit fails.
[[nodiscard]] FitMetrics evaluate_dataset_sample(const Fitter& fitter, const DatasetSample& sample,
                                                 const DatasetEvalOptions& options);

// Means of FitMetrics over a set of fits.
struct MetricsSummary {
    int count = 0;
    double yaw = 0, pitch = 0, roll = 0, vertex = 0, meanshape = 0, alpha = 0, reprojection = 0, ms = 0, cpu_ms = 0;
    double yaw_bias = 0, pitch_bias = 0, roll_bias = 0;  // sums of the signed errors
    void add(const FitMetrics& m);
    // Writes PREFIX + count, yaw_mae_deg, pitch_mae_deg, roll_mae_deg, yaw_bias_deg, pitch_bias_deg,
    // roll_bias_deg (mean fitted - true), vertex_rmse_mm, vertex_rmse_mm_meanshape, alpha_rmse,
    // reprojection_px, ms_per_fit, cpu_ms_per_fit (means; 0 when empty).
    void write(nlohmann::json& j, const std::string& prefix) const;
};

// Overall and per 15° bin of the true yaw over [-max_yaw, max_yaw) (yaws outside go to the end bins).
struct YawBinnedSummary {
    explicit YawBinnedSummary(double max_yaw_deg);
    void add(const FitMetrics& m);
    // "yaw_-60_-45_" etc., the JSON key prefix of bin b; label() is "[-60,-45)".
    [[nodiscard]] std::string prefix(std::size_t b) const;
    [[nodiscard]] std::string label(std::size_t b) const;
    // Overall keys without a prefix plus every bin's keys (empty bins included, so keys are stable).
    void write(nlohmann::json& j) const;

    double max_yaw_deg;
    MetricsSummary all;
    std::vector<MetricsSummary> bins;
};

// `facesynth eval fit` as a function (the CLI and the Python package call it): the settings, and a
// summary whose `json` holds the flat keys of `--json`.
struct FitSetEvalSettings {
    std::string data;              // a `facesynth synth` dataset folder; empty: `count` cases generated in code
    std::string mode = "contour";  // with data: "contour" or "fixed" labels (generated cases are always fixed)
    int count = 300;
    std::int64_t seed = 424242;    // the generated set, and the noise draws with data
    double noise_px = 0;
    std::string landmark_set = "68";
    bool refine = false;
    bool visible_only = false;
    double lambda = FitOptions{}.lambda;
    double sigma_px = RefineOptions{}.landmark_sigma_px;
    std::optional<double> max_yaw_deg;  // generated: the ±range (60 when unset); with data: the bins' range (90)
};
struct FitSetEvaluation {
    YawBinnedSummary summary{60};
    std::size_t samples = 0;          // cases generated, or samples the manifest lists
    std::vector<std::string> errors;  // one line per skipped sample: unreadable meta or failed fit
    nlohmann::json json;
};
// Throws core::Error naming the first setting out of range.
void check_fit_set_settings(const FitSetEvalSettings& settings);
// Throws core::Error for a setting out of range, a missing or empty manifest, and a dataset made with
// another model (`model_label` names the model in that message); a sample that cannot be read or
// fitted is skipped and listed in `errors`. `on_case(total)` runs after every case.
[[nodiscard]] FitSetEvaluation evaluate_fit_set(const Fitter& fitter, const std::string& model_label,
                                                const FitSetEvalSettings& settings, const std::function<void(std::size_t total)>& on_case = {});
// The error `facesynth eval fit` ends with when samples were skipped (empty when none were).
[[nodiscard]] std::string fit_set_failure(const FitSetEvalSettings& settings, const FitSetEvaluation& evaluation);

}  // namespace facesynth::fit
