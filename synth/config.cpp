#include "synth/config.h"

#include "core/error.h"
#include "core/toml_file.h"
#include "render/renderer.h"

#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>

namespace facesynth::synth {
namespace {

void add_angle(std::vector<ConfigField>& f, const std::string& name, AngleDistribution& a) {
    const std::string p = "pose." + name + ".";
    f.push_back({p + "distribution", &a.distribution, "\"uniform\" over [min, max] or \"normal\" (mean, stddev) kept inside [min, max]"});
    f.push_back({p + "min", &a.min, name + " lower bound, degrees"});
    f.push_back({p + "max", &a.max, name + " upper bound, degrees"});
    f.push_back({p + "mean", &a.mean, name + " mean for the normal distribution, degrees"});
    f.push_back({p + "stddev", &a.stddev, name + " standard deviation for the normal distribution, degrees"});
}

const ConfigField& find_field(const std::vector<ConfigField>& fields, std::string_view key, const std::string& context) {
    for (const auto& field : fields)
        if (field.key == key) return field;
    for (const std::string_view replaced : {"render.edge_antialiasing", "render.msaa_samples", "render.supersampling"})
        if (key == replaced)
            throw core::Error(context + "config key '" + std::string(key) +
                              "' was replaced by render.antialiasing (\"edges\", \"msaa\", \"supersampling\" or \"none\") and render.antialiasing_samples");
    throw core::Error(context + "unknown config key '" + std::string(key) + "'");
}

std::string type_name(const ConfigField& field) {
    return std::visit(
        [](auto* p) -> std::string {
            using T = std::remove_pointer_t<decltype(p)>;
            if constexpr (std::is_same_v<T, double>) return "a finite number";
            else if constexpr (std::is_same_v<T, bool>) return "true or false";
            else if constexpr (std::is_same_v<T, std::string>) return "a string";
            else return "an integer";
        },
        field.target);
}

template <typename Int>
bool parse_integer(std::string_view text, Int& out) {
    const auto* end = text.data() + text.size();
    const auto result = std::from_chars(text.data(), end, out);
    return result.ec == std::errc() && result.ptr == end;
}

// Sets a field from its text form (for --set); returns false when the text does not fit its type.
bool set_from_text(const ConfigField& field, std::string_view text) {
    return std::visit(
        [&](auto* p) -> bool {
            using T = std::remove_pointer_t<decltype(p)>;
            if constexpr (std::is_same_v<T, double>) {
                std::string copy(text);
                char* end = nullptr;
                const double v = std::strtod(copy.c_str(), &end);
                if (copy.empty() || end != copy.c_str() + copy.size() || !std::isfinite(v)) return false;
                *p = v;
                return true;
            } else if constexpr (std::is_same_v<T, bool>) {
                if (text == "true" || text == "1") *p = true;
                else if (text == "false" || text == "0") *p = false;
                else return false;
                return true;
            } else if constexpr (std::is_same_v<T, std::string>) {
                *p = std::string(text);
                return true;
            } else {
                return parse_integer(text, *p);
            }
        },
        field.target);
}

// Sets a field from a TOML value; returns false on a type mismatch.
bool set_from_toml(const ConfigField& field, const toml::value& value) {
    return std::visit(
        [&](auto* p) -> bool {
            using T = std::remove_pointer_t<decltype(p)>;
            if constexpr (std::is_same_v<T, double>) {
                if (value.is_floating() && std::isfinite(value.as_floating())) *p = value.as_floating();
                else if (value.is_integer()) *p = static_cast<double>(value.as_integer());
                else return false;
            } else if constexpr (std::is_same_v<T, bool>) {
                if (!value.is_boolean()) return false;
                *p = value.as_boolean();
            } else if constexpr (std::is_same_v<T, std::string>) {
                if (!value.is_string()) return false;
                *p = value.as_string().str;
            } else {
                if (!value.is_integer()) return false;
                if constexpr (std::is_same_v<T, std::uint64_t>) {
                    if (value.as_integer() < 0) return false;
                }
                *p = static_cast<T>(value.as_integer());
            }
            return true;
        },
        field.target);
}

void apply_toml_table(const std::vector<ConfigField>& fields, const toml::table& table, const std::string& prefix,
                      const std::string& context) {
    for (const auto& [name, value] : table) {
        const std::string key = prefix.empty() ? name : prefix + "." + name;
        if (value.is_table()) {
            apply_toml_table(fields, value.as_table(), key, context);
            continue;
        }
        const auto& field = find_field(fields, key, context);
        if (!set_from_toml(field, value)) throw core::Error(context + "config key '" + key + "' must be " + type_name(field));
    }
}

void apply_json_object(const std::vector<ConfigField>& fields, const nlohmann::json& object, const std::string& prefix) {
    for (const auto& item : object.items()) {
        // Not a structured binding: clang 14 (the fuzzing build) cannot capture one in the lambda below.
        const std::string& name = item.key();
        const nlohmann::json& value = item.value();
        const std::string key = prefix.empty() ? name : prefix + "." + name;
        if (value.is_object()) {
            apply_json_object(fields, value, key);
            continue;
        }
        const auto& field = find_field(fields, key, "dataset.json: ");
        std::visit([&](auto* p) { *p = value.get<std::remove_pointer_t<decltype(p)>>(); }, field.target);
    }
}

void require(bool ok, const std::string& key, const std::string& problem) {
    if (!ok) throw core::Error("config key '" + key + "': " + problem);
}

void validate_share(double v, const std::string& key) { require(v >= 0 && v <= 1, key, "must be in [0, 1]"); }

void validate_angle(const AngleDistribution& a, const std::string& name) {
    const std::string p = "pose." + name + ".";
    require(a.distribution == "uniform" || a.distribution == "normal", p + "distribution", "must be \"uniform\" or \"normal\"");
    require(a.min <= a.max, p + "min", "must not exceed " + p + "max");
    require(a.min >= -180 && a.max <= 180, p + "max", "angles must lie in [-180, 180]");
    if (a.distribution == "normal") {
        require(a.stddev > 0, p + "stddev", "must be positive for a normal distribution");
        require(a.mean >= a.min && a.mean <= a.max, p + "mean", "must lie in [min, max]");
    }
}

}  // namespace

std::vector<ConfigField> config_fields(SynthConfig& c) {
    std::vector<ConfigField> f;
    f.push_back({"model", &c.model, "model spec as for --model: builtin, a model file or a model folder"});
    f.push_back({"seed", &c.seed, "dataset seed; sample i depends only on (seed, i)"});
    f.push_back({"count", &c.count, "number of samples in the dataset"});
    f.push_back({"identity.truncation", &c.identity.truncation, "identity coefficients ~ N(0,1) truncated at ±k σ"});
    f.push_back({"identity.scale", &c.identity.scale, "multiplier on the identity coefficients (0 = mean face)"});
    f.push_back({"identity.source", &c.identity.source,
                 "\"random\" (drawn) or \"texture\" (the shape fitted to the photograph of the sample's texture; needs albedo.texture_bank)"});
    f.push_back({"identity.texture_jitter", &c.identity.texture_jitter,
                 "with source = \"texture\": N(0, x^2) added to each fitted shape coefficient per sample (sigma units; 0 = the fitted shape)"});
    f.push_back({"expression.neutral_share", &c.expression.neutral_share, "share of neutral faces"});
    f.push_back({"expression.max_active", &c.expression.max_active, "blendshape models: 1..max_active blendshapes per expressive face"});
    f.push_back({"expression.min_weight", &c.expression.min_weight, "blendshape weight lower bound"});
    f.push_back({"expression.max_weight", &c.expression.max_weight, "blendshape weight upper bound"});
    f.push_back({"expression.truncation", &c.expression.truncation, "PCA expression models: coefficients truncated at ±k σ"});
    f.push_back({"expression.source", &c.expression.source,
                 "\"random\" (drawn) or \"texture\" (the expression fitted to the photograph of the sample's texture; needs albedo.texture_bank)"});
    f.push_back({"albedo.truncation", &c.albedo.truncation, "colour coefficients truncated at ±k σ (models without a colour model get a random uniform skin tone)"});
    f.push_back({"albedo.scale", &c.albedo.scale, "multiplier on the colour coefficients (0 = mean colour)"});
    f.push_back({"albedo.reject_implausible", &c.albedo.reject_implausible,
                 "redraw colour draws whose mean skin colour is implausible (too dark, light or red, wrong hue, clamped; docs/builtin-model.md); the others are unchanged"});
    f.push_back({"albedo.texture_folder", &c.albedo.texture_folder,
                 "folder of UV texture maps (images, sampled with the model's uv); each sample renders with one, chosen from (seed, index); empty = off"});
    f.push_back({"albedo.texture_bank", &c.albedo.texture_bank,
                 "texture bank made by `facesynth textures` for this model; each sample renders with one of its textures, chosen from (seed, index); empty = off"});
    f.push_back({"albedo.texture_tone_jitter", &c.albedo.texture_tone_jitter,
                 "with a texture: its linear albedo times a per-channel gain uniform in [1 - x, 1 + x] per sample (0 = as in the texture)"});
    f.push_back({"albedo.texture_mix_probability", &c.albedo.texture_mix_probability,
                 "with a texture: share of samples whose texture takes the coarse colour of a second one (0 = off)"});
    add_angle(f, "yaw", c.pose.yaw);
    add_angle(f, "pitch", c.pose.pitch);
    add_angle(f, "roll", c.pose.roll);
    f.push_back({"pose.source", &c.pose.source,
                 "\"random\" or \"texture\": yaw, pitch and roll drawn around the pose fitted to the texture's photograph (albedo.texture_bank; the distributions' means become offsets)"});
    f.push_back({"pose.translation_jitter", &c.pose.translation_jitter, "face centre offset from the image centre, share of the image side (uniform ±)"});
    f.push_back({"camera.width", &c.camera.width, "image width, px"});
    f.push_back({"camera.height", &c.camera.height, "image height, px"});
    f.push_back({"camera.fov_min", &c.camera.fov_min, "vertical field of view lower bound, degrees"});
    f.push_back({"camera.fov_max", &c.camera.fov_max, "vertical field of view upper bound, degrees"});
    f.push_back({"camera.principal_point_jitter", &c.camera.principal_point_jitter, "principal point offset from the image centre, share of the side (uniform ±)"});
    f.push_back({"camera.face_scale_min", &c.camera.face_scale_min, "face size (68-landmark box diagonal) / image diagonal, lower bound"});
    f.push_back({"camera.face_scale_max", &c.camera.face_scale_max, "face size / image diagonal, upper bound"});
    f.push_back({"lighting.environment_min", &c.lighting.environment_min, "SH environment radiance lower bound"});
    f.push_back({"lighting.environment_max", &c.lighting.environment_max, "SH environment radiance upper bound"});
    f.push_back({"lighting.sh_strength", &c.lighting.sh_strength, "stddev of SH bands 1-2 relative to the DC term"});
    f.push_back({"lighting.ambient_max", &c.lighting.ambient_max, "extra grey ambient uniform in [0, ambient_max]"});
    f.push_back({"lighting.directional_min", &c.lighting.directional_min, "fewest directional lights per sample"});
    f.push_back({"lighting.directional_max", &c.lighting.directional_max, "most directional lights per sample (at most 4)"});
    f.push_back({"lighting.intensity_min", &c.lighting.intensity_min, "directional light intensity lower bound"});
    f.push_back({"lighting.intensity_max", &c.lighting.intensity_max, "directional light intensity upper bound"});
    f.push_back({"lighting.colour_temperature_min", &c.lighting.colour_temperature_min, "light colour temperature lower bound, K"});
    f.push_back({"lighting.colour_temperature_max", &c.lighting.colour_temperature_max, "light colour temperature upper bound, K"});
    f.push_back({"lighting.white_balance", &c.lighting.white_balance,
                 "share of the environment light's colour cast removed, as a camera's white balance does (0 = none, 1 = all)"});
    f.push_back({"lighting.specular_max", &c.lighting.specular_max, "Blinn-Phong specular weight upper bound"});
    f.push_back({"lighting.shadow_probability", &c.lighting.shadow_probability,
                 "share of samples whose directional lights cast shadows (shadow maps)"});
    f.push_back({"lighting.face_luminance_mean", &c.lighting.face_luminance_mean,
                 "face-metered exposure: mean grey level of the face in [0, 1] (0 = off)"});
    f.push_back({"lighting.face_luminance_stddev", &c.lighting.face_luminance_stddev, "face-metered exposure: its spread over samples"});
    f.push_back({"lighting.face_light", &c.lighting.face_light,
                 "\"sampled\" (the face lit as the rest) or \"even\" (the face under the environment's uniform light only, for textures "
                 "with their photograph's light; the sampled lights shade the head parts)"});
    f.push_back({"background.type", &c.background.type,
                 "\"solid\", \"procedural\", \"images\" (background.folder) or \"wallpapers\" (the photographs among Debian's wallpaper packages)"});
    f.push_back({"background.folder", &c.background.folder, "folder of background images (type = \"images\")"});
    f.push_back({"degrade.blur_probability", &c.degrade.blur_probability, "share of images blurred"});
    f.push_back({"degrade.blur_sigma_max", &c.degrade.blur_sigma_max, "Gaussian blur sigma upper bound, px"});
    f.push_back({"degrade.noise_probability", &c.degrade.noise_probability, "share of images with Gaussian noise"});
    f.push_back({"degrade.noise_sigma_max", &c.degrade.noise_sigma_max, "noise stddev upper bound, 8-bit levels"});
    f.push_back({"degrade.jpeg_probability", &c.degrade.jpeg_probability, "share of images passed through JPEG"});
    f.push_back({"degrade.jpeg_quality_min", &c.degrade.jpeg_quality_min, "JPEG degradation quality lower bound"});
    f.push_back({"degrade.jpeg_quality_max", &c.degrade.jpeg_quality_max, "JPEG degradation quality upper bound"});
    f.push_back({"degrade.gamma_probability", &c.degrade.gamma_probability, "share of images with a gamma change"});
    f.push_back({"degrade.gamma_min", &c.degrade.gamma_min, "gamma lower bound"});
    f.push_back({"degrade.gamma_max", &c.degrade.gamma_max, "gamma upper bound"});
    f.push_back({"degrade.colour_jitter_probability", &c.degrade.colour_jitter_probability, "share of images with per-channel gain jitter"});
    f.push_back({"degrade.colour_jitter", &c.degrade.colour_jitter, "per-channel gain in [1 - x, 1 + x]"});
    f.push_back({"degrade.downscale_probability", &c.degrade.downscale_probability, "share of images downscaled and scaled back up"});
    f.push_back({"degrade.downscale_min", &c.degrade.downscale_min, "smallest downscale factor"});
    f.push_back({"degrade.sharpen_probability", &c.degrade.sharpen_probability, "share of images sharpened (unsharp mask, as cameras do before JPEG)"});
    f.push_back({"degrade.sharpen_amount_max", &c.degrade.sharpen_amount_max, "unsharp-mask amount upper bound (lower bound 0.25)"});
    f.push_back({"occluders.probability", &c.occluders.probability, "share of samples with occluders"});
    f.push_back({"occluders.max_count", &c.occluders.max_count, "1..n occluding shapes"});
    f.push_back({"occluders.max_size", &c.occluders.max_size, "largest occluder extent, share of the face size"});
    f.push_back({"occluders.fill", &c.occluders.fill,
                 "\"colour\" (one random flat colour per shape), \"image\" (a random crop of a background image; background.type images or wallpapers) or \"skin\" (the face's own skin colour, shaded, as hands)"});
    f.push_back({"occluders.placement", &c.occluders.placement,
                 "\"landmarks\" (each shape centred near a random landmark) or \"jaw\" (along the jaw line, its edge beside the face's outline, as scarves, collars and hands)"});
    f.push_back({"head.neck", &c.head.neck, "a neck under the jaw (an elliptic cylinder placed by the face's landmarks, with the skin under the chin and region label neck); the model and its landmarks are unchanged"});
    f.push_back({"head.body", &c.head.body,
                 "neck, shoulders, clothing and hair meshes (MakeHuman's CC0 meshes) placed on the face; the model, its landmarks and face labels are unchanged"});
    f.push_back({"head.hair_probability", &c.head.hair_probability, "with head.body: share of samples with a hair mesh (the others show the model's scalp)"});
    f.push_back({"head.hair_styles", &c.head.hair_styles,
                 "with head.body: the hair meshes a sample draws from, comma-separated (afro01, bob01, bob02, braid01, long01, ponytail01, short01-short04); empty = all"});
    f.push_back({"head.ambient_occlusion", &c.head.ambient_occlusion,
                 "with head.body: darkens the bare skin of neck and shoulders by the sky the face and chin hide from it (ambient occlusion), 0 = off, 1 = fully"});
    f.push_back({"head.parts_file", &c.head.parts_file, "with head.body: a head parts file from tools/makehuman_parts.py (empty = the project's assets/head_parts.bin)"});
    f.push_back({"landmarks.mode", &c.landmarks.mode,
                 "jaw points written to .pts: \"contour\" (on the visible outline), \"even\" (contour, evenly spaced along the outline as 300-W annotators space them) or \"fixed\" (the model's vertices)"});
    f.push_back({"render.antialiasing", &c.render.antialiasing,
                 "\"edges\" (silhouette edges blended on the CPU after a single-sample render), \"msaa\", \"supersampling\" or \"none\""});
    f.push_back({"render.antialiasing_samples", &c.render.antialiasing_samples,
                 "msaa: samples per pixel (2-16); supersampling: N x N samples per pixel (N 2-4); 0 = 4 for msaa, 2 for supersampling"});
    f.push_back({"render.shadow_map_size", &c.render.shadow_map_size, "shadow-map texels per side, per light (with shadows)"});
    f.push_back({"render.lights_per_vertex", &c.render.lights_per_vertex,
                 "directional lights shaded per vertex (Gouraud): cheaper, narrow highlights softened; not with shadows"});
    f.push_back({"output.formats", &c.output.formats, "comma-separated: folder, wds, coco"});
    f.push_back({"output.image_format", &c.output.image_format, "\"png\" or \"jpg\""});
    f.push_back({"output.png_compression", &c.output.png_compression, "PNG deflate level 0-9 (low = fast, larger files; 0 = uncompressed)"});
    f.push_back({"output.jpeg_quality", &c.output.jpeg_quality, "JPEG quality for image_format = \"jpg\""});
    f.push_back({"output.depth", &c.output.depth, "write depth/ (EXR, camera-space mm)"});
    f.push_back({"output.mask", &c.output.mask, "write mask/ (PNG, 255 = face)"});
    f.push_back({"output.normals", &c.output.normals, "write normals/ (PNG)"});
    f.push_back({"output.labels", &c.output.labels, "write labels/ (PNG, 8-bit region ids: 0 background, 1 skin, 2 brows, 3 eyes, 4 lips, 5 nose, 6 mouth interior, 7 hair, 8 ears, 9 neck, 10 clothing)"});
    f.push_back({"output.wds_shard_size", &c.output.wds_shard_size, "samples per WebDataset tar"});
    f.push_back({"output.wds_prefix", &c.output.wds_prefix, "WebDataset tar name prefix ({prefix}-000000.tar)"});
    f.push_back({"sequence.frames", &c.sequence.frames, "frames per clip (0: still samples); sample i is frame i % frames of clip i / frames"});
    f.push_back({"sequence.fps", &c.sequence.fps, "frame rate of the clips"});
    f.push_back({"sequence.key_seconds", &c.sequence.key_seconds, "seconds between the keys of the pose, expression and drift trajectories"});
    f.push_back({"sequence.hold_share", &c.sequence.hold_share, "share of key intervals in which head and face hold still"});
    f.push_back({"sequence.max_turn_deg", &c.sequence.max_turn_deg, "largest yaw change between keys, degrees (pitch and roll: half)"});
    f.push_back({"sequence.drift", &c.sequence.drift, "the face centre moves within +- this share of the image side"});
    return f;
}

void apply_toml_fields(const std::vector<ConfigField>& fields, const std::filesystem::path& path) {
    const toml::value root = core::read_toml_file(path);
    if (!root.is_table()) throw core::file_error(path.string(), "not a TOML table");
    apply_toml_table(fields, root.as_table(), "", path.string() + ": ");
}

void apply_toml_file(SynthConfig& config, const std::filesystem::path& path) { apply_toml_fields(config_fields(config), path); }

namespace {

// The same value as TOML holds it, so that settings follow a TOML file's type rules.
toml::value toml_from_json(const nlohmann::json& value, const std::string& key, const std::string& context) {
    if (value.is_boolean()) return toml::value(value.get<bool>());
    if (value.is_number_integer()) {
        if (value.is_number_unsigned() && value.get<std::uint64_t>() > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
            throw core::Error(context + "config key '" + key + "': integer out of range");
        return toml::value(value.get<std::int64_t>());
    }
    if (value.is_number_float()) return toml::value(value.get<double>());
    if (value.is_string()) return toml::value(value.get<std::string>());
    if (value.is_object()) {
        toml::table table;
        for (const auto& item : value.items())
            table.emplace(item.key(), toml_from_json(item.value(), key.empty() ? item.key() : key + "." + item.key(), context));
        return toml::value(table);
    }
    throw core::Error(context + "config key '" + key + "' must be a number, boolean or string, got " + std::string(value.type_name()));
}

}  // namespace

void apply_settings(SynthConfig& config, const nlohmann::json& settings, const std::string& origin) {
    const std::string context = origin + ": ";
    if (!settings.is_object()) throw core::Error(context + "settings must be a mapping of config keys to values");
    const toml::value root = toml_from_json(settings, "", context);
    apply_toml_table(config_fields(config), root.as_table(), "", context);
}

void apply_override(SynthConfig& config, std::string_view assignment) {
    const auto eq = assignment.find('=');
    if (eq == std::string_view::npos || eq == 0)
        throw core::Error("--set '" + std::string(assignment) + "': expected key.sub=value");
    const auto key = assignment.substr(0, eq);
    const auto text = assignment.substr(eq + 1);
    const auto fields = config_fields(config);
    const auto& field = find_field(fields, key, "--set: ");
    if (!set_from_text(field, text))
        throw core::Error("--set: config key '" + std::string(key) + "' must be " + type_name(field) + ", got '" + std::string(text) + "'");
}

void validate(const SynthConfig& c) {
    require(c.count >= 0, "count", "must not be negative");
    require(c.count <= 99'999'999, "count", "at most 99999999 samples (8-digit keys)");
    require(c.identity.truncation >= 0, "identity.truncation", "must not be negative");
    require(c.identity.texture_jitter >= 0 && c.identity.texture_jitter <= 3, "identity.texture_jitter", "must be in [0, 3]");
    require(c.identity.texture_jitter == 0 || c.identity.source == "texture", "identity.texture_jitter", "needs identity.source = \"texture\"");
    require(c.identity.source == "random" || c.identity.source == "texture", "identity.source", "must be \"random\" or \"texture\"");
    require(c.identity.source != "texture" || !c.albedo.texture_bank.empty(), "identity.source",
            "\"texture\" needs albedo.texture_bank (the shapes come with the bank's textures)");
    require(c.expression.source == "random" || c.expression.source == "texture", "expression.source", "must be \"random\" or \"texture\"");
    require(c.expression.source != "texture" || !c.albedo.texture_bank.empty(), "expression.source",
            "\"texture\" needs albedo.texture_bank (the expressions come with the bank's textures)");
    validate_share(c.expression.neutral_share, "expression.neutral_share");
    require(c.expression.max_active >= 1, "expression.max_active", "must be at least 1");
    require(c.expression.min_weight <= c.expression.max_weight, "expression.min_weight", "must not exceed expression.max_weight");
    require(c.expression.truncation >= 0, "expression.truncation", "must not be negative");
    require(c.albedo.truncation >= 0, "albedo.truncation", "must not be negative");
    require(c.albedo.texture_folder.empty() || c.albedo.texture_bank.empty(), "albedo.texture_bank", "cannot be combined with albedo.texture_folder: set one");
    require(c.albedo.texture_tone_jitter >= 0 && c.albedo.texture_tone_jitter < 1, "albedo.texture_tone_jitter", "must be in [0, 1)");
    validate_share(c.albedo.texture_mix_probability, "albedo.texture_mix_probability");
    validate_angle(c.pose.yaw, "yaw");
    validate_angle(c.pose.pitch, "pitch");
    validate_angle(c.pose.roll, "roll");
    require(c.pose.source == "random" || c.pose.source == "texture", "pose.source", "must be \"random\" or \"texture\"");
    require(c.pose.source != "texture" || !c.albedo.texture_bank.empty(), "pose.source",
            "\"texture\" needs albedo.texture_bank (the poses come with the bank's textures)");
    require(c.sequence.frames == 0 || c.pose.source == "random", "pose.source",
            "\"texture\" is for still samples: a clip's keys are drawn from the distributions themselves (sequence.frames > 0)");
    for (const auto& [angle, name] : {std::pair{&c.pose.yaw, "yaw"}, std::pair{&c.pose.pitch, "pitch"}, std::pair{&c.pose.roll, "roll"}})
        require(c.pose.source != "texture" || angle->distribution == "normal", std::string("pose.") + name + ".distribution",
                "must be \"normal\" with pose.source = \"texture\" (drawn around the texture's angle)");
    require(c.pose.translation_jitter >= 0 && c.pose.translation_jitter < 0.5, "pose.translation_jitter", "must be in [0, 0.5)");
    require(c.camera.width >= 16 && c.camera.width <= 8192, "camera.width", "must be in [16, 8192]");
    require(c.camera.height >= 16 && c.camera.height <= 8192, "camera.height", "must be in [16, 8192]");
    require(c.camera.fov_min > 0 && c.camera.fov_min <= c.camera.fov_max, "camera.fov_min", "must be positive and not exceed camera.fov_max");
    require(c.camera.fov_max < 150, "camera.fov_max", "must be below 150 degrees");
    require(c.camera.principal_point_jitter >= 0 && c.camera.principal_point_jitter < 0.5, "camera.principal_point_jitter", "must be in [0, 0.5)");
    require(c.camera.face_scale_min > 0 && c.camera.face_scale_min <= c.camera.face_scale_max, "camera.face_scale_min", "must be positive and not exceed camera.face_scale_max");
    require(c.camera.face_scale_max <= 2, "camera.face_scale_max", "must be at most 2");
    require(c.lighting.environment_min >= 0 && c.lighting.environment_min <= c.lighting.environment_max, "lighting.environment_min",
            "must be in [0, lighting.environment_max]");
    require(c.lighting.ambient_max >= 0, "lighting.ambient_max", "must not be negative");
    require(c.lighting.sh_strength >= 0, "lighting.sh_strength", "must not be negative");
    require(c.lighting.directional_max >= 0 && c.lighting.directional_max <= 4, "lighting.directional_max", "must be in [0, 4]");
    require(c.lighting.directional_min >= 0 && c.lighting.directional_min <= c.lighting.directional_max, "lighting.directional_min",
            "must be in [0, lighting.directional_max]");
    require(c.lighting.intensity_min >= 0 && c.lighting.intensity_min <= c.lighting.intensity_max, "lighting.intensity_min", "must be in [0, lighting.intensity_max]");
    require(c.lighting.colour_temperature_min >= 1000 && c.lighting.colour_temperature_min <= c.lighting.colour_temperature_max,
            "lighting.colour_temperature_min", "must be at least 1000 K and not exceed lighting.colour_temperature_max");
    require(c.lighting.white_balance >= 0 && c.lighting.white_balance <= 1, "lighting.white_balance", "must lie in [0, 1]");
    require(c.lighting.colour_temperature_max <= 40000, "lighting.colour_temperature_max", "must be at most 40000 K");
    require(c.lighting.specular_max >= 0, "lighting.specular_max", "must not be negative");
    validate_share(c.lighting.shadow_probability, "lighting.shadow_probability");
    require(c.lighting.face_luminance_mean == 0 || (c.lighting.face_luminance_mean >= 0.1 && c.lighting.face_luminance_mean <= 0.9),
            "lighting.face_luminance_mean", "must be 0 (off) or in [0.1, 0.9]");
    require(c.lighting.face_luminance_stddev >= 0 && c.lighting.face_luminance_stddev <= 0.5, "lighting.face_luminance_stddev",
            "must be in [0, 0.5]");
    require(c.background.type == "solid" || c.background.type == "procedural" || c.background.type == "images" || c.background.type == "wallpapers",
            "background.type", "must be \"solid\", \"procedural\", \"images\" or \"wallpapers\"");
    require(c.background.type != "images" || !c.background.folder.empty(), "background.folder", "must name a folder when background.type = \"images\"");
    validate_share(c.head.hair_probability, "head.hair_probability");
    validate_share(c.head.ambient_occlusion, "head.ambient_occlusion");
    require(!(c.head.body && c.head.neck), "head.body", "cannot be combined with head.neck (the body has its own neck): set one");
    const auto& d = c.degrade;
    for (const auto& [value, key] : {std::pair{d.blur_probability, "degrade.blur_probability"}, {d.noise_probability, "degrade.noise_probability"},
                                     {d.jpeg_probability, "degrade.jpeg_probability"}, {d.gamma_probability, "degrade.gamma_probability"},
                                     {d.colour_jitter_probability, "degrade.colour_jitter_probability"},
                                     {d.downscale_probability, "degrade.downscale_probability"},
                                     {d.sharpen_probability, "degrade.sharpen_probability"}, {c.occluders.probability, "occluders.probability"}})
        validate_share(value, key);
    require(d.blur_sigma_max >= 0.3, "degrade.blur_sigma_max", "must be at least 0.3");
    require(d.noise_sigma_max >= 1, "degrade.noise_sigma_max", "must be at least 1");
    require(d.jpeg_quality_min >= 1 && d.jpeg_quality_min <= d.jpeg_quality_max && d.jpeg_quality_max <= 100, "degrade.jpeg_quality_min",
            "need 1 <= jpeg_quality_min <= jpeg_quality_max <= 100");
    require(d.gamma_min > 0 && d.gamma_min <= d.gamma_max, "degrade.gamma_min", "must be positive and not exceed degrade.gamma_max");
    require(d.colour_jitter >= 0 && d.colour_jitter < 1, "degrade.colour_jitter", "must be in [0, 1)");
    require(d.downscale_min > 0 && d.downscale_min <= 1, "degrade.downscale_min", "must be in (0, 1]");
    require(d.sharpen_amount_max >= 0.25 && d.sharpen_amount_max <= 5, "degrade.sharpen_amount_max", "must be in [0.25, 5]");
    require(c.occluders.max_count >= 1, "occluders.max_count", "must be at least 1");
    require(c.sequence.frames >= 0, "sequence.frames", "must not be negative");
    require(std::isfinite(c.sequence.fps) && c.sequence.fps > 0 && c.sequence.fps <= 1000, "sequence.fps", "must be in (0, 1000]");
    require(std::isfinite(c.sequence.key_seconds) && c.sequence.key_seconds > 0, "sequence.key_seconds", "must be positive");
    validate_share(c.sequence.hold_share, "sequence.hold_share");
    require(c.sequence.max_turn_deg >= 0 && c.sequence.max_turn_deg <= 180, "sequence.max_turn_deg", "must be in [0, 180]");
    require(c.sequence.drift >= 0 && c.sequence.drift <= 0.5, "sequence.drift", "must be in [0, 0.5]");
    require(c.occluders.max_size > 0 && c.occluders.max_size <= 1, "occluders.max_size", "must be in (0, 1]");
    require(c.occluders.fill == "colour" || c.occluders.fill == "image" || c.occluders.fill == "skin", "occluders.fill", "must be \"colour\", \"image\" or \"skin\"");
    require(c.occluders.placement == "landmarks" || c.occluders.placement == "jaw", "occluders.placement", "must be \"landmarks\" or \"jaw\"");
    require(c.occluders.fill != "image" || c.background.type == "images" || c.background.type == "wallpapers", "occluders.fill",
            "\"image\" takes its crops from the background images: needs background.type = \"images\" or \"wallpapers\"");
    require(c.lighting.face_light == "sampled" || c.lighting.face_light == "even", "lighting.face_light", "must be \"sampled\" or \"even\"");
    require(c.landmarks.mode == "contour" || c.landmarks.mode == "even" || c.landmarks.mode == "fixed", "landmarks.mode", "must be \"contour\", \"even\" or \"fixed\"");
    // The method first (with its default count), then the count, so that the error names the key at fault.
    for (const auto& [key, samples] : {std::pair{"render.antialiasing", 0}, std::pair{"render.antialiasing_samples", c.render.antialiasing_samples}}) {
        try {
            (void)render::antialiasing_from(c.render.antialiasing, samples);
        } catch (const core::Error& e) {
            require(false, key, e.what());
        }
    }
    require(c.render.shadow_map_size >= 16 && c.render.shadow_map_size <= 8192, "render.shadow_map_size", "must be in [16, 8192]");
    (void)parse_formats(c.output.formats);
    require(c.output.image_format == "png" || c.output.image_format == "jpg", "output.image_format", "must be \"png\" or \"jpg\"");
    require(c.output.png_compression >= 0 && c.output.png_compression <= 9, "output.png_compression", "must be in [0, 9]");
    require(c.output.jpeg_quality >= 1 && c.output.jpeg_quality <= 100, "output.jpeg_quality", "must be in [1, 100]");
    require(c.output.wds_shard_size >= 1, "output.wds_shard_size", "must be at least 1");
    require(!c.output.wds_prefix.empty() && c.output.wds_prefix.find_first_of("/.") == std::string::npos, "output.wds_prefix",
            "must be a non-empty name without '/' or '.'");
}

nlohmann::json to_json(const SynthConfig& config) {
    SynthConfig copy = config;
    nlohmann::json out = nlohmann::json::object();
    for (const auto& field : config_fields(copy)) {
        nlohmann::json* node = &out;
        std::string_view rest = field.key;
        for (auto dot = rest.find('.'); dot != std::string_view::npos; dot = rest.find('.')) {
            node = &(*node)[std::string(rest.substr(0, dot))];
            rest.remove_prefix(dot + 1);
        }
        std::visit([&](auto* p) { (*node)[std::string(rest)] = *p; }, field.target);
    }
    return out;
}

SynthConfig config_from_json(const nlohmann::json& json) {
    SynthConfig config;
    apply_json_object(config_fields(config), json, "");
    return config;
}

std::string to_commented_toml(const SynthConfig& config) {
    SynthConfig copy = config;
    std::string text;
    std::string table;
    for (const auto& field : config_fields(copy)) {
        const auto dot = field.key.rfind('.');
        const std::string section = dot == std::string::npos ? "" : field.key.substr(0, dot);
        const std::string name = dot == std::string::npos ? field.key : field.key.substr(dot + 1);
        if (section != table) {
            text += "\n[" + section + "]\n";
            table = section;
        }
        const std::string value = std::visit(
            [](auto* p) -> std::string {
                using T = std::remove_pointer_t<decltype(p)>;
                if constexpr (std::is_same_v<T, std::string>) return nlohmann::json(*p).dump();
                else if constexpr (std::is_same_v<T, bool>) return *p ? "true" : "false";
                else if constexpr (std::is_same_v<T, double>) {
                    std::string v = nlohmann::json(*p).dump();
                    if (v.find_first_of(".eE") == std::string::npos) v += ".0";
                    return v;
                } else return std::to_string(*p);
            },
            field.target);
        text += name + " = " + value + "  # " + field.help + "\n";
    }
    return text;
}

OutputFormats parse_formats(const std::string& formats) {
    OutputFormats out;
    std::stringstream stream(formats);
    std::string name;
    while (std::getline(stream, name, ',')) {
        if (name == "folder") out.folder = true;
        else if (name == "wds") out.wds = true;
        else if (name == "coco") out.coco = true;
        else throw core::Error("config key 'output.formats': unknown format '" + name + "' (expected folder, wds, coco)");
    }
    if (!out.folder && !out.wds && !out.coco) throw core::Error("config key 'output.formats': name at least one format");
    return out;
}

}  // namespace facesynth::synth
