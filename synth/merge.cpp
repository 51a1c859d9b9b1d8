// `facesynth synth merge`: shard manifests (and their files) into one dataset folder.
#include "synth/dataset.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "synth/dataset_layout.h"
#include "synth/scene.h"

#include <map>
#include <sstream>

namespace facesynth::synth {
namespace fs = std::filesystem;
namespace {

// What decides whether two dataset folders may be merged: the configuration and model checksum of
// their dataset.json (read_dataset_config checks the configuration itself first).
nlohmann::json read_dataset_identity(const fs::path& dataset) {
    const fs::path path = dataset / "dataset.json";
    (void)read_dataset_config(dataset);
    try {
        const nlohmann::json info = nlohmann::json::parse(core::read_file(path));
        const auto checksum = info.find("model_checksum");
        if (checksum != info.end() && !checksum->is_string()) throw core::file_error(path.string(), "model_checksum must be a string");
        return dataset_identity(info.at("config"), checksum == info.end() ? "" : checksum->get<std::string>());
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("not a facesynth dataset.json: ") + e.what());
    }
}

// The sample index of one manifest line; a line that is not an entry of this dataset (no integer
// "index" below count, or a "key" that is not that index's) is an error naming file and line.
std::int64_t manifest_line_index(const std::string& line, const SynthConfig& config, const fs::path& manifest, int line_number) {
    const auto bad = [&](const std::string& problem) {
        return core::file_error(manifest.string(), "line " + std::to_string(line_number) + ": " + problem);
    };
    const auto parsed = nlohmann::json::parse(line, nullptr, false);
    if (parsed.is_discarded() || !parsed.is_object()) throw bad("not a manifest entry (a JSON object per line)");
    const auto index = parsed.find("index");
    if (index == parsed.end() || !index->is_number_integer()) throw bad("no integer \"index\" key");
    const auto value = index->get<std::int64_t>();
    if (value < 0 || value >= config.count)
        throw bad("index " + std::to_string(value) + " is outside the dataset's 0.." + std::to_string(config.count - 1));
    const auto key = parsed.find("key");
    if (key != parsed.end() && !(key->is_string() && key->get<std::string>() == sample_key(value)))
        throw bad("key " + key->dump() + " does not match index " + std::to_string(value));
    return value;
}

}  // namespace

MergeResult merge_datasets(const std::vector<fs::path>& inputs, const fs::path& out) {
    if (inputs.empty()) throw core::Error("synth merge: name at least one dataset folder");
    const fs::path first_info = inputs.front() / "dataset.json";
    const SynthConfig config = read_dataset_config(inputs.front());
    const auto formats = parse_formats(config.output.formats);
    const auto identity = read_dataset_identity(inputs.front());
    std::map<std::int64_t, fs::path> sources;  // index -> folder holding it
    MergeResult result;
    for (const auto& input : inputs) {
        const auto difference = identity_mismatch(identity, read_dataset_identity(input));
        if (!difference.empty())
            throw core::file_error(input.string(), "made with a different config than " + inputs.front().string() + " ('" + difference + "' differs)");
        for (const auto& entry : fs::directory_iterator(input)) {
            const std::string name = entry.path().filename().string();
            if (!name.starts_with("manifest") || !name.ends_with(".jsonl")) continue;
            std::stringstream lines(core::read_file(entry.path()));
            std::string line;
            int line_number = 0;
            while (std::getline(lines, line)) {
                ++line_number;
                if (line.empty()) continue;
                if (!sources.emplace(manifest_line_index(line, config, entry.path(), line_number), input).second) ++result.duplicates;
            }
        }
    }
    const auto files = sample_files(config);
    std::vector<std::int64_t> indices;
    std::vector<std::pair<fs::path, fs::path>> links;
    const TarLayout tars = tar_layout(config);
    for (const auto& [index, source] : sources) {
        indices.push_back(index);
        if (formats.folder || formats.coco)
            for (const auto& file : files) links.emplace_back(source / file.folder / (sample_key(index) + file.suffix), out / file.folder / (sample_key(index) + file.suffix));
        if (formats.wds && tars.first(tars.tar_of(index)) == index) {
            const auto tar = wds_tar_name(config.output.wds_prefix, tars.tar_of(index));
            links.emplace_back(source / tar, out / tar);
        }
    }
    // Every file is checked before the first is linked: a missing one leaves `out` as it was.
    for (const auto& [from, to] : links)
        if (!fs::exists(from)) throw core::file_error(from.string(), "listed in a manifest but missing");
    std::error_code error;
    fs::create_directories(out, error);
    if (error) throw core::file_error(out.string(), "cannot create output folder: " + error.message());
    for (const auto& [from, to] : links) {
        if (fs::equivalent(from.parent_path(), to.parent_path(), error) || fs::exists(to)) continue;
        fs::create_directories(to.parent_path());
        const auto temp = core::temporary_path_for(to);
        fs::create_hard_link(from, temp, error);
        if (error) fs::copy_file(from, temp);
        core::commit_temporary_file(temp, to);
    }
    for (std::int64_t i = 0; i < config.count; ++i)
        if (!sources.count(i)) ++result.missing;
    result.samples = indices.size();
    // The COCO file is built (reading every meta file) before anything is written, so that a
    // damaged meta file leaves no manifest behind.
    const std::string coco = formats.coco ? coco_from_meta(out, indices, image_extension(config), kSynthCocoDescription).dump() + "\n" : "";
    if (!fs::exists(out / "dataset.json") || !fs::equivalent(inputs.front(), out)) core::write_file_atomically(out / "dataset.json", core::read_file(first_info));
    core::write_file_atomically(out / "manifest.jsonl", manifest_text(indices, config));
    if (formats.coco) core::write_file_atomically(out / "coco.json", coco);
    return result;
}

}  // namespace facesynth::synth
