#include "synth/texture_bank.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <system_error>
#include <unistd.h>

namespace facesynth::synth {
namespace fs = std::filesystem;
namespace {

constexpr const char* kManifestName = "bank.json";

template <typename T>
T required(const nlohmann::json& j, const char* key, const std::string& origin) {
    if (!j.is_object() || !j.contains(key)) throw core::file_error(origin, std::string("missing key '") + key + "'");
    try {
        return j.at(key).get<T>();
    } catch (const nlohmann::json::exception&) {
        throw core::file_error(origin, std::string("key '") + key + "' has the wrong type");
    }
}

}  // namespace

nlohmann::json to_json(const TextureBankManifest& m) {
    nlohmann::json j;
    j["format"] = kTextureBankFormat;
    j["version"] = kTextureBankVersion;
    j["model"] = m.model;
    j["model_checksum"] = m.model_checksum;
    j["vertices"] = m.vertices;
    j["size"] = m.size;
    j["settings"] = m.settings;
    nlohmann::json textures = nlohmann::json::array();
    for (const TextureBankEntry& e : m.textures) {
        nlohmann::json t = {{"file", e.file}, {"source", e.source}, {"landmarks_source", e.landmarks_source}, {"yaw_deg", e.yaw_deg},
                            {"pitch_deg", e.pitch_deg}, {"roll_deg", e.roll_deg}, {"face_coverage", e.face_coverage},
                            {"seen_share", e.seen_share}, {"skin_outliers", e.skin_outliers}, {"dropped_share", e.dropped_share}, {"fit_error", e.fit_error},
                            {"shading_range", e.shading_range}, {"skin_srgb", e.skin_srgb}, {"shape", e.shape}};
        if (e.expression) t["expression"] = *e.expression;
        textures.push_back(std::move(t));
    }
    j["textures"] = textures;
    nlohmann::json rejected = nlohmann::json::array();
    for (const TextureBankRejection& r : m.rejected) rejected.push_back({{"source", r.source}, {"reason", r.reason}});
    j["rejected"] = rejected;
    return j;
}

TextureBankManifest texture_bank_from_json(const nlohmann::json& j, const std::string& origin) {
    if (!j.is_object() || !j.contains("format") || !j["format"].is_string() || j["format"] != kTextureBankFormat)
        throw core::file_error(origin, std::string("not a texture bank manifest (no \"format\": \"") + kTextureBankFormat + "\")");
    const int version = required<int>(j, "version", origin);
    if (version != kTextureBankVersion)
        throw core::file_error(origin, "texture bank version " + std::to_string(version) + " is not supported (expected " +
                                     std::to_string(kTextureBankVersion) + ")");
    TextureBankManifest m;
    m.model = required<std::string>(j, "model", origin);
    m.model_checksum = required<std::string>(j, "model_checksum", origin);
    m.vertices = required<int>(j, "vertices", origin);
    m.size = required<int>(j, "size", origin);
    if (m.size < 8 || m.size > 8192) throw core::file_error(origin, "texture size " + std::to_string(m.size) + " is out of range (8..8192)");
    if (j.contains("settings")) m.settings = j["settings"];
    const auto textures = required<nlohmann::json>(j, "textures", origin);
    if (!textures.is_array()) throw core::file_error(origin, "key 'textures' is not an array");
    for (std::size_t i = 0; i < textures.size(); ++i) {
        const std::string where = origin + ": textures[" + std::to_string(i) + "]";
        const nlohmann::json& t = textures[i];
        TextureBankEntry e;
        e.file = required<std::string>(t, "file", where);
        if (e.file.empty() || fs::path(e.file).is_absolute() || e.file.find("..") != std::string::npos)
            throw core::Error(where + ": file '" + e.file + "' must be a relative path inside the bank");
        e.source = t.value("source", std::string());
        e.landmarks_source = t.value("landmarks_source", std::string());
        e.yaw_deg = t.value("yaw_deg", 0.0);
        e.pitch_deg = t.value("pitch_deg", 0.0);
        e.roll_deg = t.value("roll_deg", 0.0);
        e.face_coverage = t.value("face_coverage", 0.0);
        e.seen_share = t.value("seen_share", 0.0);
        e.skin_outliers = t.value("skin_outliers", 0.0);
        e.dropped_share = t.value("dropped_share", 0.0);
        e.fit_error = t.value("fit_error", 0.0);
        e.shading_range = t.value("shading_range", 0.0);
        if (t.contains("skin_srgb")) e.skin_srgb = required<std::array<double, 3>>(t, "skin_srgb", where);
        const auto coefficients = [&](const char* key) {
            auto values = required<std::vector<float>>(t, key, where);
            for (const float a : values)
                if (!std::isfinite(a)) throw core::Error(where + ": key '" + key + "' holds a value that is not a finite number");
            return values;
        };
        if (t.contains("shape")) e.shape = coefficients("shape");
        if (t.contains("expression")) e.expression = coefficients("expression");
        m.textures.push_back(std::move(e));
    }
    if (j.contains("rejected") && j["rejected"].is_array())
        for (const nlohmann::json& r : j["rejected"]) m.rejected.push_back({r.value("source", std::string()), r.value("reason", std::string())});
    return m;
}

TextureBankManifest read_texture_bank_manifest(const fs::path& bank) {
    std::error_code error;
    if (!fs::is_directory(bank, error)) throw core::file_error(bank.string(), "texture bank folder not found");
    const fs::path manifest = bank / kManifestName;
    if (!fs::is_regular_file(manifest, error)) throw core::file_error(bank.string(), std::string("not a texture bank (no ") + kManifestName + ")");
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(core::read_file(manifest));
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(manifest.string(), std::string("not valid JSON: ") + e.what());
    }
    return texture_bank_from_json(j, manifest.string());
}

TextureBankWriter::TextureBankWriter(fs::path bank, TextureBankManifest header) : bank_(std::move(bank)), manifest_(std::move(header)) {
    std::error_code error;
    if (fs::exists(bank_, error) && !fs::exists(bank_ / kManifestName, error))
        throw core::file_error(bank_.string(), "exists and is not a texture bank; refusing to replace it");
    temporary_ = bank_;
    temporary_ += ".partial." + std::to_string(::getpid());
    fs::remove_all(temporary_, error);
    fs::create_directories(temporary_ / "textures", error);
    if (error) throw core::file_error(temporary_.string(), "cannot create the folder: " + error.message());
    manifest_.textures.clear();
    manifest_.rejected.clear();
}

TextureBankWriter::~TextureBankWriter() {
    if (committed_) return;
    std::error_code error;
    fs::remove_all(temporary_, error);
}

void TextureBankWriter::add(const cv::Mat& texture, TextureBankEntry entry) {
    if (texture.type() != CV_8UC3 || texture.rows != manifest_.size || texture.cols != manifest_.size)
        throw core::Error("texture bank: texture from " + entry.source + " is not a " + std::to_string(manifest_.size) + "² RGB image");
    char name[32];
    std::snprintf(name, sizeof name, "textures/%06zu.png", manifest_.textures.size());
    entry.file = name;
    cv::Mat bgr;
    cv::cvtColor(texture, bgr, cv::COLOR_RGB2BGR);
    std::vector<unsigned char> png;
    if (!cv::imencode(".png", bgr, png)) throw core::file_error((temporary_ / name).string(), "PNG encoding failed");
    core::write_file_atomically(temporary_ / name, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    manifest_.textures.push_back(std::move(entry));
}

void TextureBankWriter::reject(std::string source, std::string reason) { manifest_.rejected.push_back({std::move(source), std::move(reason)}); }

void TextureBankWriter::commit() {
    if (committed_) return;
    core::write_file_atomically(temporary_ / kManifestName, to_json(manifest_).dump(1) + "\n");
    std::error_code error;
    if (fs::exists(bank_, error)) {
        fs::remove_all(bank_, error);
        if (error) throw core::file_error(bank_.string(), "cannot replace the earlier bank: " + error.message());
    }
    fs::rename(temporary_, bank_, error);
    if (error) throw core::file_error(bank_.string(), "cannot move the finished bank into place: " + error.message());
    committed_ = true;
}

ImageLibrary load_texture_bank(const fs::path& bank, const morph::MorphableModel& model) {
    const TextureBankManifest m = read_texture_bank_manifest(bank);
    const std::string manifest = (bank / kManifestName).string();
    if (m.model_checksum != model.checksum() || m.vertices != model.num_vertices())
        throw core::file_error(manifest, "made for model '" + m.model + "' (" + std::to_string(m.vertices) + " vertices, checksum " + m.model_checksum +
                                       "), not for '" + model.name + "' (" + std::to_string(model.num_vertices()) + " vertices, checksum " +
                                       model.checksum() + ")");
    if (m.textures.empty()) throw core::file_error(manifest, "the bank holds no texture (every photograph was rejected?)");
    std::vector<cv::Mat> images;
    std::vector<std::string> names;
    std::vector<TextureFit> fits;
    images.reserve(m.textures.size());
    for (const TextureBankEntry& e : m.textures) {
        const fs::path file = bank / e.file;
        const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
        if (bgr.empty()) throw core::file_error(file.string(), "cannot read the texture (missing, not an image, or corrupt)");
        if (bgr.rows != m.size || bgr.cols != m.size)
            throw core::file_error(file.string(), std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) + " texture in a bank of " +
                                                std::to_string(m.size) + "² textures");
        cv::Mat rgb;
        cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
        images.push_back(std::move(rgb));
        names.push_back(e.file);
        if (!e.shape.empty() && static_cast<int>(e.shape.size()) != model.num_shape_components())
            throw core::file_error(manifest, e.file + ": " + std::to_string(e.shape.size()) + " shape coefficients, the model has " +
                                           std::to_string(model.num_shape_components()));
        if (e.expression && static_cast<int>(e.expression->size()) != model.num_expression_components())
            throw core::file_error(manifest, e.file + ": " + std::to_string(e.expression->size()) + " expression coefficients, the model has " +
                                           std::to_string(model.num_expression_components()));
        fits.push_back({e.shape, e.expression, {e.yaw_deg, e.pitch_deg, e.roll_deg}});
    }
    return {std::move(images), std::move(names), std::move(fits)};
}

}  // namespace facesynth::synth
