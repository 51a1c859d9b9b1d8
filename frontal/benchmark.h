#pragma once
// The frontalisation benchmark against ground truth (docs/frontalise.md, "Ground-truth benchmark"): known textured
// faces rendered at yaws in 10° bins, frontalised from their true landmarks (and, with a
// LandmarkFinder, from detected ones), each frontal render scored against the face's true frontal
// render, with and without mirror filling. Face detection and landmarking (train/) come in through
// LandmarkFinder, so that this library does not depend on them.
#include "frontal/evaluate.h"
#include "morph/model.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace facesynth::frontal {

// Landmarks that a face detector and a landmark regressor find on `image`, or nullopt when no face
// is found. `true_landmarks` lets it pick the detection of this face.
using LandmarkFinder = std::function<std::optional<Eigen::Matrix2Xd>(const cv::Mat& image, const Eigen::Matrix2Xd& true_landmarks)>;

inline constexpr int kYawBins = 7;  // 10° bins of |yaw| from 0 to 70
[[nodiscard]] std::string yaw_bin_label(int bin);  // "0_10", "10_20", ...

struct BenchmarkOptions {
    int count = 10;  // identities, each seen once per yaw bin
    std::uint64_t seed = 20261122;
    int isomap_size = 512;
    int size = 256;  // the frontal render's side
    ViewOptions view;  // the posed renders
    // With a LandmarkFinder: the views it sees show this much around the face (with_context).
    double detection_framing = 2.5;
    std::filesystem::path examples;  // non-empty: write the first two identities' images here
};

// Sums over frontalised views; mean() divides by count.
struct ViewScores {
    int count = 0;
    double psnr = 0, ssim = 0, l1 = 0, psnr_mirror = 0, ssim_mirror = 0, l1_mirror = 0;
    double isomap_l1 = 0, isomap_psnr = 0, isomap_coverage = 0, isomap_l1_mirror = 0, isomap_coverage_mirror = 0;
    double cpu_ms = 0;

    void add(const ViewScores& other);
    [[nodiscard]] ViewScores mean() const;
    // The means under `prefix` (PREFIXcount, PREFIXpsnr, ...); an empty set has only its count.
    void write_json(nlohmann::json& j, const std::string& prefix) const;
};

struct BenchmarkResult {
    std::array<ViewScores, kYawBins> truth{};     // from the true landmarks
    std::array<ViewScores, kYawBins> detected{};  // from found landmarks (with a LandmarkFinder)
    bool has_detected = false;
    // Views whose face was not found, or whose fit on found landmarks failed, per bin.
    std::array<int, kYawBins> detector_misses{};
    int detection_image_size = 0;
    [[nodiscard]] ViewScores truth_all() const;
    [[nodiscard]] ViewScores detected_all() const;
    [[nodiscard]] int detector_misses_all() const;
};

// Deterministic: identity i's face and yaws depend only on (seed, i). `on_identity` is called after
// each identity. Throws core::Error when the model has no symmetry map, when options are invalid, or
// (naming the identity and yaw) when a fit on true landmarks fails.
[[nodiscard]] BenchmarkResult run_benchmark(const morph::MorphableModel& model, const BenchmarkOptions& options,
                                            const std::function<void()>& on_identity = {}, const LandmarkFinder& find_landmarks = {});

// The result as flat JSON: the options, yaw_BIN_* and all_* means, detected_* and detector_misses*
// with a LandmarkFinder.
[[nodiscard]] nlohmann::json to_json(const BenchmarkResult& result, const BenchmarkOptions& options, const morph::MorphableModel& model);

}  // namespace facesynth::frontal
