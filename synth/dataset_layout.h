#pragma once
// A dataset folder's layout, shared by the writer (dataset.cpp), the COCO export (coco.cpp) and
// merge (merge.cpp): which files a sample has and where, sample keys, manifest lines, and what must
// agree for two runs to share a folder.
#include "synth/config.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace facesynth::synth {

// Per-sample files go here when only tars are wanted (removed when the run ends).
inline constexpr const char* kStagingFolder = ".staging";

// ".jpg" or ".png", as output.image_format says.
[[nodiscard]] std::string image_extension(const SynthConfig& config);

// The folder holding per-sample files: the dataset itself, or a staging folder when only tars are wanted.
[[nodiscard]] std::filesystem::path sample_root(const std::filesystem::path& out, const SynthConfig& config);

// A sample's files relative to the sample root, in write order (meta last: it marks completion).
struct SampleFile {
    std::string folder;
    std::string suffix;  // file name after the key
    std::string wds_extension;  // member name after the key in tars
};
[[nodiscard]] std::vector<SampleFile> sample_files(const SynthConfig& config);

// How samples 0..count-1 fall into WebDataset tars of output.wds_shard_size samples each (the last
// may be short).
struct TarLayout {
    std::int64_t count = 0;  // samples in the dataset
    std::int64_t size = 1;   // samples per tar
    [[nodiscard]] std::int64_t tars() const { return (count + size - 1) / size; }
    [[nodiscard]] std::int64_t tar_of(std::int64_t index) const { return index / size; }
    [[nodiscard]] std::int64_t first(std::int64_t tar) const { return tar * size; }
    [[nodiscard]] std::int64_t end(std::int64_t tar) const { return std::min(count, (tar + 1) * size); }  // one past its last sample
};
[[nodiscard]] inline TarLayout tar_layout(const SynthConfig& config) { return {config.count, config.output.wds_shard_size}; }

// The landmarks' box [x, y, width, height] clamped to the image (meta's and COCO's bbox).
[[nodiscard]] std::array<double, 4> landmark_box(const Eigen::Matrix2Xd& points, int width, int height);

// The index of a file name starting with a sample key ("s00000012..."), or nullopt.
[[nodiscard]] std::optional<std::int64_t> index_of_key(std::string_view name);

// What must agree for two runs to write into the same folder: the config without count and model
// spec, and the model's checksum.
[[nodiscard]] nlohmann::json dataset_identity(const nlohmann::json& config_json, const std::string& model_checksum);
// The first flattened key in which two identities differ; empty when they agree.
[[nodiscard]] std::string identity_mismatch(const nlohmann::json& a, const nlohmann::json& b);

// One manifest line (index, key, the sample's files or its tar) and manifest.jsonl's lines.
[[nodiscard]] nlohmann::json manifest_entry(std::int64_t index, const SynthConfig& config);
[[nodiscard]] std::string manifest_text(const std::vector<std::int64_t>& indices, const SynthConfig& config);

}  // namespace facesynth::synth
