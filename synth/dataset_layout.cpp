#include "synth/dataset_layout.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "synth/dataset.h"
#include "synth/scene.h"

#include <charconv>
#include <cstdio>
#include <cstdlib>

namespace facesynth::synth {
namespace fs = std::filesystem;

nlohmann::json manifest_entry(std::int64_t index, const SynthConfig& config) {
    const auto formats = parse_formats(config.output.formats);
    const std::string key = sample_key(index);
    nlohmann::json line = {{"index", index}, {"key", key}};
    if (formats.folder || formats.coco)
        for (const auto& file : sample_files(config)) line[file.folder == "images" ? "image" : file.folder] = file.folder + "/" + key + file.suffix;
    if (formats.wds) line["tar"] = wds_tar_name(config.output.wds_prefix, tar_layout(config).tar_of(index));
    return line;
}

std::string manifest_text(const std::vector<std::int64_t>& indices, const SynthConfig& config) {
    std::string text;
    for (const auto index : indices) text += manifest_entry(index, config).dump() + "\n";
    return text;
}

std::string image_extension(const SynthConfig& config) { return config.output.image_format == "jpg" ? ".jpg" : ".png"; }

fs::path sample_root(const fs::path& out, const SynthConfig& config) {
    const auto formats = parse_formats(config.output.formats);
    return formats.folder || formats.coco ? out : out / kStagingFolder;
}

std::vector<SampleFile> sample_files(const SynthConfig& config) {
    const std::string image = image_extension(config);
    std::vector<SampleFile> files{{"images", image, image}, {"landmarks", ".pts", ".pts"}};
    if (config.output.depth) files.push_back({"depth", ".exr", ".depth.exr"});
    if (config.output.mask) files.push_back({"mask", ".png", ".mask.png"});
    if (config.output.normals) files.push_back({"normals", ".png", ".normals.png"});
    if (config.output.labels) files.push_back({"labels", ".png", ".labels.png"});
    files.push_back({"meta", ".json", ".json"});
    return files;
}

std::optional<std::int64_t> index_of_key(std::string_view name) {
    if (name.size() < 9 || name[0] != 's') return std::nullopt;
    std::int64_t index = 0;
    const auto result = std::from_chars(name.data() + 1, name.data() + 9, index);
    if (result.ec != std::errc() || result.ptr != name.data() + 9) return std::nullopt;
    return index;
}

std::string identity_mismatch(const nlohmann::json& a, const nlohmann::json& b) {
    const auto flat_a = a.flatten(), flat_b = b.flatten();
    for (const auto& [key, value] : flat_a.items())
        if (!flat_b.contains(key) || flat_b[key] != value) return key;
    for (const auto& [key, value] : flat_b.items())
        if (!flat_a.contains(key)) return key;
    return {};
}

nlohmann::json dataset_identity(const nlohmann::json& config_json, const std::string& model_checksum) {
    nlohmann::json identity = config_json;
    identity.erase("count");
    identity.erase("model");
    identity["model_checksum"] = model_checksum;
    return identity;
}

Shard parse_shard(std::string_view text, int auto_total) {
    Shard shard;
    if (text == "auto") {
        const auto env_int = [](const char* name) -> std::optional<int> {
            const char* value = std::getenv(name);
            if (!value || !*value) return std::nullopt;
            int v = 0;
            const auto end = value + std::strlen(value);
            if (std::from_chars(value, end, v).ptr != end) throw core::Error(std::string("--shard auto: environment variable ") + name + " is not an integer");
            return v;
        };
        if (const auto k8s = env_int("JOB_COMPLETION_INDEX")) {
            shard.index = *k8s;
            shard.count = auto_total > 0 ? auto_total : env_int("FACESYNTH_SHARD_COUNT").value_or(0);
            if (shard.count <= 0) throw core::Error("--shard auto: JOB_COMPLETION_INDEX is set but the total is not (pass --shard-count or set FACESYNTH_SHARD_COUNT)");
        } else if (const auto slurm = env_int("SLURM_ARRAY_TASK_ID")) {
            shard.index = *slurm - env_int("SLURM_ARRAY_TASK_MIN").value_or(0);
            shard.count = auto_total > 0 ? auto_total : env_int("SLURM_ARRAY_TASK_COUNT").value_or(0);
            if (shard.count <= 0) throw core::Error("--shard auto: SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not (pass --shard-count)");
        }
    } else {
        const auto slash = text.find('/');
        const auto parse = [&](std::string_view part, int& out) {
            const auto r = std::from_chars(part.data(), part.data() + part.size(), out);
            return r.ec == std::errc() && r.ptr == part.data() + part.size();
        };
        if (slash == std::string_view::npos || !parse(text.substr(0, slash), shard.index) || !parse(text.substr(slash + 1), shard.count))
            throw core::Error("--shard '" + std::string(text) + "': expected K/N (0-based K) or auto");
    }
    if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count)
        throw core::Error("--shard: index " + std::to_string(shard.index) + " is outside 0.." + std::to_string(shard.count - 1));
    return shard;
}

std::int64_t shard_unit(const SynthConfig& config) {
    return parse_formats(config.output.formats).wds ? config.output.wds_shard_size : 1;
}

bool in_shard(std::int64_t index, const Shard& shard, std::int64_t unit) { return (index / unit) % shard.count == shard.index; }

std::string manifest_name(const Shard& shard) {
    if (shard.count == 1) return "manifest.jsonl";
    return "manifest-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count) + ".jsonl";
}

std::string coco_name(const Shard& shard) {
    if (shard.count == 1) return "coco.json";
    return "coco-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count) + ".json";
}

std::string wds_tar_name(const std::string& prefix, std::int64_t tar_index) {
    char number[32];
    std::snprintf(number, sizeof number, "%06lld", static_cast<long long>(tar_index));
    return prefix + "-" + number + ".tar";
}

std::array<double, 4> landmark_box(const Eigen::Matrix2Xd& points, int width, int height) {
    const auto clamp_x = [&](double v) { return std::clamp(v, 0.0, width - 1.0); };
    const auto clamp_y = [&](double v) { return std::clamp(v, 0.0, height - 1.0); };
    const double x0 = clamp_x(points.row(0).minCoeff()), x1 = clamp_x(points.row(0).maxCoeff());
    const double y0 = clamp_y(points.row(1).minCoeff()), y1 = clamp_y(points.row(1).maxCoeff());
    return {x0, y0, x1 - x0, y1 - y0};
}

nlohmann::json read_json_file(const fs::path& path) {
    try {
        return nlohmann::json::parse(core::read_file(path));
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("invalid JSON: ") + e.what());
    }
}

SynthConfig read_dataset_config(const fs::path& dataset) {
    const fs::path path = dataset / "dataset.json";
    try {
        SynthConfig config = config_from_json(nlohmann::json::parse(core::read_file(path)).at("config"));
        validate(config);  // a hand-edited file must not reach merge with, say, wds_shard_size 0
        return config;
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("not a facesynth dataset.json: ") + e.what());
    } catch (const core::Error& e) {
        throw core::file_error(path.string(), e.what());
    }
}

}  // namespace facesynth::synth
