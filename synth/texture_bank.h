#pragma once
// A texture bank: albedo textures in one model's uv layout, taken from photographs by
// `facesynth textures` (frontal/photo_texture.h) and drawn one per sample by synth
// (albedo.texture_bank). On disk (docs/textures.md):
//   BANK/bank.json            the manifest: format, model name and checksum, texture size, one entry
//                             per texture (file, source photograph, pose, coverage, skin colour) and
//                             one per rejected photograph (source, reason)
//   BANK/textures/NNNNNN.png  8-bit RGB: the renderer's texture (sRGB-encoded linear albedo)
// A bank is written into a temporary folder and renamed into place when complete.
#include "synth/sample.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::synth {

inline constexpr const char* kTextureBankFormat = "facesynth-texture-bank";
inline constexpr int kTextureBankVersion = 1;

struct TextureBankEntry {
    std::string file;    // relative to the bank folder
    std::string source;  // the photograph it came from
    std::string landmarks_source;  // "pts" or the detector that found the face
    double yaw_deg = 0, pitch_deg = 0, roll_deg = 0;
    double face_coverage = 0, seen_share = 0, skin_outliers = 0, dropped_share = 0, fit_error = 0, shading_range = 0;
    std::array<double, 3> skin_srgb{};
    std::vector<float> shape;  // identity coefficients of the fit (identity.source = "texture"); empty in older banks
    // Expression coefficients of the fit (expression.source = "texture"); absent in older banks, empty
    // for a model without expressions.
    std::optional<std::vector<float>> expression;
};

struct TextureBankRejection {
    std::string source;
    std::string reason;
};

struct TextureBankManifest {
    std::string model;           // the model's name
    std::string model_checksum;  // MorphableModel::checksum()
    int vertices = 0;
    int size = 0;                // texture side, texels
    nlohmann::json settings = nlohmann::json::object();  // how the textures were made
    std::vector<TextureBankEntry> textures;
    std::vector<TextureBankRejection> rejected;
};

[[nodiscard]] nlohmann::json to_json(const TextureBankManifest& manifest);
// Throws core::Error naming `origin` (the manifest's path) and the key at fault.
[[nodiscard]] TextureBankManifest texture_bank_from_json(const nlohmann::json& json, const std::string& origin);
// Reads BANK/bank.json; throws core::Error naming the file when it is missing or not a bank.
[[nodiscard]] TextureBankManifest read_texture_bank_manifest(const std::filesystem::path& bank);

// Writes a bank: textures go into a temporary folder beside `bank`; commit() writes the manifest and
// renames the folder to `bank` (which must not exist yet, or be an earlier bank, which it replaces).
// Destroyed without commit(), it removes the temporary folder: no partial bank is left.
class TextureBankWriter {
public:
    TextureBankWriter(std::filesystem::path bank, TextureBankManifest header);
    ~TextureBankWriter();
    TextureBankWriter(const TextureBankWriter&) = delete;
    TextureBankWriter& operator=(const TextureBankWriter&) = delete;

    // `texture` is CV_8UC3 R G B of the manifest's size; entry.file is set here.
    void add(const cv::Mat& texture, TextureBankEntry entry);
    void reject(std::string source, std::string reason);
    [[nodiscard]] const TextureBankManifest& manifest() const { return manifest_; }
    void commit();

private:
    std::filesystem::path bank_, temporary_;
    TextureBankManifest manifest_;
    bool committed_ = false;
};

// The bank's textures for `model`, in manifest order. Throws core::Error naming the bank (and the
// file) when it was made for another model, holds no texture, or a texture is unreadable or of the
// wrong size.
[[nodiscard]] ImageLibrary load_texture_bank(const std::filesystem::path& bank, const morph::MorphableModel& model);

}  // namespace facesynth::synth
