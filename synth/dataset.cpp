#include "synth/dataset.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "synth/dataset_layout.h"
#include "morph/landmarks.h"
#include "synth/exr.h"
#include "synth/png.h"
#include "synth/stream.h"
#include "synth/tar.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <concepts>
#include <csignal>
#include <functional>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>
#include <string_view>
#include <map>
#include <memory>
#include <mutex>
#include <set>


namespace facesynth::synth {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

// Unit normals n as 8-bit RGB (n + 1) / 2; background (zero normal) stays black.
std::string encode_normals(const cv::Mat& normals, PngEncoder& png, const std::string& context) {
    cv::Mat rgb(normals.size(), CV_8UC3, cv::Scalar(0, 0, 0));
    for (int y = 0; y < normals.rows; ++y) {
        const auto* n = normals.ptr<cv::Vec3f>(y);
        auto* o = rgb.ptr<cv::Vec3b>(y);
        for (int x = 0; x < normals.cols; ++x)
            if (n[x] != cv::Vec3f(0, 0, 0))
                for (int c = 0; c < 3; ++c) o[x][c] = cv::saturate_cast<uchar>(127.5 * (n[x][c] + 1.0f));
    }
    return png.encode(rgb, context);
}

nlohmann::json dataset_json(const SynthConfig& config, const morph::MorphableModel& model, const std::string& checksum) {
    return {{"format", "facesynth-synth"},
            {"format_version", 1},
            {"tool_version", FACESYNTH_SYNTH_VERSION},
            {"count", config.count},
            {"seed", config.seed},
            {"model_name", model.name},
            {"model_checksum", checksum},
            {"model_vertices", model.num_vertices()},
            {"key_format", "s%08d"},
            {"config", to_json(config)}};
}

void remove_dataset_outputs(const fs::path& out) {
    for (const char* folder : {"images", "landmarks", "meta", "depth", "mask", "normals", "labels", kStagingFolder}) fs::remove_all(out / folder);
    for (const auto& entry : fs::directory_iterator(out)) {
        const std::string name = entry.path().filename().string();
        if (name.ends_with(".tar") || name.starts_with("manifest") || name.starts_with("coco") || name.starts_with("dataset.json"))
            fs::remove(entry.path());
    }
}

// Checks (or creates) dataset.json. A folder made with a different config is refused unless
// overwrite, which removes the old dataset first.
void prepare_folder(const fs::path& out, const SynthConfig& config, const morph::MorphableModel& model, const std::string& checksum,
                    bool overwrite) {
    std::error_code error;
    fs::create_directories(out, error);
    if (error) throw core::file_error(out.string(), "cannot create output folder: " + error.message());
    const fs::path info_path = out / "dataset.json";
    const nlohmann::json mine = dataset_json(config, model, checksum);
    if (fs::exists(info_path)) {
        nlohmann::json theirs;
        try {
            theirs = nlohmann::json::parse(core::read_file(info_path));
        } catch (const nlohmann::json::exception& e) {
            if (!overwrite) throw core::file_error(info_path.string(), std::string("unreadable dataset.json (use --overwrite to replace): ") + e.what());
        }
        if (!theirs.is_null()) {
            const auto difference = identity_mismatch(dataset_identity(theirs.value("config", nlohmann::json::object()), theirs.value("model_checksum", "")),
                                                      dataset_identity(mine["config"], checksum));
            if (!difference.empty() && !overwrite)
                throw core::file_error(out.string(), "holds a dataset made with a different config ('" + difference +
                                                   "' differs); use --overwrite to replace it or choose another folder");
            if (!difference.empty() || overwrite) remove_dataset_outputs(out);
        }
    } else if (overwrite) {
        remove_dataset_outputs(out);
    }
    core::write_file_atomically(info_path, mine.dump(2) + "\n");
}

bool process_alive(const std::string& pid_text) {
    int pid = 0;
    const auto result = std::from_chars(pid_text.data(), pid_text.data() + pid_text.size(), pid);
    if (result.ec != std::errc() || pid <= 0) return false;
    return ::kill(pid, 0) == 0 || errno == EPERM;
}

// Removes temporary files left by killed runs: those of this shard's samples, tars and manifest,
// and any other whose writing process no longer exists on this machine.
void remove_stale_temporaries(const fs::path& out, const fs::path& root, const SynthConfig& config, const Shard& shard) {
    const std::int64_t unit = shard_unit(config);
    const auto is_stale = [&](const std::string& name) {
        const auto tmp = name.find(".tmp.");
        if (tmp == std::string::npos) return false;
        const std::string base = name.substr(0, tmp);
        if (const auto index = index_of_key(base); index && base.size() >= 9 && base[9] == '.') return in_shard(*index, shard, unit);
        if (base == manifest_name(shard) || base == coco_name(shard)) return true;
        const std::string pid = name.substr(tmp + 5, name.find('.', tmp + 5) - (tmp + 5));
        return !process_alive(pid);
    };
    std::vector<fs::path> folders{out};
    for (const auto& file : sample_files(config)) folders.push_back(root / file.folder);
    for (const auto& folder : folders) {
        if (!fs::is_directory(folder)) continue;
        for (const auto& entry : fs::directory_iterator(folder)) {
            const std::string name = entry.path().filename().string();
            if (!is_stale(name)) continue;
            if (name.starts_with(config.output.wds_prefix + "-") && folder == out) {
                // A tar temp: stale if its tar belongs to this shard.
                const auto dash = config.output.wds_prefix.size() + 1;
                std::int64_t tar = 0;
                std::from_chars(name.data() + dash, name.data() + name.size(), tar);
                if (!in_shard(tar * unit, shard, unit)) continue;
            }
            std::error_code ignored;
            fs::remove(entry.path(), ignored);
        }
    }
}

struct ResumeScan {
    std::set<std::int64_t> done;  // this shard's samples complete on disk (their meta file or tar exists)
    std::vector<char> tar_done;   // per tar (with wds): complete on disk
    std::vector<std::int64_t> todo;
    std::size_t already_done = 0;
    std::map<std::int64_t, std::int64_t> tar_remaining;  // tar index -> samples still missing
};

// What a resumed run finds finished: samples whose meta file exists, and tars that hold every file
// of their samples (a larger count than the run that wrote one can make the last tar short).
ResumeScan scan_for_resume(const fs::path& out, const fs::path& root, const SynthConfig& config, const Shard& shard,
                           const std::vector<SampleFile>& files) {
    const auto formats = parse_formats(config.output.formats);
    const std::int64_t unit = shard_unit(config);
    const TarLayout tars = tar_layout(config);
    ResumeScan scan;
    for (const auto& entry : fs::directory_iterator(root / "meta")) {
        const std::string name = entry.path().filename().string();
        const auto index = index_of_key(name);
        if (index && name == sample_key(*index) + ".json" && *index < config.count && in_shard(*index, shard, unit)) scan.done.insert(*index);
    }
    const auto tar_is_complete = [&](const fs::path& tar, std::int64_t t) {
        if (!fs::exists(tar)) return false;
        const std::int64_t samples = tars.end(t) - tars.first(t);
        try {
            return list_tar(tar).size() == static_cast<std::size_t>(samples) * files.size();
        } catch (const core::Error&) {
            return false;
        }
    };
    scan.tar_done.assign(static_cast<std::size_t>(formats.wds ? tars.tars() : 0), 0);
    for (std::int64_t t = 0; t < static_cast<std::int64_t>(scan.tar_done.size()); ++t)
        scan.tar_done[static_cast<std::size_t>(t)] = in_shard(tars.first(t), shard, unit) && tar_is_complete(out / wds_tar_name(config.output.wds_prefix, t), t);
    for (std::int64_t i = 0; i < config.count; ++i) {
        if (!in_shard(i, shard, unit)) continue;
        const bool in_finished_tar = formats.wds && scan.tar_done[static_cast<std::size_t>(tars.tar_of(i))];
        if (scan.done.count(i) || in_finished_tar) {
            ++scan.already_done;
            scan.done.insert(i);
            continue;
        }
        scan.todo.push_back(i);
        if (formats.wds) ++scan.tar_remaining[tars.tar_of(i)];
    }
    return scan;
}

// The contents of a sample's files, in the order of `files`.
std::vector<std::string> encode_sample(const Sample& sample, const std::vector<SampleFile>& files, const SynthConfig& config,
                                       const morph::MorphableModel& model, const std::string& checksum, PngEncoder& png,
                                       const std::string& key) {
    std::vector<std::string> contents;
    contents.reserve(files.size());
    for (const auto& file : files) {
        if (file.folder == "images") contents.push_back(encode_image(sample.image, config.output.image_format, config.output.jpeg_quality, png, key));
        else if (file.folder == "landmarks") contents.push_back(morph::format_pts(chosen_landmarks(sample.labels, config.landmarks.mode)));
        else if (file.folder == "depth") contents.push_back(encode_depth_exr(sample.depth, key));
        else if (file.folder == "mask") contents.push_back(png.encode(sample.mask, key));
        else if (file.folder == "normals") contents.push_back(encode_normals(sample.normals, png, key));
        else if (file.folder == "labels") contents.push_back(png.encode(sample.regions, key));
        else contents.push_back(sample_meta(sample, config, model, checksum));
    }
    return contents;
}

// The shard's manifest and WebDataset tars while its samples are made: the manifest is rebuilt from
// what is on disk, then appended to as samples finish; a tar is written when its last sample is.
// sample_done may be called from any thread.
class ShardOutputs {
public:
    ShardOutputs(const RunOptions& options, const fs::path& root, const std::vector<SampleFile>& files, ResumeScan& scan)
        : options_(options), config_(options.config), root_(root), files_(files), formats_(parse_formats(config_.output.formats)),
          tars_(tar_layout(config_)), tar_remaining_(scan.tar_remaining), manifest_path_(options.out / manifest_name(options.shard)) {
        core::write_file_atomically(manifest_path_, manifest_text({scan.done.begin(), scan.done.end()}, config_));
        manifest_.reset(std::fopen(manifest_path_.c_str(), "a"));
        if (!manifest_) throw core::file_error(manifest_path_.string(), "cannot open for appending");
    }

    // Tars whose samples all exist but that a killed run did not finish; returns how many were written.
    std::size_t write_unfinished_tars(const ResumeScan& scan) {
        if (!formats_.wds) return 0;
        std::size_t written = 0;
        const std::int64_t unit = shard_unit(config_);
        for (std::int64_t t = 0; t < tars_.tars(); ++t)
            if (in_shard(tars_.first(t), options_.shard, unit) && !scan.tar_done[static_cast<std::size_t>(t)] && !tar_remaining_.count(t)) {
                write_tar(t);
                ++written;
            }
        return written;
    }

    // After the sample's files are written: its manifest line, the progress callback, and its tar when
    // it completes one.
    void sample_done(std::int64_t index) {
        bool tar_ready = false;
        {
            const std::lock_guard lock(mutex_);
            const std::string line = manifest_entry(index, config_).dump() + "\n";
            if (std::fputs(line.c_str(), manifest_.get()) < 0 || std::fflush(manifest_.get()) != 0)
                throw core::file_error(manifest_path_.string(), "write failed (disk full?)");
            ++generated_;
            if (formats_.wds) tar_ready = --tar_remaining_[tars_.tar_of(index)] == 0;
            if (options_.on_sample) options_.on_sample();
        }
        if (tar_ready) {
            write_tar(tars_.tar_of(index));
            const std::lock_guard lock(mutex_);
            ++tars_written_;
        }
    }

    // The final manifest and COCO file list this shard's samples in index order, whatever the order
    // they finished in.
    void finish() {
        const std::int64_t unit = shard_unit(config_);
        std::vector<std::int64_t> all;
        for (std::int64_t i = 0; i < config_.count; ++i)
            if (in_shard(i, options_.shard, unit)) all.push_back(i);
        core::write_file_atomically(manifest_path_, manifest_text(all, config_));
        if (formats_.coco) core::write_file_atomically(options_.out / coco_name(options_.shard), coco_from_meta(options_.out, all, image_extension(config_), kSynthCocoDescription).dump() + "\n");
        if (!formats_.folder && !formats_.coco) {
            std::error_code ignored;
            fs::remove_all(options_.out / kStagingFolder, ignored);  // succeeds only when other shards left nothing there either
        }
    }

    [[nodiscard]] std::size_t generated() const { return generated_; }
    [[nodiscard]] std::size_t tars_written() const { return tars_written_; }

private:
    void write_tar(std::int64_t t) {
        std::vector<TarMember> members;
        for (std::int64_t i = tars_.first(t); i < tars_.end(t); ++i)
            for (const auto& file : files_)
                members.push_back({sample_key(i) + file.wds_extension, root_ / file.folder / (sample_key(i) + file.suffix)});
        write_tar_file(options_.out / wds_tar_name(config_.output.wds_prefix, t), members);
        if (!formats_.folder && !formats_.coco)
            for (const auto& member : members) fs::remove(member.source);
    }

    struct FileCloser {
        void operator()(std::FILE* f) const { std::fclose(f); }
    };

    const RunOptions& options_;
    const SynthConfig& config_;
    const fs::path root_;
    const std::vector<SampleFile>& files_;
    const OutputFormats formats_;
    const TarLayout tars_;
    std::map<std::int64_t, std::int64_t>& tar_remaining_;
    const fs::path manifest_path_;
    std::unique_ptr<std::FILE, FileCloser> manifest_;
    std::mutex mutex_;  // manifest, tar bookkeeping, progress
    std::size_t generated_ = 0, tars_written_ = 0;
};

}  // namespace

RunResult run_synth(const RunOptions& options, const morph::MorphableModel& model) {
    const SynthConfig& config = options.config;
    validate(config);
    if (options.threads < 1) throw core::Error("--threads must be at least 1");
    const std::string checksum = model.checksum();
    const fs::path& out = options.out;
    // The workers load what the config names (backgrounds, texture bank, head parts) and throw on what
    // is wrong there: they start before the folder is touched, so that such an error leaves no empty
    // dataset and, with --overwrite, removes no earlier one.
    const std::int64_t shard_samples = (config.count + options.shard.count - 1) / options.shard.count;
    const int thread_count = static_cast<int>(std::clamp<std::int64_t>(shard_samples, 1, options.threads));
    const auto start = Clock::now();
    SampleStream stream(config, model, thread_count, options.renderer);
    prepare_folder(out, config, model, checksum, options.overwrite);
    const fs::path root = sample_root(out, config);
    const auto files = sample_files(config);
    for (const auto& file : files) {
        std::error_code error;
        fs::create_directories(root / file.folder, error);
        if (error) throw core::file_error((root / file.folder).string(), "cannot create folder: " + error.message());
    }
    remove_stale_temporaries(out, root, config, options.shard);

    ResumeScan scan = scan_for_resume(out, root, config, options.shard, files);
    const std::vector<std::int64_t>& todo = scan.todo;
    ShardOutputs outputs(options, root, files, scan);
    if (options.on_start) options.on_start(todo.size(), scan.already_done);
    RunResult result;
    result.already_done = scan.already_done;
    result.tars_written = outputs.write_unfinished_tars(scan);

    std::vector<PngEncoder> pngs;
    pngs.reserve(static_cast<std::size_t>(thread_count));
    for (int w = 0; w < thread_count; ++w) pngs.emplace_back(config.output.png_compression);
    std::vector<StageTimes> output_times(static_cast<std::size_t>(thread_count));  // encode and write, per worker
    stream.generate(todo, [&](int worker, std::int64_t slot, Sample& sample) {
        const std::int64_t index = todo[static_cast<std::size_t>(slot)];
        const std::string key = sample_key(index);
        StageTimes& times = output_times[static_cast<std::size_t>(worker)];
        StageClock clock;
        const std::vector<std::string> contents = encode_sample(sample, files, config, model, checksum, pngs[static_cast<std::size_t>(worker)], key);
        clock.lap(times.encode);
        for (std::size_t f = 0; f < files.size(); ++f) core::write_file_atomically(root / files[f].folder / (key + files[f].suffix), contents[f]);
        outputs.sample_done(index);
        clock.lap(times.write);
    });
    result.times = stream.times();
    for (const auto& times : output_times) result.times += times;
    result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    result.generated = outputs.generated();
    result.tars_written += outputs.tars_written();
    result.renderer = stream.renderer_description();
    outputs.finish();
    return result;
}

}  // namespace facesynth::synth
