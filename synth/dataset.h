#pragma once
// Writing a dataset: folder layout, manifest, dataset.json, WebDataset tars and COCO keypoints, with
// sharding, threads and resume. Sample i's files depend only on (config, model, i), so every split
// of the work produces the same bytes.
#include "morph/model.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace facesynth::synth {

// Shard `index` of `count` (0-based index).
struct Shard {
    int index = 0;
    int count = 1;
};

// "K/N" (0 <= K < N), or "auto": JOB_COMPLETION_INDEX (Kubernetes Indexed Job) with the total from
// FACESYNTH_SHARD_COUNT, or SLURM_ARRAY_TASK_ID with SLURM_ARRAY_TASK_COUNT (SLURM_ARRAY_TASK_MIN
// subtracted); neither set means 0/1. `auto_total` (> 0) overrides the total for "auto".
[[nodiscard]] Shard parse_shard(std::string_view text, int auto_total = 0);

// Samples are handed to shards in units: one WebDataset tar's worth when wds is written (so each tar
// is written by exactly one process), else single samples. Sample i belongs to shard (i / unit) % N.
[[nodiscard]] std::int64_t shard_unit(const SynthConfig& config);
[[nodiscard]] bool in_shard(std::int64_t index, const Shard& shard, std::int64_t unit);

// "manifest.jsonl" for 0/1, else "manifest-K-of-N.jsonl"; the same for coco(.json).
[[nodiscard]] std::string manifest_name(const Shard& shard);
[[nodiscard]] std::string coco_name(const Shard& shard);
// "{prefix}-000012.tar"
[[nodiscard]] std::string wds_tar_name(const std::string& prefix, std::int64_t tar_index);

struct RunOptions {
    SynthConfig config;
    std::filesystem::path out;
    int threads = 1;
    Shard shard;
    bool overwrite = false;
    render::RendererOptions renderer;
    // Called once before work starts (samples to make in this run, samples already on disk), then
    // after each finished sample, from worker threads (serialised).
    std::function<void(std::size_t todo, std::size_t already_done)> on_start;
    std::function<void()> on_sample;
};

struct RunResult {
    std::size_t generated = 0;     // samples made in this run
    std::size_t already_done = 0;  // samples of this shard found complete on disk
    std::size_t tars_written = 0;
    double seconds = 0;            // wall time of the generation phase
    StageTimes times;              // summed over threads
    std::string renderer;          // backend and GL renderer string, each distinct one the workers used joined by " + "
};

// Generates (or completes) this shard of the dataset in options.out. Throws core::Error naming
// the file or sample on failure; completed samples stay intact.
RunResult run_synth(const RunOptions& options, const morph::MorphableModel& model);

// The meta file of one sample: compact JSON text with a final newline, keys sorted (docs/synth.md
// lists them).
[[nodiscard]] std::string sample_meta(const Sample& sample, const SynthConfig& config, const morph::MorphableModel& model,
                                      const std::string& model_checksum);

struct MergeResult {
    std::size_t samples = 0;
    std::size_t missing = 0;     // indices below count that no manifest lists
    std::size_t duplicates = 0;  // entries listed by more than one manifest (identical, kept once)
};

// Merges the shard manifests found in `inputs` (dataset folders made with the same config) into
// `out`/manifest.jsonl (and coco.json when coco is a format). Files of inputs other than `out` are
// hard-linked (or copied) into `out`.
MergeResult merge_datasets(const std::vector<std::filesystem::path>& inputs, const std::filesystem::path& out);

// Builds a COCO keypoints JSON from the meta files of the listed samples (their keys image_width,
// image_height, bbox, landmarks, visibility, occluded); images are "images/KEY{image_extension}".
inline constexpr const char* kSynthCocoDescription = "facesynth synthetic faces";
[[nodiscard]] nlohmann::json coco_from_meta(const std::filesystem::path& dataset, const std::vector<std::int64_t>& indices,
                                            const std::string& image_extension, const std::string& description);

// Parses a JSON file of a dataset folder (a meta file); throws core::Error
// "<path>: invalid JSON: …" when it is not JSON.
[[nodiscard]] nlohmann::json read_json_file(const std::filesystem::path& path);

// Reads dataset.json's configuration; throws core::Error naming the file.
[[nodiscard]] SynthConfig read_dataset_config(const std::filesystem::path& dataset);

}  // namespace facesynth::synth
