#pragma once
// The per-sample scene: everything random about sample i, drawn from Rng(seed, i, stream) with one
// RandomStream per quantity, so sample i depends only on (config, model, seed, i).
#include "degrade/degrade.h"
#include "morph/camera.h"
#include "morph/model.h"
#include "morph/pose.h"
#include "morph/skin_colour.h"
#include "render/lighting.h"
#include "synth/config.h"
#include "synth/head_parts.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace facesynth::synth {

// The sampled lighting in the renderer's terms (view space: x right, y up, z toward the camera),
// with the colour temperatures it was drawn from.
struct LightingSpec {
    render::Lighting lighting;
    double environment_radiance = 0;        // radiance of the SH environment's DC term
    double environment_temperature = 6500;  // K
    std::vector<double> light_temperatures;  // K, one per directional light
    std::array<double, 3> white_balance_gain{1, 1, 1};  // applied to every light colour above (already in `lighting`)
    double face_luminance = 0;  // face-metered exposure's target grey level, 0 = none (synth/exposure.h)
    // With lighting.face_light = "even": the sampled lighting, which lights the head parts only, scaled so
    // that a surface facing the camera receives what `lighting` (then the environment's uniform term,
    // which lights the face) gives it.
    std::optional<render::Lighting> head_parts;
};

struct BackgroundSpec {
    std::string type;  // solid, procedural, images
    Eigen::Vector3d colour = Eigen::Vector3d::Zero();   // sRGB in [0, 1]; the only colour for solid
    Eigen::Vector3d colour2 = Eigen::Vector3d::Zero();  // second gradient colour (procedural)
    double gradient_angle = 0;                          // degrees (procedural)
    std::uint64_t pattern_seed = 0;                     // procedural shapes / image choice and crop
};

struct OccluderSpec {
    std::string shape;  // "ellipse" or "rectangle"
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // px, 0-based
    Eigen::Vector2d half_size = Eigen::Vector2d::Zero();  // px
    double angle = 0;                                  // degrees
    Eigen::Vector3d colour = Eigen::Vector3d::Zero();  // sRGB in [0, 1]
    // occluders.fill = "image": the seed of the background-image crop that fills the shape (as
    // BackgroundSpec::pattern_seed); 0: the flat colour.
    std::uint64_t image_seed = 0;
    // occluders.fill = "skin": the face's median skin colour as rendered, times this shade (0: the flat colour).
    double skin_shade = 0;
};

// The fit a texture bank's texture was taken with: the identity (empty in banks made before shapes
// were stored), the expression (absent in banks made before expressions were stored) and the pose.
struct TextureFit {
    std::vector<float> shape;
    std::optional<std::vector<float>> expression;
    morph::EulerAngles angles;  // the fitted head pose, degrees (pose.source = "texture")
};

// Where a sample sits in its clip (sequence.frames > 0).
struct SequencePosition {
    std::int64_t clip = 0;
    int frame = 0;
    double time_s = 0;  // frame / sequence.fps
};

struct SampleSpec {
    std::uint64_t seed = 0;
    std::int64_t index = 0;
    std::string key;  // "s00001234"
    std::vector<float> alpha, psi, beta;
    int albedo_redraws = 0;     // implausible colour draws replaced (albedo.reject_implausible)
    double albedo_shrink = 1;   // < 1: no redraw passed and the first draw was moved toward the mean
    // Uniform skin colour (linear RGB) for models without a colour model; empty otherwise.
    std::optional<Eigen::Vector3d> skin_tone;
    // With albedo.texture_folder or albedo.texture_bank: which texture map (a draw taken modulo the number of maps).
    std::optional<std::uint64_t> texture_choice;
    // With albedo.texture_tone_jitter: per-channel gain on the texture's linear albedo (R G B).
    Eigen::Vector3d texture_gain = Eigen::Vector3d::Ones();
    // With albedo.texture_mix_probability: the texture whose coarse colour is mixed in (a draw taken
    // modulo the number of maps), and by how much.
    std::optional<std::uint64_t> texture_mix_choice;
    double texture_mix_weight = 0;
    morph::EulerAngles angles;
    morph::CameraPose pose;
    morph::Intrinsics intrinsics;
    double fov = 0;  // vertical, degrees
    LightingSpec lighting;
    BackgroundSpec background;
    degrade::DegradationSpec degradation;
    std::vector<OccluderSpec> occluders;
    std::optional<HeadPartsSpec> head_parts;  // with head.body
    std::optional<SequencePosition> sequence;  // with sequence.frames
};

// "s" + the index in 8 digits (keys without dots, as WebDataset wants).
[[nodiscard]] std::string sample_key(std::int64_t index);

// Draws the scene of sample `index` (with sequence.frames: frame index % frames of clip index / frames,
// whose clip-level quantities are drawn with the clip's number as the index). The camera distance and translation are chosen so that the
// sampled face (its 68 landmarks) has the sampled size and position in the image. `albedo_check` is
// make_albedo_check's result, made once per model; without it, it is made here when needed. With
// `shape`, the sampled shape (identity and expression, model space) that placed the face is moved
// there, so that a renderer need not evaluate the model a second time.
// `texture_fits` are the texture bank's fits, one per texture (ImageLibrary::fits), which
// identity.source = "texture" and expression.source = "texture" need.
[[nodiscard]] SampleSpec sample_scene(const SynthConfig& config, const morph::MorphableModel& model, std::int64_t index,
                                      const morph::SkinColourCheck* albedo_check = nullptr, Eigen::Matrix3Xf* shape = nullptr,
                                      std::span<const TextureFit> texture_fits = {});

// What sample `index` wears with head.body (the kHead stream); `head` is its head pose.
[[nodiscard]] HeadPartsSpec sample_head_parts(const SynthConfig& config, std::int64_t index, const morph::EulerAngles& head);

// Redraws per sample before falling back to shrinking the first draw (albedo.reject_implausible).
inline constexpr int kMaxAlbedoRedraws = 16;

// The check albedo.reject_implausible applies: none when the key is off or the model has no colour
// model. Throws core::Error naming the model when its mean colour fails the check itself.
[[nodiscard]] std::optional<morph::SkinColourCheck> make_albedo_check(const SynthConfig& config, const morph::MorphableModel& model);

// The colour coefficients of sample `index` (the model must have a colour model): the kAlbedo
// stream's draw, and while `albedo_check` rejects it, draws from the kAlbedoRedraw stream.
[[nodiscard]] morph::AlbedoDraw sample_albedo(const SynthConfig& config, const morph::MorphableModel& model, std::int64_t index,
                                       const morph::SkinColourCheck* albedo_check);

// Linear RGB of a black body at `kelvin`, normalised to a maximum component of 1.
[[nodiscard]] Eigen::Vector3d colour_of_temperature(double kelvin);

}  // namespace facesynth::synth
