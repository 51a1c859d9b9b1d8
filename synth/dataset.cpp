#include "synth/dataset.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "synth/exr.h"
#include "synth/png.h"
#include "synth/tar.h"
#include "synth/texture_bank.h"
#include "synth/wallpapers.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <concepts>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>
#include <string_view>
#include <map>
#include <mutex>
#include <set>
#include <thread>

namespace facesynth::synth {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* kStagingFolder = ".staging";

std::string image_extension(const SynthConfig& config) { return config.output.image_format == "jpg" ? ".jpg" : ".png"; }

// The folder holding per-sample files: the dataset itself, or a staging folder when only tars are wanted.
fs::path sample_root(const fs::path& out, const SynthConfig& config) {
    const auto formats = parse_formats(config.output.formats);
    return formats.folder || formats.coco ? out : out / kStagingFolder;
}

// A sample's files relative to the sample root, in write order (meta last: it marks completion).
struct SampleFile {
    std::string folder;
    std::string suffix;  // file name after the key
    std::string wds_extension;  // member name after the key in tars
};

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

std::string encode_image(const cv::Mat& rgb, const SynthConfig& config, PngEncoder& png, const std::string& context) {
    if (config.output.image_format != "jpg") return png.encode(rgb, context);
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    std::vector<uchar> bytes;
    if (!cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, config.output.jpeg_quality})) throw core::Error(context + ": image encoding failed");
    return {bytes.begin(), bytes.end()};
}

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

// JSON text in nlohmann's compact form (what json::dump() writes: no spaces, numbers in its shortest
// round-trip format, integers in decimal, strings escaped by nlohmann), written as it goes instead of
// built as an object tree: a meta file holds about 900 numbers. Members are written in the order
// given; callers give them sorted, as nlohmann's objects are.
class CompactJson {
public:
    CompactJson& key(std::string_view name) {
        element();
        text_ += '"';
        text_ += name;  // plain ASCII names: nothing to escape
        text_ += "\":";
        after_key_ = true;
        return *this;
    }
    void begin_object() { open('{'); }
    void end_object() { close('}'); }
    void begin_array() { open('['); }
    void end_array() { close(']'); }
    void number(double value) {
        element();
        if (!std::isfinite(value)) {
            text_ += "null";
            return;
        }
        char digits[64];
        text_.append(digits, nlohmann::detail::to_chars(digits, digits + sizeof digits, value));
    }
    void integer(std::integral auto value) {
        element();
        char digits[24];
        text_.append(digits, std::to_chars(digits, digits + sizeof digits, value).ptr);
    }
    void string(const std::string& value) { raw(nlohmann::json(value).dump()); }
    void null() { raw("null"); }
    void raw(std::string_view json) {
        element();
        text_ += json;
    }
    template <typename Range>
    void numbers(const Range& values) {
        begin_array();
        for (const auto v : values) number(static_cast<double>(v));
        end_array();
    }
    void integers(const std::vector<int>& values) {
        begin_array();
        for (const int v : values) integer(v);
        end_array();
    }
    template <typename Derived>
    void point(const Eigen::MatrixBase<Derived>& p) {
        begin_array();
        for (Eigen::Index i = 0; i < p.size(); ++i) number(static_cast<double>(p(i)));
        end_array();
    }
    template <int Rows>
    void points(const Eigen::Matrix<double, Rows, Eigen::Dynamic>& p) {
        begin_array();
        for (Eigen::Index i = 0; i < p.cols(); ++i) point(p.col(i));
        end_array();
    }
    [[nodiscard]] std::string text() const { return text_ + "\n"; }

private:
    // A comma before every element but the first of its container; none right after a key.
    void element() {
        if (after_key_) {
            after_key_ = false;
            return;
        }
        if (!first_.empty() && !first_.back()) text_ += ',';
        if (!first_.empty()) first_.back() = false;
    }
    void open(char bracket) {
        element();
        text_ += bracket;
        first_.push_back(true);
    }
    void close(char bracket) {
        text_ += bracket;
        first_.pop_back();
    }

    std::string text_;
    std::vector<bool> first_;  // per open container: nothing written in it yet
    bool after_key_ = false;
};

// [x, y, width, height] of the points, clipped to the image.
std::array<double, 4> bounding_box(const Eigen::Matrix2Xd& p, int width, int height) {
    const double x0 = std::clamp(p.row(0).minCoeff(), 0.0, width - 1.0), x1 = std::clamp(p.row(0).maxCoeff(), 0.0, width - 1.0);
    const double y0 = std::clamp(p.row(1).minCoeff(), 0.0, height - 1.0), y1 = std::clamp(p.row(1).maxCoeff(), 0.0, height - 1.0);
    return {x0, y0, x1 - x0, y1 - y0};
}

std::string identity_mismatch(const nlohmann::json& a, const nlohmann::json& b) {
    const auto flat_a = a.flatten(), flat_b = b.flatten();
    for (const auto& [key, value] : flat_a.items())
        if (!flat_b.contains(key) || flat_b[key] != value) return key;
    for (const auto& [key, value] : flat_b.items())
        if (!flat_a.contains(key)) return key;
    return {};
}

// What must agree for two runs to write into the same folder: the config without count and model
// spec, and the model's checksum.
nlohmann::json dataset_identity(const nlohmann::json& config_json, const std::string& model_checksum) {
    nlohmann::json identity = config_json;
    identity.erase("count");
    identity.erase("model");
    identity["model_checksum"] = model_checksum;
    return identity;
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

// While it lives, OpenCV runs its functions (the background blur, resizes) on the calling thread.
// Synth's workers already keep the cores busy; OpenCV's own thread pool only added hand-offs to
// pool threads (and CPU time outside the worker's stage clocks). The results are the same.
class OpenCvOnCallingThread {
public:
    OpenCvOnCallingThread() : previous_(cv::getNumThreads()) { cv::setNumThreads(1); }
    ~OpenCvOnCallingThread() { cv::setNumThreads(previous_); }
    OpenCvOnCallingThread(const OpenCvOnCallingThread&) = delete;
    OpenCvOnCallingThread& operator=(const OpenCvOnCallingThread&) = delete;

private:
    int previous_;
};

nlohmann::json manifest_entry(std::int64_t index, const SynthConfig& config) {
    const auto formats = parse_formats(config.output.formats);
    const std::string key = sample_key(index);
    nlohmann::json line = {{"index", index}, {"key", key}};
    if (formats.folder || formats.coco)
        for (const auto& file : sample_files(config)) line[file.folder == "images" ? "image" : file.folder] = file.folder + "/" + key + file.suffix;
    if (formats.wds) line["tar"] = wds_tar_name(config, index / config.output.wds_shard_size);
    return line;
}

std::string manifest_text(const std::vector<std::int64_t>& indices, const SynthConfig& config) {
    std::string text;
    for (const auto index : indices) text += manifest_entry(index, config).dump() + "\n";
    return text;
}

}  // namespace

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

std::string wds_tar_name(const SynthConfig& config, std::int64_t tar_index) {
    char number[32];
    std::snprintf(number, sizeof number, "%06lld", static_cast<long long>(tar_index));
    return config.output.wds_prefix + "-" + number + ".tar";
}

std::string sample_meta(const Sample& sample, const SynthConfig& config, const morph::MorphableModel& model, const std::string& checksum) {
    const auto& s = sample.spec;
    const auto& k = s.intrinsics;
    const auto& labels = sample.labels;
    const std::string& mode = config.landmarks.mode;
    // The lighting (its keys are render::Lighting's) is the one part built as a JSON object.
    nlohmann::json lighting = s.lighting.lighting;
    lighting["environment_radiance"] = s.lighting.environment_radiance;
    lighting["environment_temperature"] = s.lighting.environment_temperature;
    lighting["light_temperatures"] = s.lighting.light_temperatures;
    lighting["white_balance_gain"] = s.lighting.white_balance_gain;
    const auto& b = s.background;
    const auto& d = s.degradation;
    const auto box = bounding_box(chosen_landmarks(labels, mode), k.width, k.height);
    // Keys in sorted order, as nlohmann's std::map objects wrote them.
    CompactJson j;
    j.begin_object();
    j.key("albedo_redraws").integer(s.albedo_redraws);
    j.key("albedo_shrink").number(s.albedo_shrink);
    j.key("alpha").numbers(s.alpha);
    j.key("background").begin_object();
    j.key("colour").point(b.colour);
    j.key("colour2").point(b.colour2);
    j.key("gradient_angle").number(b.gradient_angle);
    j.key("pattern_seed").integer(b.pattern_seed);
    j.key("type").string(b.type);
    j.end_object();
    j.key("bbox").numbers(box);
    j.key("beta").numbers(s.beta);
    j.key("degradation").begin_object();
    j.key("blur_sigma").number(d.blur_sigma);
    j.key("downscale").number(d.downscale);
    j.key("gains").point(d.gains);
    j.key("gamma").number(d.gamma);
    j.key("jpeg_quality").integer(d.jpeg_quality);
    j.key("noise_sigma").number(d.noise_sigma);
    j.end_object();
    j.key("fov").number(s.fov);
    j.key("head_parts");
    if (!s.head_parts) {
        j.null();
    } else {
        j.begin_object();
        j.key("clothing").string(sample.clothing);
        j.key("clothing_pattern").string(s.head_parts->clothing_pattern == 0 ? "plain" : s.head_parts->clothing_pattern == 1 ? "stripes" : "checks");
        j.key("hair");
        if (sample.hair.empty()) j.null();
        else j.string(sample.hair);
        j.key("torso").point(Eigen::Vector3d(s.head_parts->torso.yaw, s.head_parts->torso.pitch, s.head_parts->torso.roll));
        j.end_object();
    }
    j.key("image_height").integer(k.height);
    j.key("image_width").integer(k.width);
    j.key("index").integer(s.index);
    j.key("intrinsics").begin_object();
    j.key("cx").number(k.cx);
    j.key("cy").number(k.cy);
    j.key("fx").number(k.fx);
    j.key("fy").number(k.fy);
    j.key("height").integer(k.height);
    j.key("width").integer(k.width);
    j.end_object();
    j.key("key").string(s.key);
    j.key("landmark_mode").string(mode);
    j.key("landmarks").points(chosen_landmarks(labels, mode));
    j.key("landmarks_3d_contour").points(labels.landmarks_3d_contour);
    j.key("landmarks_3d_fixed").points(labels.landmarks_3d_fixed);
    j.key("landmarks_contour").points(labels.landmarks_contour);
    j.key("landmarks_fixed").points(labels.landmarks_fixed);
    j.key("lighting").raw(lighting.dump());
    j.key("model_checksum").string(checksum);
    j.key("model_name").string(model.name);
    j.key("occluded").integers(labels.occluded);
    j.key("occluders").begin_array();
    for (const auto& o : s.occluders) {
        j.begin_object();
        j.key("angle").number(o.angle);
        j.key("centre").point(o.centre);
        j.key("colour").point(o.colour);
        j.key("half_size").point(o.half_size);
        j.key("shape").string(o.shape);
        j.end_object();
    }
    j.end_array();
    j.key("pitch").number(s.angles.pitch);
    j.key("psi").numbers(s.psi);
    j.key("roll").number(s.angles.roll);
    j.key("rotation").begin_array();
    for (int r = 0; r < 3; ++r) j.point(Eigen::Vector3d(s.pose.rotation.row(r).transpose()));
    j.end_array();
    j.key("seed").integer(s.seed);
    j.key("skin_tone");
    if (s.skin_tone) j.point(*s.skin_tone);
    else j.null();
    j.key("texture");
    if (sample.texture.empty()) j.null();
    else j.string(sample.texture);
    j.key("texture_gain").point(s.texture_gain);
    j.key("translation").point(s.pose.translation);
    j.key("visibility").integers(chosen_visibility(labels, mode));
    j.key("visibility_contour").integers(labels.visible_contour);
    j.key("visibility_fixed").integers(labels.visible_fixed);
    j.key("yaw").number(s.angles.yaw);
    j.end_object();
    return j.text();
}

RunResult run_synth(const RunOptions& options, const morph::MorphableModel& model) {
    const SynthConfig& config = options.config;
    validate(config);
    if (options.threads < 1) throw core::Error("--threads must be at least 1");
    const auto formats = parse_formats(config.output.formats);
    const std::string checksum = model.checksum();
    const fs::path& out = options.out;
    prepare_folder(out, config, model, checksum, options.overwrite);
    const fs::path root = sample_root(out, config);
    const auto files = sample_files(config);
    for (const auto& file : files) {
        std::error_code error;
        fs::create_directories(root / file.folder, error);
        if (error) throw core::file_error((root / file.folder).string(), "cannot create folder: " + error.message());
    }
    remove_stale_temporaries(out, root, config, options.shard);

    const std::int64_t unit = shard_unit(config);
    const std::int64_t tar_size = config.output.wds_shard_size;
    const std::int64_t tar_count = (config.count + tar_size - 1) / tar_size;
    std::set<std::int64_t> done;  // this shard's samples complete on disk (their meta file exists)
    for (const auto& entry : fs::directory_iterator(root / "meta")) {
        const std::string name = entry.path().filename().string();
        const auto index = index_of_key(name);
        if (index && name == sample_key(*index) + ".json" && *index < config.count && in_shard(*index, options.shard, unit)) done.insert(*index);
    }
    // A tar is complete when it holds every file of its samples (a larger count than the run that
    // wrote it can make the last tar short).
    const auto tar_is_complete = [&](const fs::path& tar, std::int64_t t) {
        if (!fs::exists(tar)) return false;
        const std::int64_t samples = std::min(config.count, (t + 1) * tar_size) - t * tar_size;
        try {
            return list_tar(tar).size() == static_cast<std::size_t>(samples) * files.size();
        } catch (const core::Error&) {
            return false;
        }
    };
    std::vector<char> tar_done(static_cast<std::size_t>(formats.wds ? tar_count : 0), 0);
    for (std::int64_t t = 0; t < static_cast<std::int64_t>(tar_done.size()); ++t)
        tar_done[static_cast<std::size_t>(t)] = in_shard(t * tar_size, options.shard, unit) && tar_is_complete(out / wds_tar_name(config, t), t);

    const auto tar_of = [&](std::int64_t index) { return index / tar_size; };
    std::vector<std::int64_t> todo;
    std::size_t already_done = 0;
    std::map<std::int64_t, std::int64_t> tar_remaining;  // tar index -> samples still missing
    for (std::int64_t i = 0; i < config.count; ++i) {
        if (!in_shard(i, options.shard, unit)) continue;
        const bool in_finished_tar = formats.wds && tar_done[static_cast<std::size_t>(tar_of(i))];
        if (done.count(i) || in_finished_tar) {
            ++already_done;
            if (!done.count(i)) done.insert(i);
            continue;
        }
        todo.push_back(i);
        if (formats.wds) ++tar_remaining[tar_of(i)];
    }

    // Rebuild the manifest from what is on disk, then append as samples finish.
    const fs::path manifest_path = out / manifest_name(options.shard);
    core::write_file_atomically(manifest_path, manifest_text({done.begin(), done.end()}, config));
    std::FILE* manifest = std::fopen(manifest_path.c_str(), "a");
    if (!manifest) throw core::file_error(manifest_path.string(), "cannot open for appending");
    struct Closer {
        std::FILE* f;
        ~Closer() { std::fclose(f); }
    } closer{manifest};

    if (options.on_start) options.on_start(todo.size(), already_done);

    const auto write_tar = [&](std::int64_t t) {
        std::vector<TarMember> members;
        const std::int64_t first = t * tar_size, last = std::min(config.count, first + tar_size);
        for (std::int64_t i = first; i < last; ++i)
            for (const auto& file : files)
                members.push_back({sample_key(i) + file.wds_extension, root / file.folder / (sample_key(i) + file.suffix)});
        write_tar_file(out / wds_tar_name(config, t), members);
        if (!formats.folder && !formats.coco)
            for (const auto& member : members) fs::remove(member.source);
    };
    RunResult result;
    result.already_done = already_done;
    // Tars whose samples all exist but that a killed run did not finish.
    if (formats.wds)
        for (std::int64_t t = 0; t < tar_count; ++t)
            if (in_shard(t * tar_size, options.shard, unit) && !tar_done[static_cast<std::size_t>(t)] && !tar_remaining.count(t)) {
                write_tar(t);
                ++result.tars_written;
            }

    ImageLibrary backgrounds, textures;
    if (config.background.type == "images") backgrounds = ImageLibrary(config.background.folder, "background");
    if (config.background.type == "wallpapers") backgrounds = load_wallpaper_photos();
    if (!config.albedo.texture_folder.empty() || !config.albedo.texture_bank.empty()) {
        const std::string key = config.albedo.texture_bank.empty() ? "albedo.texture_folder" : "albedo.texture_bank";
        if (model.uv.cols() != model.num_vertices())
            throw core::Error(key + ": model '" + model.name + "' has no uv coordinates to map a texture with");
        textures = config.albedo.texture_bank.empty() ? ImageLibrary(config.albedo.texture_folder, "texture")
                                                      : load_texture_bank(config.albedo.texture_bank, model);
    }

    std::atomic<std::size_t> next{0};
    std::atomic<bool> failed{false};
    std::mutex mutex;  // manifest, tar bookkeeping, progress, first error, stage times
    std::exception_ptr first_error;
    std::size_t generated = 0;
    std::size_t tars_written = 0;
    const int thread_count = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(options.threads), std::max<std::size_t>(todo.size(), 1)));
    std::vector<std::string> worker_renderers(static_cast<std::size_t>(thread_count));
    const OpenCvOnCallingThread opencv_threads;
    const auto start = Clock::now();

    const auto worker = [&](int worker_index) {
        try {
            // Workers alternate between Mesa's two software displays: llvmpipe rasterises one scene
            // at a time per display, and two workers on one display waited for each other.
            render::RendererOptions renderer_options = options.renderer;
            renderer_options.software_display = options.renderer.software_display + worker_index;
            SampleGenerator generator(config, model, backgrounds, textures, renderer_options);
            worker_renderers[static_cast<std::size_t>(worker_index)] = generator.renderer_description();
            PngEncoder png(config.output.png_compression);
            StageTimes times;
            for (;;) {
                const std::size_t slot = next.fetch_add(1);
                if (slot >= todo.size() || failed) break;
                const std::int64_t index = todo[slot];
                const std::string key = sample_key(index);
                try {
                    Sample sample = generator.generate(index, &times);
                    StageClock clock;
                    std::vector<std::string> contents;
                    contents.reserve(files.size());
                    for (const auto& file : files) {
                        if (file.folder == "images") contents.push_back(encode_image(sample.image, config, png, key));
                        else if (file.folder == "landmarks") contents.push_back(morph::format_pts(chosen_landmarks(sample.labels, config.landmarks.mode)));
                        else if (file.folder == "depth") contents.push_back(encode_depth_exr(sample.depth, key));
                        else if (file.folder == "mask") contents.push_back(png.encode(sample.mask, key));
                        else if (file.folder == "normals") contents.push_back(encode_normals(sample.normals, png, key));
                        else if (file.folder == "labels") contents.push_back(png.encode(sample.regions, key));
                        else contents.push_back(sample_meta(sample, config, model, checksum));
                    }
                    clock.lap(times.encode);
                    for (std::size_t f = 0; f < files.size(); ++f)
                        core::write_file_atomically(root / files[f].folder / (key + files[f].suffix), contents[f]);
                    bool tar_ready = false;
                    {
                        std::lock_guard lock(mutex);
                        const std::string line = manifest_entry(index, config).dump() + "\n";
                        if (std::fputs(line.c_str(), manifest) < 0 || std::fflush(manifest) != 0)
                            throw core::file_error(manifest_path.string(), "write failed (disk full?)");
                        ++generated;
                        if (formats.wds) tar_ready = --tar_remaining[tar_of(index)] == 0;
                        if (options.on_sample) options.on_sample();
                    }
                    if (tar_ready) {
                        write_tar(tar_of(index));
                        std::lock_guard lock(mutex);
                        ++tars_written;
                    }
                    clock.lap(times.write);
                } catch (const core::Error& e) {
                    throw core::Error("sample " + key + ": " + e.what());
                } catch (const std::exception& e) {
                    throw core::Error("sample " + key + ": " + e.what());
                }
            }
            std::lock_guard lock(mutex);
            result.times += times;
        } catch (...) {
            failed = true;
            std::lock_guard lock(mutex);
            if (!first_error) first_error = std::current_exception();
        }
    };
    std::vector<std::thread> threads;
    for (int t = 1; t < thread_count; ++t) threads.emplace_back(worker, t);
    worker(0);
    for (auto& thread : threads) thread.join();
    if (first_error) std::rethrow_exception(first_error);
    result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    result.generated = generated;
    result.tars_written += tars_written;
    std::vector<std::string> distinct_renderers;
    for (const auto& name : worker_renderers)
        if (std::find(distinct_renderers.begin(), distinct_renderers.end(), name) == distinct_renderers.end()) {
            result.renderer += (distinct_renderers.empty() ? "" : " + ") + name;
            distinct_renderers.push_back(name);
        }

    // The final manifest and COCO file list this shard's samples in index order, whatever the
    // order they finished in.
    std::vector<std::int64_t> all;
    for (std::int64_t i = 0; i < config.count; ++i)
        if (in_shard(i, options.shard, unit)) all.push_back(i);
    core::write_file_atomically(manifest_path, manifest_text(all, config));
    if (formats.coco) core::write_file_atomically(out / coco_name(options.shard), coco_from_meta(out, all, config).dump() + "\n");
    if (!formats.folder && !formats.coco) {
        std::error_code ignored;
        fs::remove_all(out / kStagingFolder, ignored);  // succeeds only when other shards left nothing there either
    }
    return result;
}

nlohmann::json read_json_file(const fs::path& path) {
    try {
        return nlohmann::json::parse(core::read_file(path));
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("invalid JSON: ") + e.what());
    }
}

nlohmann::json coco_from_meta(const fs::path& dataset, const std::vector<std::int64_t>& indices, const SynthConfig& config) {
    nlohmann::json names = nlohmann::json::array();
    for (int i = 1; i <= morph::kNumIbugLandmarks; ++i) names.push_back("ibug_" + std::to_string(i));
    // 1-based COCO skeleton along the iBUG contours: jaw, brows, nose bridge and base, eyes, lips.
    nlohmann::json skeleton = nlohmann::json::array();
    const auto chain = [&](int first, int last, bool closed) {
        for (int i = first; i < last; ++i) skeleton.push_back({i, i + 1});
        if (closed) skeleton.push_back({last, first});
    };
    chain(1, 17, false);
    chain(18, 22, false);
    chain(23, 27, false);
    chain(28, 31, false);
    chain(32, 36, false);
    chain(37, 42, true);
    chain(43, 48, true);
    chain(49, 60, true);
    chain(61, 68, true);
    nlohmann::json images = nlohmann::json::array(), annotations = nlohmann::json::array();
    const std::string extension = image_extension(config);
    for (const auto index : indices) {
        const std::string key = sample_key(index);
        const fs::path meta_path = dataset / "meta" / (key + ".json");
        const nlohmann::json meta = read_json_file(meta_path);
        // A meta file edited or damaged by hand: every access is checked (at()), and a wrong key,
        // type or length is reported against the file.
        try {
            const auto side = [&](const char* name) {  // checked as a double: a huge value must not overflow int
                const double v = meta.at(name).get<double>();
                if (!(v >= 1 && v <= 1e6)) throw core::file_error(meta_path.string(), std::string(name) + " out of range");
                return static_cast<int>(v);
            };
            const int width = side("image_width"), height = side("image_height");
            images.push_back({{"id", index + 1}, {"file_name", "images/" + key + extension}, {"width", width}, {"height", height}});
            nlohmann::json keypoints = nlohmann::json::array();
            int labelled = 0;
            const auto& points = meta.at("landmarks");
            const auto& visibility = meta.at("visibility");
            const auto& occluded = meta.at("occluded");
            for (std::size_t p = 0; p < points.size(); ++p) {
                const double x = points.at(p).at(0), y = points.at(p).at(1);
                const bool inside = x >= -0.5 && y >= -0.5 && x < width - 0.5 && y < height - 0.5;
                int v = 0;
                if (inside) v = visibility.at(p).get<double>() != 0 && occluded.at(p).get<double>() == 0 ? 2 : 1;
                keypoints.push_back(inside ? x : 0.0);
                keypoints.push_back(inside ? y : 0.0);
                keypoints.push_back(v);
                labelled += v > 0;
            }
            const auto& box = meta.at("bbox");
            annotations.push_back({{"id", index + 1}, {"image_id", index + 1}, {"category_id", 1}, {"iscrowd", 0},
                                   {"bbox", box}, {"area", box.at(2).get<double>() * box.at(3).get<double>()},
                                   {"num_keypoints", labelled}, {"keypoints", keypoints}});
        } catch (const nlohmann::json::exception& e) {
            throw core::file_error(meta_path.string(), std::string("not a facesynth meta file: ") + e.what());
        }
    }
    return {{"info", {{"description", "facesynth synthetic faces"}, {"version", "1"}}},
            {"images", images},
            {"annotations", annotations},
            {"categories", nlohmann::json::array({{{"id", 1}, {"name", "face"}, {"supercategory", "face"}, {"keypoints", names}, {"skeleton", skeleton}}})}};
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
    for (const auto& [index, source] : sources) {
        indices.push_back(index);
        if (formats.folder || formats.coco)
            for (const auto& file : files) links.emplace_back(source / file.folder / (sample_key(index) + file.suffix), out / file.folder / (sample_key(index) + file.suffix));
        if (formats.wds && index % config.output.wds_shard_size == 0) {
            const auto tar = wds_tar_name(config, index / config.output.wds_shard_size);
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
    const std::string coco = formats.coco ? coco_from_meta(out, indices, config).dump() + "\n" : "";
    if (!fs::exists(out / "dataset.json") || !fs::equivalent(inputs.front(), out)) core::write_file_atomically(out / "dataset.json", core::read_file(first_info));
    core::write_file_atomically(out / "manifest.jsonl", manifest_text(indices, config));
    if (formats.coco) core::write_file_atomically(out / "coco.json", coco);
    return result;
}

}  // namespace facesynth::synth
