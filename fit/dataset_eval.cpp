#include "fit/dataset_eval.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace facesynth::fit {
namespace {

namespace fs = std::filesystem;

nlohmann::json parse_json_file(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw core::file_error(path.string(), "cannot open");
    std::ostringstream text;
    text << in.rdbuf();
    auto j = nlohmann::json::parse(text.str(), nullptr, false);
    if (j.is_discarded()) throw core::file_error(path.string(), "not valid JSON (truncated or corrupt?)");
    if (!j.is_object()) throw core::file_error(path.string(), "expected a JSON object");
    return j;
}

const nlohmann::json& member(const nlohmann::json& j, const char* key, const fs::path& path) {
    const auto it = j.find(key);
    if (it == j.end()) throw core::file_error(path.string(), std::string("missing key '") + key + "'");
    return *it;
}

double number(const nlohmann::json& v, const std::string& what, const fs::path& path) {
    if (v.is_null()) return std::numeric_limits<double>::quiet_NaN();  // NaN is written as null
    if (!v.is_number()) throw core::file_error(path.string(), "'" + what + "' is not a number");
    return v.get<double>();
}

Eigen::Matrix2Xd read_points(const nlohmann::json& j, const char* key, const fs::path& path) {
    const auto& a = member(j, key, path);
    if (!a.is_array() || a.size() != static_cast<std::size_t>(morph::kNumIbugLandmarks))
        throw core::file_error(path.string(), std::string("'") + key + "' must hold 68 [x, y] points");
    Eigen::Matrix2Xd p(2, morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        const auto& q = a[static_cast<std::size_t>(i)];
        if (!q.is_array() || q.size() != 2) throw core::file_error(path.string(), std::string("'") + key + "' point " + std::to_string(i + 1) + " is not [x, y]");
        for (int c = 0; c < 2; ++c) p(c, i) = number(q[static_cast<std::size_t>(c)], std::string(key) + " point " + std::to_string(i + 1), path);
    }
    return p;
}

std::vector<int> read_flags(const nlohmann::json& j, const char* key, const fs::path& path) {
    const auto& a = member(j, key, path);
    if (!a.is_array() || a.size() != static_cast<std::size_t>(morph::kNumIbugLandmarks))
        throw core::file_error(path.string(), std::string("'") + key + "' must hold 68 flags");
    std::vector<int> flags;
    for (const auto& v : a) {
        if (v.is_boolean()) flags.push_back(v.get<bool>() ? 1 : 0);
        else if (v.is_number_integer()) flags.push_back(v.get<int>() != 0 ? 1 : 0);
        else throw core::file_error(path.string(), std::string("'") + key + "' holds a value that is not 0/1");
    }
    return flags;
}

std::vector<float> read_floats(const nlohmann::json& j, const char* key, const fs::path& path) {
    const auto& a = member(j, key, path);
    if (!a.is_array()) throw core::file_error(path.string(), std::string("'") + key + "' must be an array");
    std::vector<float> out;
    for (const auto& v : a) {
        const double x = number(v, key, path);
        if (!std::isfinite(x)) throw core::file_error(path.string(), std::string("'") + key + "' holds a non-finite value");
        out.push_back(static_cast<float>(x));
    }
    return out;
}

}  // namespace

std::vector<DatasetEntry> read_dataset_manifest(const fs::path& dir) {
    const fs::path path = dir / "manifest.jsonl";
    std::ifstream in(path);
    if (!in) {
        throw core::file_error(path.string(), fs::exists(dir) ? "cannot open (not a facesynth synth dataset, or an unmerged sharded one?)"
                                                         : "dataset folder does not exist");
    }
    std::vector<DatasetEntry> entries;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        const auto j = nlohmann::json::parse(line, nullptr, false);
        const std::string where = path.string() + ":" + std::to_string(number);
        if (j.is_discarded() || !j.is_object()) throw core::Error(where + ": not a JSON object");
        const auto index = j.find("index");
        const auto key = j.find("key");
        if (index == j.end() || !index->is_number_integer() || key == j.end() || !key->is_string())
            throw core::Error(where + ": expected a manifest entry with \"index\" and \"key\"");
        DatasetEntry e;
        e.index = index->get<std::int64_t>();
        e.key = key->get<std::string>();
        const auto meta = j.find("meta");
        e.meta = dir / (meta != j.end() && meta->is_string() ? meta->get<std::string>() : "meta/" + e.key + ".json");
        entries.push_back(std::move(e));
    }
    return entries;
}

std::string dataset_model_checksum(const fs::path& dir) {
    const fs::path path = dir / "dataset.json";
    if (!fs::exists(path)) return {};
    const auto j = parse_json_file(path);
    const auto& c = member(j, "model_checksum", path);
    if (!c.is_string()) throw core::file_error(path.string(), "'model_checksum' is not a string");
    return c.get<std::string>();
}

DatasetSample read_sample_meta(const fs::path& path) {
    const auto j = parse_json_file(path);
    DatasetSample s;
    const auto& key = member(j, "key", path);
    if (!key.is_string()) throw core::file_error(path.string(), "'key' is not a string");
    s.key = key.get<std::string>();
    const auto& index = member(j, "index", path);
    if (!index.is_number_integer()) throw core::file_error(path.string(), "'index' is not an integer");
    s.index = index.get<std::int64_t>();
    const auto& checksum = member(j, "model_checksum", path);
    if (!checksum.is_string()) throw core::file_error(path.string(), "'model_checksum' is not a string");
    s.model_checksum = checksum.get<std::string>();
    s.truth.alpha = read_floats(j, "alpha", path);
    s.psi = read_floats(j, "psi", path);

    const auto& r = member(j, "rotation", path);
    if (!r.is_array() || r.size() != 3) throw core::file_error(path.string(), "'rotation' must be a 3x3 array");
    for (int row = 0; row < 3; ++row) {
        const auto& rr = r[static_cast<std::size_t>(row)];
        if (!rr.is_array() || rr.size() != 3) throw core::file_error(path.string(), "'rotation' must be a 3x3 array");
        for (int col = 0; col < 3; ++col) {
            const double v = number(rr[static_cast<std::size_t>(col)], "rotation", path);
            if (!std::isfinite(v)) throw core::file_error(path.string(), "'rotation' holds a non-finite value");
            s.truth.rotation(row, col) = v;
        }
    }
    if ((s.truth.rotation.transpose() * s.truth.rotation - Eigen::Matrix3d::Identity()).norm() > 1e-4)
        throw core::file_error(path.string(), "'rotation' is not a rotation matrix");

    const auto& k = member(j, "intrinsics", path);
    if (!k.is_object()) throw core::file_error(path.string(), "'intrinsics' must be an object");
    s.intrinsics.fx = number(member(k, "fx", path), "intrinsics.fx", path);
    s.intrinsics.fy = number(member(k, "fy", path), "intrinsics.fy", path);
    s.intrinsics.cx = number(member(k, "cx", path), "intrinsics.cx", path);
    s.intrinsics.cy = number(member(k, "cy", path), "intrinsics.cy", path);
    s.intrinsics.width = static_cast<int>(number(member(k, "width", path), "intrinsics.width", path));
    s.intrinsics.height = static_cast<int>(number(member(k, "height", path), "intrinsics.height", path));
    if (!(s.intrinsics.fx > 0 && s.intrinsics.fy > 0 && std::isfinite(s.intrinsics.cx) && std::isfinite(s.intrinsics.cy)))
        throw core::file_error(path.string(), "'intrinsics' must have fx, fy > 0 and finite cx, cy");

    s.landmarks_fixed = read_points(j, "landmarks_fixed", path);
    s.landmarks_contour = read_points(j, "landmarks_contour", path);
    s.visibility_fixed = read_flags(j, "visibility_fixed", path);
    s.visibility_contour = read_flags(j, "visibility_contour", path);
    return s;
}

Eigen::Matrix2Xd dataset_sample_landmarks(const DatasetSample& sample, const DatasetEvalOptions& options) {
    Eigen::Matrix2Xd landmarks = options.eval.fit.jaw == JawMode::kContour ? sample.landmarks_contour : sample.landmarks_fixed;
    if (options.noise_px > 0) {
        core::Rng noise = core::make_rng(options.noise_seed, static_cast<std::uint64_t>(sample.index), core::RandomStream::kNoise);
        for (Eigen::Index i = 0; i < landmarks.cols(); ++i) {
            const double dx = noise.normal(), dy = noise.normal();  // drawn for every point: subsets see the same noise
            landmarks(0, i) += options.noise_px * dx;
            landmarks(1, i) += options.noise_px * dy;
        }
    }
    return landmarks;
}

FitMetrics evaluate_dataset_sample(const Fitter& fitter, const DatasetSample& sample, const DatasetEvalOptions& options) {
    EvalOptions o = options.eval;
    o.refine_options.intrinsics = sample.intrinsics;
    const Eigen::Matrix2Xd landmarks = dataset_sample_landmarks(sample, options);
    // Points without a label (null in the file) or hidden ones with visible_only get weight 0.
    const std::vector<int>& visible = o.fit.jaw == JawMode::kContour ? sample.visibility_contour : sample.visibility_fixed;
    Eigen::VectorXd weights = o.fit.weights.size() == morph::kNumIbugLandmarks ? o.fit.weights : Eigen::VectorXd::Ones(morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        if (!landmarks.col(i).allFinite()) weights(i) = 0;
        if (options.visible_only && !visible[static_cast<std::size_t>(i)]) weights(i) = 0;
    }
    o.fit.weights = weights;
    return evaluate_fit(fitter, landmarks, sample.truth, o);
}

void MetricsSummary::add(const FitMetrics& m) {
    yaw += m.yaw_error_deg;
    pitch += m.pitch_error_deg;
    roll += m.roll_error_deg;
    yaw_bias += m.yaw_signed_error_deg;
    pitch_bias += m.pitch_signed_error_deg;
    roll_bias += m.roll_signed_error_deg;
    vertex += m.vertex_rmse_mm;
    meanshape += m.vertex_rmse_mm_meanshape;
    alpha += m.alpha_rmse;
    reprojection += m.reprojection_px;
    ms += m.ms;
    cpu_ms += m.cpu_ms;
    ++count;
}

void MetricsSummary::write(nlohmann::json& j, const std::string& prefix) const {
    const double n = std::max(count, 1);
    j[prefix + "count"] = count;
    j[prefix + "yaw_mae_deg"] = yaw / n;
    j[prefix + "pitch_mae_deg"] = pitch / n;
    j[prefix + "roll_mae_deg"] = roll / n;
    j[prefix + "yaw_bias_deg"] = yaw_bias / n;
    j[prefix + "pitch_bias_deg"] = pitch_bias / n;
    j[prefix + "roll_bias_deg"] = roll_bias / n;
    j[prefix + "vertex_rmse_mm"] = vertex / n;
    j[prefix + "vertex_rmse_mm_meanshape"] = meanshape / n;
    j[prefix + "alpha_rmse"] = alpha / n;
    j[prefix + "reprojection_px"] = reprojection / n;
    j[prefix + "ms_per_fit"] = ms / n;
    j[prefix + "cpu_ms_per_fit"] = cpu_ms / n;
}

YawBinnedSummary::YawBinnedSummary(double max_yaw)
    : max_yaw_deg(max_yaw), bins(static_cast<std::size_t>(std::max(1.0, std::ceil(2 * max_yaw / 15.0 - 1e-9)))) {}

void YawBinnedSummary::add(const FitMetrics& m) {
    all.add(m);
    const double position = std::floor((m.truth.yaw + max_yaw_deg) / 15.0);
    const auto bin = static_cast<std::size_t>(std::clamp(position, 0.0, static_cast<double>(bins.size() - 1)));
    bins[bin].add(m);
}

std::string YawBinnedSummary::prefix(std::size_t b) const {
    const long low = std::lround(-max_yaw_deg + 15.0 * static_cast<double>(b));
    char text[48];
    const int length = std::snprintf(text, sizeof text, "yaw_%ld_%ld_", low, low + 15);
    // An explicit length: GCC 12 misreports -Wrestrict for std::string(const char*) here.
    return std::string(text, static_cast<std::size_t>(std::clamp(length, 0, static_cast<int>(sizeof text) - 1)));
}

std::string YawBinnedSummary::label(std::size_t b) const {
    const long low = std::lround(-max_yaw_deg + 15.0 * static_cast<double>(b));
    char text[48];
    const int length = std::snprintf(text, sizeof text, "[%ld,%ld)", low, low + 15);
    // An explicit length: GCC 12 misreports -Wrestrict for std::string(const char*) here.
    return std::string(text, static_cast<std::size_t>(std::clamp(length, 0, static_cast<int>(sizeof text) - 1)));
}

void YawBinnedSummary::write(nlohmann::json& j) const {
    all.write(j, "");
    for (std::size_t b = 0; b < bins.size(); ++b) bins[b].write(j, prefix(b));
}

namespace {

EvalOptions eval_options(const FitSetEvalSettings& s, JawMode jaw) {
    EvalOptions o;
    const auto subset = morph::landmark_subset(morph::parse_landmark_subset(s.landmark_set));
    o.fit.subset.assign(subset.begin(), subset.end());
    o.fit.jaw = jaw;
    o.fit.lambda = o.fit.expression_lambda = s.lambda;
    o.refine = s.refine;
    o.refine_options.landmark_sigma_px = s.sigma_px;
    return o;
}

void write_settings(nlohmann::json& j, const FitSetEvalSettings& s, const morph::MorphableModel& model, const std::string& mode) {
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["noise_px"] = s.noise_px;
    j["landmarks"] = s.landmark_set;
    j["refine"] = s.refine;
    j["lambda"] = s.lambda;
    j["sigma_px"] = s.sigma_px;
    j["seed"] = s.seed;
    j["data"] = s.data;
    j["mode"] = mode;
}

}  // namespace

void check_fit_set_settings(const FitSetEvalSettings& s) {
    const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
    if (s.mode != "fixed" && s.mode != "contour") throw core::Error("eval fit: mode must be 'fixed' or 'contour', got '" + s.mode + "'");
    if (s.data.empty() && s.count <= 0) throw core::Error("eval fit: count must be positive, got " + std::to_string(s.count));
    if (!std::isfinite(s.noise_px) || s.noise_px < 0) throw core::Error("eval fit: noise must be a non-negative number of pixels");
    if (!std::isfinite(s.lambda) || s.lambda < 0) throw core::Error("eval fit: lambda must be a non-negative number");
    if (!positive(s.sigma_px)) throw core::Error("eval fit: sigma must be a positive number of pixels");
    if (s.max_yaw_deg && !(*s.max_yaw_deg >= 1 && *s.max_yaw_deg <= 90)) throw core::Error("eval fit: max_yaw must be in [1, 90] degrees");
}

namespace {

// Cases generated in code: landmarks projected from random faces and poses with fixed jaw
// correspondences, plus noise (docs/fit.md).
FitSetEvaluation evaluate_generated(const Fitter& fitter, const FitSetEvalSettings& s, const std::function<void(std::size_t)>& on_case) {
    const morph::MorphableModel& model = fitter.model();
    EvalOptions o = eval_options(s, JawMode::kFixed);
    SyntheticOptions synthetic;
    synthetic.noise_px = s.noise_px;
    synthetic.max_yaw_deg = s.max_yaw_deg.value_or(60.0);
    FitSetEvaluation e{YawBinnedSummary(synthetic.max_yaw_deg), static_cast<std::size_t>(s.count), {}, {}};
    for (int i = 0; i < s.count; ++i) {
        const SyntheticCase c = make_synthetic_case(model, static_cast<std::uint64_t>(s.seed), static_cast<std::uint64_t>(i), synthetic);
        o.refine_options.intrinsics = c.intrinsics;
        e.summary.add(evaluate_fit(fitter, c.landmarks, c.truth, o));
        if (on_case) on_case(e.samples);
    }
    write_settings(e.json, s, model, "fixed");
    e.json["visible_only"] = false;
    return e;
}

FitSetEvaluation evaluate_dataset(const Fitter& fitter, const std::string& model_label, const FitSetEvalSettings& s,
                                  const std::function<void(std::size_t)>& on_case) {
    const morph::MorphableModel& model = fitter.model();
    const std::string checksum = model.checksum();
    const fs::path dir(s.data);
    const std::vector<DatasetEntry> entries = read_dataset_manifest(dir);
    if (entries.empty()) throw core::file_error((dir / "manifest.jsonl").string(), "lists no samples");
    auto mismatch = [&](const std::string& theirs) {
        return core::Error("dataset " + dir.string() + " was made with model checksum " + theirs + ", but --model " + model_label + " (" +
                           model.name + ") has checksum " + checksum + ": evaluate with the dataset's model");
    };
    if (const std::string theirs = dataset_model_checksum(dir); !theirs.empty() && theirs != checksum) throw mismatch(theirs);

    DatasetEvalOptions o;
    o.eval = eval_options(s, s.mode == "fixed" ? JawMode::kFixed : JawMode::kContour);
    o.noise_px = s.noise_px;
    o.noise_seed = static_cast<std::uint64_t>(s.seed);
    o.visible_only = s.visible_only;
    FitSetEvaluation e{YawBinnedSummary(s.max_yaw_deg.value_or(90.0)), entries.size(), {}, {}};
    for (const auto& entry : entries) {
        DatasetSample sample;
        try {
            sample = read_sample_meta(entry.meta);
        } catch (const core::Error& error) {
            e.errors.push_back("sample " + entry.key + ": " + error.what());
            if (on_case) on_case(e.samples);
            continue;
        }
        if (sample.model_checksum != checksum) throw mismatch(sample.model_checksum + " (" + entry.meta.string() + ")");
        try {
            e.summary.add(evaluate_dataset_sample(fitter, sample, o));
        } catch (const core::Error& error) {
            e.errors.push_back("sample " + entry.key + " (" + entry.meta.string() + "): fit failed: " + error.what());
        }
        if (on_case) on_case(e.samples);
    }
    write_settings(e.json, s, model, s.mode);
    e.json["visible_only"] = s.visible_only;
    return e;
}

}  // namespace

FitSetEvaluation evaluate_fit_set(const Fitter& fitter, const std::string& model_label, const FitSetEvalSettings& settings,
                                  const std::function<void(std::size_t)>& on_case) {
    check_fit_set_settings(settings);
    FitSetEvaluation e = settings.data.empty() ? evaluate_generated(fitter, settings, on_case) : evaluate_dataset(fitter, model_label, settings, on_case);
    e.json["failed"] = e.errors.size();
    e.summary.write(e.json);
    return e;
}

std::string fit_set_failure(const FitSetEvalSettings& settings, const FitSetEvaluation& evaluation) {
    if (evaluation.errors.empty()) return {};
    return "eval fit: " + std::to_string(evaluation.errors.size()) + " of " + std::to_string(evaluation.samples) + " samples of " + settings.data +
           " failed; the metrics cover the other " + std::to_string(evaluation.summary.all.count);
}

}  // namespace facesynth::fit
