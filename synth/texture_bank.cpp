#include "synth/texture_bank.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "synth/photo_backgrounds.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
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

nlohmann::json points_to_json(const Eigen::Matrix2Xd& points) {
    nlohmann::json j = nlohmann::json::array();
    for (Eigen::Index k = 0; k < points.cols(); ++k) j.push_back({points(0, k), points(1, k)});
    return j;
}

Eigen::Matrix2Xd points_from_json(const nlohmann::json& j, const std::string& where) {
    if (!j.is_array()) throw core::Error(where + ": key 'surroundings_landmarks' is not an array");
    Eigen::Matrix2Xd points(2, static_cast<Eigen::Index>(j.size()));
    for (std::size_t k = 0; k < j.size(); ++k) {
        if (!j[k].is_array() || j[k].size() != 2 || !j[k][0].is_number() || !j[k][1].is_number())
            throw core::Error(where + ": surroundings_landmarks[" + std::to_string(k) + "] is not a pair of numbers");
        points(0, static_cast<Eigen::Index>(k)) = j[k][0].get<double>();
        points(1, static_cast<Eigen::Index>(k)) = j[k][1].get<double>();
    }
    return points;
}

}  // namespace

PhotoSurroundings photo_surroundings(const cv::Mat& photo, const Eigen::Matrix2Xd& landmarks) {
    Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), high = -low;
    for (Eigen::Index k = 0; k < landmarks.cols(); ++k)
        if (landmarks.col(k).allFinite()) {
            low = low.cwiseMin(landmarks.col(k));
            high = high.cwiseMax(landmarks.col(k));
        }
    const double diagonal = (high - low).norm();
    if (!std::isfinite(diagonal) || diagonal <= 0) throw core::Error("surroundings: the landmarks span no area");
    const Eigen::Vector2d centre = 0.5 * (low + high);
    const double span = kSurroundingsSpan * diagonal;
    const double scale = kSurroundingsSide / span;
    // photograph -> surroundings: p' = scale (p - centre) + side / 2
    cv::Matx23d to_crop(scale, 0, kSurroundingsSide / 2.0 - scale * centre.x(), 0, scale, kSurroundingsSide / 2.0 - scale * centre.y());
    PhotoSurroundings out;
    // Shrinking by more than 2: smooth first, as area averaging would (warpAffine samples bilinearly).
    cv::Mat source = photo;
    if (scale < 0.5) {
        const double sigma = 0.5 / scale;
        cv::GaussianBlur(photo, source, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
    }
    const cv::Size side(kSurroundingsSide, kSurroundingsSide);
    cv::warpAffine(source, out.image, to_crop, side, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::warpAffine(cv::Mat(photo.size(), CV_8UC1, cv::Scalar(255)), out.valid, to_crop, side, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
    out.landmarks = ((landmarks.colwise() - centre) * scale).array() + kSurroundingsSide / 2.0;
    return out;
}

void exclude_other_faces(PhotoSurroundings& surroundings, const std::vector<cv::Rect>& detections) {
    const Eigen::Vector2d low = surroundings.landmarks.rowwise().minCoeff(), high = surroundings.landmarks.rowwise().maxCoeff();
    const FaceExclusion grow;
    for (const cv::Rect& box : detections) {
        const double cx = box.x + 0.5 * box.width, cy = box.y + 0.5 * box.height;
        if (cx >= low.x() && cx <= high.x() && cy >= low.y() && cy <= high.y()) continue;
        const int x0 = static_cast<int>(std::floor(box.x - grow.side * box.width));
        const int x1 = static_cast<int>(std::ceil(box.x + (1 + grow.side) * box.width));
        const int y0 = static_cast<int>(std::floor(box.y - grow.above * box.height));
        const int y1 = static_cast<int>(std::ceil(box.y + (1 + grow.below) * box.height));
        const cv::Rect grown = cv::Rect(x0, y0, x1 - x0, y1 - y0) & cv::Rect(0, 0, surroundings.valid.cols, surroundings.valid.rows);
        if (grown.area() > 0) surroundings.valid(grown).setTo(0);
    }
}

void draw_texture_photo(cv::Mat& out, const TextureFit& fit, const Eigen::Matrix2Xd& rendered) {
    if (rendered.cols() != morph::kNumIbugLandmarks || fit.surroundings_landmarks.cols() != morph::kNumIbugLandmarks || fit.surroundings.empty() ||
        fit.surroundings_valid.size() != fit.surroundings.size() || out.type() != CV_8UC3)
        throw core::Error("texture_photo: needs 68 rendered landmarks and a texture loaded with its photograph around the face");
    constexpr int kFirstInner = 17;
    std::vector<int> used;
    for (int k = kFirstInner; k < morph::kNumIbugLandmarks; ++k)
        if (rendered.col(k).allFinite() && fit.surroundings_landmarks.col(k).allFinite()) used.push_back(k);
    if (used.size() < 3) return;
    // Least-squares similarity (rotation, uniform scale, shift) in closed form: q = [a -b; b a] p + t.
    Eigen::Vector2d from_mean = Eigen::Vector2d::Zero(), to_mean = Eigen::Vector2d::Zero();
    for (const int k : used) from_mean += fit.surroundings_landmarks.col(k), to_mean += rendered.col(k);
    from_mean /= static_cast<double>(used.size());
    to_mean /= static_cast<double>(used.size());
    double dot = 0, cross = 0, norm = 0;
    for (const int k : used) {
        const Eigen::Vector2d p = fit.surroundings_landmarks.col(k) - from_mean, q = rendered.col(k) - to_mean;
        dot += p.dot(q);
        cross += p.x() * q.y() - p.y() * q.x();
        norm += p.squaredNorm();
    }
    const double a = norm > 0 ? dot / norm : 1, b = norm > 0 ? cross / norm : 0;
    const Eigen::Vector2d shift = to_mean - Eigen::Vector2d(a * from_mean.x() - b * from_mean.y(), b * from_mean.x() + a * from_mean.y());
    const cv::Matx23d photo_to_image(a, -b, shift.x(), b, a, shift.y());
    cv::Mat photo, valid;
    cv::warpAffine(fit.surroundings, photo, photo_to_image, out.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::warpAffine(fit.surroundings_valid, valid, photo_to_image, out.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    for (int y = 0; y < out.rows; ++y) {
        uchar* o = out.ptr<uchar>(y);
        const uchar* p = photo.ptr<uchar>(y);
        const uchar* v = valid.ptr<uchar>(y);
        for (int x = 0; x < out.cols; ++x) {
            const int w = v[x];
            for (int c = 0; c < 3; ++c) o[3 * x + c] = static_cast<uchar>((p[3 * x + c] * w + o[3 * x + c] * (255 - w) + 127) / 255);
        }
    }
}

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
                            {"seen_share", e.seen_share}, {"skin_outliers", e.skin_outliers}, {"fit_error", e.fit_error},
                            {"shading_range", e.shading_range}, {"skin_srgb", e.skin_srgb}, {"shape", e.shape}};
        if (e.expression) t["expression"] = *e.expression;
        if (!e.surroundings.empty()) {
            t["surroundings"] = e.surroundings;
            t["surroundings_valid"] = e.surroundings_valid;
            t["surroundings_landmarks"] = points_to_json(e.surroundings_landmarks);
        }
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
        if (t.contains("surroundings")) {
            e.surroundings = required<std::string>(t, "surroundings", where);
            e.surroundings_valid = required<std::string>(t, "surroundings_valid", where);
            for (const std::string& file : {e.surroundings, e.surroundings_valid})
                if (file.empty() || fs::path(file).is_absolute() || file.find("..") != std::string::npos)
                    throw core::Error(where + ": surroundings file '" + file + "' must be a relative path inside the bank");
            e.surroundings_landmarks = points_from_json(required<nlohmann::json>(t, "surroundings_landmarks", where), where);
            if (e.surroundings_landmarks.cols() != morph::kNumIbugLandmarks || !e.surroundings_landmarks.allFinite())
                throw core::Error(where + ": surroundings_landmarks must be 68 finite points");
        }
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
    if (!error) fs::create_directories(temporary_ / "surroundings", error);
    if (error) throw core::file_error(temporary_.string(), "cannot create the folder: " + error.message());
    manifest_.textures.clear();
    manifest_.rejected.clear();
}

TextureBankWriter::~TextureBankWriter() {
    if (committed_) return;
    std::error_code error;
    fs::remove_all(temporary_, error);
}

void TextureBankWriter::add(const cv::Mat& texture, TextureBankEntry entry, const PhotoSurroundings* surroundings) {
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
    if (surroundings != nullptr) {
        const cv::Size side(kSurroundingsSide, kSurroundingsSide);
        if (surroundings->image.type() != CV_8UC3 || surroundings->image.size() != side || surroundings->valid.type() != CV_8UC1 ||
            surroundings->valid.size() != side || surroundings->landmarks.cols() != morph::kNumIbugLandmarks)
            throw core::Error("texture bank: surroundings of " + entry.source + " are not a " + std::to_string(kSurroundingsSide) +
                              "² colour image with its mask and 68 landmarks");
        std::snprintf(name, sizeof name, "surroundings/%06zu.jpg", manifest_.textures.size());
        entry.surroundings = name;
        std::vector<unsigned char> bytes;
        if (!cv::imencode(".jpg", surroundings->image, bytes, {cv::IMWRITE_JPEG_QUALITY, 92}))
            throw core::file_error((temporary_ / name).string(), "JPEG encoding failed");
        core::write_file_atomically(temporary_ / name, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
        std::snprintf(name, sizeof name, "surroundings/%06zu_valid.png", manifest_.textures.size());
        entry.surroundings_valid = name;
        if (!cv::imencode(".png", surroundings->valid, bytes)) throw core::file_error((temporary_ / name).string(), "PNG encoding failed");
        core::write_file_atomically(temporary_ / name, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
        entry.surroundings_landmarks = surroundings->landmarks;
    }
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

ImageLibrary load_texture_bank(const fs::path& bank, const morph::MorphableModel& model, bool with_surroundings) {
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
        TextureFit fit;
        fit.shape = e.shape;
        fit.expression = e.expression;
        fit.angles = {e.yaw_deg, e.pitch_deg, e.roll_deg};
        if (with_surroundings) {
            if (e.surroundings.empty())
                throw core::file_error(manifest, e.file + ": no photograph around the face (a bank made before they were kept: rebuild it)");
            const fs::path photo = bank / e.surroundings;
            const cv::Mat photo_bgr = cv::imread(photo.string(), cv::IMREAD_COLOR);
            if (photo_bgr.empty()) throw core::file_error(photo.string(), "cannot read the photograph around the face (missing, not an image, or corrupt)");
            cv::cvtColor(photo_bgr, fit.surroundings, cv::COLOR_BGR2RGB);
            const fs::path valid = bank / e.surroundings_valid;
            fit.surroundings_valid = cv::imread(valid.string(), cv::IMREAD_GRAYSCALE);
            if (fit.surroundings_valid.empty()) throw core::file_error(valid.string(), "cannot read the mask of the photograph around the face");
            if (fit.surroundings_valid.size() != fit.surroundings.size())
                throw core::file_error(valid.string(), "mask and photograph around the face differ in size");
            fit.surroundings_landmarks = e.surroundings_landmarks;
        }
        fits.push_back(std::move(fit));
    }
    return {std::move(images), std::move(names), std::move(fits)};
}

}  // namespace facesynth::synth
