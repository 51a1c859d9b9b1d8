#pragma once
// The dataset generator's configuration: a tree of plain structs with documented defaults, read from
// TOML, overridden by `--set key.sub=value`, written back as JSON into dataset.json.
// Every key is listed once, in config_fields(), which drives parsing, overrides, JSON and the docs.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace facesynth::synth {

// An angle (degrees) drawn uniformly in [min, max], or normally N(mean, stddev) and then clamped to
// [min, max] by rejection.
struct AngleDistribution {
    std::string distribution = "uniform";  // "uniform" or "normal"
    double min = 0;
    double max = 0;
    double mean = 0;
    double stddev = 0;
};

struct IdentityConfig {
    double truncation = 3.0;  // identity coefficients ~ N(0, 1) truncated at ±truncation σ
    double scale = 1.0;       // then multiplied by this (0 = the mean face)
    // "random": drawn as above; "texture": the shape fitted to the photograph of the sample's texture
    // (albedo.texture_bank), so that face and texture come from one person (truncation, scale unused).
    std::string source = "random";
    // With source "texture": N(0, texture_jitter²) added to each fitted coefficient (σ units) per
    // sample, so that one photograph's texture lies on a family of shapes around its own.
    double texture_jitter = 0;
};

struct ExpressionConfig {
    double neutral_share = 0.3;  // share of samples with no expression
    int max_active = 2;          // blendshape models: up to this many blendshapes per sample
    double min_weight = 0.2;     // blendshape weights uniform in [min_weight, max_weight]
    double max_weight = 1.0;
    double truncation = 2.0;     // PCA expression models: coefficients truncated at ±truncation σ
    // "random": drawn as above; "texture": the expression fitted to the photograph of the sample's
    // texture (albedo.texture_bank), so that the texture's lips and teeth sit on lips parted as in the
    // photograph (the settings above unused).
    std::string source = "random";
};

struct AlbedoConfig {
    double truncation = 2.0;  // colour coefficients truncated at ±truncation σ
    double scale = 1.0;
    // Redraw colour coefficients whose mean skin colour is implausible (morph/skin_colour.h), from
    // their own random stream, so that the samples that pass keep their bytes.
    bool reject_implausible = true;
    std::string texture_folder;  // folder of UV texture maps; each sample renders with one of them
    std::string texture_bank;    // texture bank (`facesynth textures`); each sample renders with one of its textures
    double texture_tone_jitter = 0;  // texture's linear albedo times a per-channel gain uniform in [1 - x, 1 + x]
    // Share of samples whose texture takes the coarse colour (tone, blotches, beard shadow) of a second
    // texture of the bank, by a weight uniform in [0, 1], keeping its own features and shape (synth/texture_mix.h).
    double texture_mix_probability = 0;
};

// Pose, camera and degradation defaults are those measured to train the best detector for real
// photographs (docs/results.md: with synth's earlier defaults, yaw uniform over ±90°, pitch and roll
// uniform, fov 10-40° and no degradations, a detector failed on turned faces: afw NME 0.42 against 0.11).
struct PoseConfig {
    AngleDistribution yaw{"normal", -60, 60, 0, 25};     // helen_train's fitted yaw has σ 12.6°, afw turns further
    AngleDistribution pitch{"normal", -30, 30, 0, 10};   // helen_train's: σ 6.7°
    AngleDistribution roll{"normal", -20, 20, 0, 8};     // helen_train's: σ 8.1°
    double translation_jitter = 0.05;  // face centre offset from the image centre, share of the image side
    // "random": the angles as above; "texture": each normal distribution centred on the angle fitted to
    // the photograph of the sample's texture (albedo.texture_bank) plus its mean, so that renders
    // show mostly the side of the face its photograph saw (min and max still bound the draw).
    std::string source = "random";
};

struct CameraConfig {
    int width = 256;
    int height = 256;
    double fov_min = 4;                 // vertical field of view range, degrees (perspective strength): long
    double fov_max = 20;                // lenses, as portraits are taken
    double principal_point_jitter = 0.02;  // cx, cy offset, share of the image side (uniform ±)
    double face_scale_min = 0.35;       // face size (landmark bounding-box diagonal) / image diagonal
    double face_scale_max = 0.55;
};

struct LightingConfig {
    double environment_min = 0.3;         // radiance of the SH environment (DC term), uniform in [min, max]
    double environment_max = 0.7;
    double sh_strength = 0.35;             // stddev of SH bands 1-2 relative to the DC term
    double ambient_max = 0.1;              // extra grey ambient uniform in [0, ambient_max]
    int directional_min = 0;               // directional_min..directional_max directional lights per sample
    int directional_max = 2;
    double intensity_min = 0.2;            // per directional light
    double intensity_max = 0.6;
    double colour_temperature_min = 3200;  // K, directional lights and the SH tint
    double colour_temperature_max = 7500;
    double white_balance = 0.7;  // share of the environment's colour cast that the camera removes
    double specular_max = 0.25;            // Blinn-Phong specular weight uniform in [0, specular_max]
    // Share of samples whose directional lights cast shadows (shadow maps). Off by default: existing
    // datasets and their figures stay byte-identical, and each shadowed light costs a depth pass.
    double shadow_probability = 0;
    // Face-metered exposure (synth/exposure.h): the face's light is scaled so that its mean grey level
    // inside the landmarks' hull is drawn from normal(mean, stddev) within [0.1, 0.9]. 0 = off (the face
    // is as bright as the drawn light makes it).
    double face_luminance_mean = 0;
    double face_luminance_stddev = 0.13;
    // "sampled": the face is lit as everything else. "even": the face gets the environment's uniform
    // term alone, for textures that keep their photograph's light (textures --keep-shading), and the
    // sampled lights (SH bands, directional lights, highlights, shadows) light the head parts only
    // (hair, ears, neck, clothing), scaled so that a surface facing the camera receives the face's light.
    std::string face_light = "sampled";
};

struct BackgroundConfig {
    std::string type = "procedural";  // "solid", "procedural", "images" or "wallpapers" (synth/wallpapers.h)
    std::string folder;               // image folder for type = "images"
};

// Image degradations, each applied with its probability (as photographs have them; 0 = off).
struct DegradationConfig {
    double blur_probability = 0.5;
    double blur_sigma_max = 1.5;      // Gaussian blur sigma uniform in [0.3, max], px
    double noise_probability = 0.5;
    double noise_sigma_max = 8;       // Gaussian noise stddev uniform in [1, max], 8-bit levels
    double jpeg_probability = 0.5;
    int jpeg_quality_min = 30;
    int jpeg_quality_max = 90;
    double gamma_probability = 0.5;
    double gamma_min = 0.7;
    double gamma_max = 1.4;
    double colour_jitter_probability = 0.5;
    double colour_jitter = 0.1;       // per-channel gain uniform in [1 - x, 1 + x]
    double downscale_probability = 0.3;
    double downscale_min = 0.3;       // downscale to this share of the size at least, then back up
    double sharpen_probability = 0;
    double sharpen_amount_max = 1.5;  // unsharp-mask amount uniform in [0.25, max] (radius: sigma 1 px)
};

struct OccluderConfig {
    double probability = 0;  // share of samples with occluders
    int max_count = 2;       // 1..max_count random shapes
    double max_size = 0.35;  // largest shape extent, share of the face size
    // "colour": each shape one random flat colour; "image": each shape filled with a random crop of
    // one of the background images (background.type images or wallpapers), textured as real objects are;
    // "skin": the face's own median skin colour (as rendered) times a shade in [0.8, 1.1], as hands are.
    std::string fill = "colour";
    // "landmarks": each shape centred near a random landmark; "jaw": on the jaw line (between two
    // neighbouring jaw points), its long side along the line and shifted across it, so that its edge
    // lies beside the face's own outline, as a headscarf's, a collar's or a hand's on the cheek does.
    std::string placement = "landmarks";
};

struct RenderConfig {
    // Anti-aliasing (render::antialiasing_from): "edges" (the default: silhouette edges blended on the CPU
    // after a single-sample render, better outlines than MSAA 4 for ~2 % of its CPU on llvmpipe,
    // docs/render.md "Edge anti-aliasing"), "msaa", "supersampling" or "none".
    std::string antialiasing = "edges";
    int antialiasing_samples = 0;  // msaa: samples per pixel (2-16); supersampling: factor per side (2-4); 0: 4 and 2
    int shadow_map_size = 512;  // shadow-map texels per side, per light (render::RenderSettings)
    // Directional lights shaded per vertex (Gouraud; render::RenderSettings::lights_per_vertex): about
    // half a lit render's CPU; within a mean 0.13 levels of per-pixel lights on synth's lightings, narrow
    // highlights softened (docs/render.md "Lights per vertex").
    bool lights_per_vertex = true;
};

struct HeadConfig {
    // A neck under the jaw (synth/neck.h): an elliptic cylinder placed by the face's landmarks, with the
    // skin under the chin (darkened for the jaw's shadow without a texture) and region label "neck".
    bool neck = false;
    // Neck, shoulders, clothing and hair meshes from MakeHuman (synth/head_parts.h), placed on the face.
    bool body = false;
    double hair_probability = 0.8;  // with body: share of samples with a hair mesh
    std::string hair_styles;        // with body: the hair meshes drawn from, comma-separated names; empty: all
    // With body: ambient occlusion on the parts' bare skin (synth/head_parts.h SkinOcclusion): 0 off, 1 the
    // full share of the sky that the face and chin hide from the neck.
    double ambient_occlusion = 0;
    std::string parts_file;         // empty: the project's assets/head_parts.bin
};

struct LandmarkConfig {
    std::string mode = "even";  // jaw points in the .pts files: "even", "contour" or "fixed"
};

struct OutputConfig {
    std::string formats = "folder";  // comma-separated: folder, wds, coco
    std::string image_format = "png";  // "png" or "jpg"
    int png_compression = 1;           // zlib level 0-9 (low = fast)
    int jpeg_quality = 95;
    bool depth = false;    // depth/ (EXR, camera-space mm)
    bool mask = false;     // mask/ (PNG, 255 = face)
    bool normals = false;  // normals/ (PNG, camera-space normal (n + 1) / 2)
    bool labels = false;   // labels/ (PNG, 8-bit region ids of morph/regions.h, 0 = background)
    int wds_shard_size = 1000;  // samples per WebDataset tar
    std::string wds_prefix = "shard";
};

// Clips instead of still samples (docs/synth.md, "Sequences"): sample i is frame i % frames of clip
// i / frames. Identity, appearance, camera, light, background and head parts are drawn once per clip;
// pose, expression and the face's place in the image follow smooth trajectories through keys.
struct SequenceConfig {
    int frames = 0;             // frames per clip; 0 = independent still samples
    double fps = 30;            // frame rate: frame f is at time f / fps
    double key_seconds = 0.8;   // time between the trajectory's keys
    double hold_share = 0.3;    // share of key intervals in which head and face hold still
    double max_turn_deg = 35;   // largest yaw change between keys (pitch and roll: half of it)
    double drift = 0.03;        // face centre within ± this share of the image side of its clip's place
};

struct SynthConfig {
    std::string model = "builtin";
    std::uint64_t seed = 1;
    std::int64_t count = 1000;
    IdentityConfig identity;
    ExpressionConfig expression;
    AlbedoConfig albedo;
    PoseConfig pose;
    CameraConfig camera;
    LightingConfig lighting;
    BackgroundConfig background;
    DegradationConfig degrade;
    OccluderConfig occluders;
    HeadConfig head;
    LandmarkConfig landmarks;
    RenderConfig render;
    OutputConfig output;
    SequenceConfig sequence;
};

// One configuration key: its dotted name, where it lives, and what it means.
struct ConfigField {
    std::string key;
    std::variant<double*, int*, std::int64_t*, std::uint64_t*, bool*, std::string*> target;
    std::string help;
};

// Every key of `config`, in documentation order. The pointers refer into `config`.
[[nodiscard]] std::vector<ConfigField> config_fields(SynthConfig& config);

// Applies a TOML file's keys (dotted names as tables: [a] b = 1 sets "a.b") to the fields they name;
// unknown keys and wrong types throw core::Error naming the file and the key.
void apply_toml_fields(const std::vector<ConfigField>& fields, const std::filesystem::path& path);

// Applies a TOML file's keys to `config`; unknown keys and wrong types throw core::Error naming
// the file and the key.
void apply_toml_file(SynthConfig& config, const std::filesystem::path& path);
// Applies keys given by a program as a JSON object (nested objects or dotted names, as TOML's
// tables; numbers, booleans and strings with TOML's types); unknown keys and wrong types throw
// core::Error "`origin`: config key '…' …".
void apply_settings(SynthConfig& config, const nlohmann::json& settings, const std::string& origin);
// Applies one `key.sub=value` override; throws core::Error naming the key.
void apply_override(SynthConfig& config, std::string_view assignment);
// Throws core::Error naming the first key whose value is out of range.
void validate(const SynthConfig& config);

// The full resolved configuration as nested JSON objects (keys as in TOML).
[[nodiscard]] nlohmann::json to_json(const SynthConfig& config);
// Reads a configuration back from to_json's output (unknown keys are errors).
[[nodiscard]] SynthConfig config_from_json(const nlohmann::json& json);

// The configuration as a commented TOML document (every key, its value and its meaning).
[[nodiscard]] std::string to_commented_toml(const SynthConfig& config);

// Output formats named in output.formats.
struct OutputFormats {
    bool folder = false;
    bool wds = false;
    bool coco = false;
};
[[nodiscard]] OutputFormats parse_formats(const std::string& formats);

}  // namespace facesynth::synth
