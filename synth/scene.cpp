#include "synth/scene.h"

#include "core/error.h"
#include "core/random.h"
#include "morph/landmarks.h"
#include "morph/sampling.h"
#include "core/srgb.h"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <utility>

namespace facesynth::synth {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

double sample_angle(core::Rng& rng, const AngleDistribution& a) {
    if (a.distribution == "normal") {
        for (;;) {
            const double v = rng.normal(a.mean, a.stddev);
            if (v >= a.min && v <= a.max) return v;
        }
    }
    return rng.uniform(a.min, a.max);
}

// The normal distribution `a` moved so that its mean is `angle` plus a's mean, kept inside [min, max].
AngleDistribution centred_on(AngleDistribution a, double angle) {
    a.mean = std::clamp(angle + a.mean, a.min, a.max);
    return a;
}

bool chance(core::Rng& rng, double probability) { return rng.uniform() < probability; }

std::vector<float> sample_expression(const SynthConfig& config, const morph::MorphableModel& model, core::Rng& rng) {
    const int n = model.num_expression_components();
    if (n == 0 || !model.expression) return {};
    if (chance(rng, config.expression.neutral_share)) return {};
    if (std::holds_alternative<morph::PcaModel>(*model.expression))
        return morph::sample_coefficients(rng, n, config.expression.truncation);
    std::vector<float> weights(static_cast<std::size_t>(n), 0.0f);
    std::vector<int> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    const int active = rng.uniform_int(1, std::min(config.expression.max_active, n));
    for (int k = 0; k < active; ++k) {  // partial Fisher-Yates: `active` distinct blendshapes
        std::swap(order[static_cast<std::size_t>(k)], order[static_cast<std::size_t>(rng.uniform_int(k, n - 1))]);
        weights[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] =
            static_cast<float>(rng.uniform(config.expression.min_weight, config.expression.max_weight));
    }
    return weights;
}

// A skin colour between a light and a dark sRGB tone with a little hue variation, as linear RGB.
Eigen::Vector3d sample_skin_tone(core::Rng& rng) {
    const Eigen::Vector3d light(0.92, 0.76, 0.66), dark(0.34, 0.21, 0.15);
    const double t = rng.uniform();
    Eigen::Vector3d srgb = (1 - t) * light + t * dark;
    srgb.x() *= rng.uniform(0.95, 1.05);
    srgb.z() *= rng.uniform(0.9, 1.1);
    Eigen::Vector3d linear;
    for (int c = 0; c < 3; ++c) linear[c] = std::pow(std::clamp(srgb[c], 0.0, 1.0), 2.2);
    return linear;
}

std::vector<float> scaled(std::vector<float> values, double scale) {
    for (auto& v : values) v = static_cast<float>(v * scale);
    return values;
}

// A unit vector within `max_angle` degrees of `axis` (uniform over the spherical cap).
Eigen::Vector3d direction_in_cone(core::Rng& rng, const Eigen::Vector3d& axis, double max_angle) {
    const double cos_max = std::cos(max_angle * kDegree);
    const double z = rng.uniform(cos_max, 1.0);
    const double phi = rng.uniform(0.0, 2.0 * std::numbers::pi);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d local(r * std::cos(phi), r * std::sin(phi), z);
    const Eigen::Vector3d a = axis.normalized();
    const Eigen::Vector3d helper = std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d u = a.cross(helper).normalized();
    const Eigen::Vector3d v = a.cross(u);
    return (local.x() * u + local.y() * v + local.z() * a).normalized();
}

std::array<float, 3> to_floats(const Eigen::Vector3d& v) {
    return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}

// A camera's white balance: the environment's colour cast is divided out to the power `share`, with
// the mean of the environment colour kept, so warm and cool scenes keep a residual tint as in
// white-balanced photographs rather than the raw illuminant colour.
void white_balance(LightingSpec& spec, double share) {
    const Eigen::Vector3d cast = colour_of_temperature(spec.environment_temperature);
    Eigen::Vector3d gain = cast.array().pow(-share);
    gain *= cast.mean() / cast.cwiseProduct(gain).mean();
    const auto scale = [&](std::array<float, 3>& rgb) {
        for (int k = 0; k < 3; ++k) rgb[static_cast<std::size_t>(k)] *= static_cast<float>(gain[k]);
    };
    for (auto& coefficient : spec.lighting.sh) scale(coefficient);
    for (auto& light : spec.lighting.lights) scale(light.colour);
    spec.white_balance_gain = {gain[0], gain[1], gain[2]};
}

// lighting.face_light = "even": the face keeps the environment's uniform term (and the grey ambient);
// the whole drawn lighting goes to the head parts, scaled to give a camera-facing surface what the
// face's light gives it, so that the parts are shaded around the face's brightness rather than
// brightened by the lights added on top of it.
void light_head_parts_only(LightingSpec& spec) {
    render::Lighting even = spec.lighting;
    for (std::size_t k = 1; k < even.sh.size(); ++k) even.sh[k] = {0, 0, 0};
    even.lights.clear();
    even.specular = 0;
    even.shadows = false;
    render::Lighting parts = spec.lighting;
    const std::array<float, 3> toward_camera{0, 0, 1};
    const auto mean = [](const std::array<float, 3>& rgb) { return (rgb[0] + rgb[1] + rgb[2]) / 3; };
    const float drawn = mean(render::diffuse_shading(parts, toward_camera));
    const float scale = drawn > 0 ? mean(render::diffuse_shading(even, toward_camera)) / drawn : 1.0f;
    for (auto& coefficient : parts.sh)
        for (float& value : coefficient) value *= scale;
    for (float& value : parts.ambient) value *= scale;
    for (auto& light : parts.lights)
        for (float& value : light.colour) value *= scale;
    spec.lighting = even;
    spec.head_parts = parts;
}

LightingSpec sample_lighting(const SynthConfig& config, std::int64_t index) {
    const auto& c = config.lighting;
    core::Rng rng = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kLighting);
    LightingSpec spec;
    auto& l = spec.lighting;
    spec.environment_radiance = rng.uniform(c.environment_min, c.environment_max);
    spec.environment_temperature = rng.uniform(c.colour_temperature_min, c.colour_temperature_max);
    const Eigen::Vector3d dc = colour_of_temperature(spec.environment_temperature) * (spec.environment_radiance * render::kShUniformDc);
    l.sh[0] = to_floats(dc);
    for (std::size_t k = 1; k < l.sh.size(); ++k) l.sh[k] = to_floats(dc * (c.sh_strength * rng.normal()));
    // Environments are brighter from above and in front. Real SH order (Y00, Y1-1 ~ y, Y10 ~ z, Y11 ~ x,
    // ...) in view space, where up is +y and toward the camera is +z.
    l.sh[1] = to_floats(Eigen::Vector3d(l.sh[1][0], l.sh[1][1], l.sh[1][2]) + dc * (0.3 * c.sh_strength));
    l.sh[2] = to_floats(Eigen::Vector3d(l.sh[2][0], l.sh[2][1], l.sh[2][2]) + dc * (0.3 * c.sh_strength));
    const float ambient = static_cast<float>(rng.uniform(0.0, c.ambient_max));
    l.ambient = {ambient, ambient, ambient};
    const int count = rng.uniform_int(c.directional_min, c.directional_max);
    for (int i = 0; i < count; ++i) {
        // Toward the camera (+z) and somewhat from above (+y), spread over a wide cone.
        const Eigen::Vector3d direction = direction_in_cone(rng, Eigen::Vector3d(0, 0.4, 1), 75.0);
        const double temperature = rng.uniform(c.colour_temperature_min, c.colour_temperature_max);
        const double intensity = rng.uniform(c.intensity_min, c.intensity_max);
        l.lights.push_back({to_floats(direction), to_floats(colour_of_temperature(temperature) * intensity)});
        spec.light_temperatures.push_back(temperature);
    }
    l.specular = static_cast<float>(rng.uniform(0.0, c.specular_max));
    white_balance(spec, c.white_balance);
    // Drawn last, so that the draws above (and datasets made before shadows existed) are unchanged.
    const bool shadows = chance(rng, c.shadow_probability);
    l.shadows = shadows && !l.lights.empty();
    if (c.face_luminance_mean > 0) {
        core::Rng exposure = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kExposure);
        spec.face_luminance = std::clamp(exposure.normal(c.face_luminance_mean, c.face_luminance_stddev), 0.1, 0.9);
    }
    if (c.face_light == "even") light_head_parts_only(spec);
    return spec;
}

Eigen::Vector3d random_colour(core::Rng& rng) { return {rng.uniform(), rng.uniform(), rng.uniform()}; }

BackgroundSpec sample_background(const SynthConfig& config, std::int64_t index) {
    core::Rng rng = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kBackground);
    BackgroundSpec b;
    b.type = config.background.type;
    b.colour = random_colour(rng);
    b.colour2 = random_colour(rng);
    b.gradient_angle = rng.uniform(0.0, 360.0);
    b.pattern_seed = rng.next_u64();
    return b;
}

degrade::DegradationSpec sample_degradation(const SynthConfig& config, std::int64_t index) {
    const auto& c = config.degrade;
    core::Rng rng = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kDegradation);
    degrade::DegradationSpec d;
    // Every draw happens whatever the probabilities, so changing one probability never moves another value.
    const double blur = rng.uniform(0.3, c.blur_sigma_max);
    const double noise = rng.uniform(1.0, c.noise_sigma_max);
    const int quality = rng.uniform_int(c.jpeg_quality_min, c.jpeg_quality_max);
    const double gamma = rng.uniform(c.gamma_min, c.gamma_max);
    // One draw per statement (the order of draws within one expression is the compiler's choice), in
    // the order GCC drew them when they were one expression, so that GCC builds keep their datasets.
    const double blue_gain = rng.uniform(1 - c.colour_jitter, 1 + c.colour_jitter);
    const double green_gain = rng.uniform(1 - c.colour_jitter, 1 + c.colour_jitter);
    const double red_gain = rng.uniform(1 - c.colour_jitter, 1 + c.colour_jitter);
    const Eigen::Vector3d gains(red_gain, green_gain, blue_gain);
    const double downscale = rng.uniform(c.downscale_min, 1.0);
    if (chance(rng, c.blur_probability)) d.blur_sigma = blur;
    if (chance(rng, c.noise_probability)) d.noise_sigma = noise;
    if (chance(rng, c.jpeg_probability)) d.jpeg_quality = quality;
    if (chance(rng, c.gamma_probability)) d.gamma = gamma;
    if (chance(rng, c.colour_jitter_probability)) d.gains = gains;
    if (chance(rng, c.downscale_probability)) d.downscale = downscale;
    // Drawn after the others, so that datasets made before sharpening existed keep every value.
    const double sharpen = rng.uniform(0.25, c.sharpen_amount_max);
    if (chance(rng, c.sharpen_probability)) d.sharpen_amount = sharpen;
    return d;
}

std::vector<OccluderSpec> sample_occluders(const SynthConfig& config, std::int64_t index, const Eigen::Matrix2Xd& landmarks) {
    const auto& c = config.occluders;
    core::Rng rng = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kOccluder);
    std::vector<OccluderSpec> out;
    if (!chance(rng, c.probability)) return out;
    const Eigen::Vector2d low = landmarks.rowwise().minCoeff();
    const Eigen::Vector2d high = landmarks.rowwise().maxCoeff();
    const double face_size = (high - low).norm();
    const int count = rng.uniform_int(1, c.max_count);
    const Eigen::Vector2d face_centre = landmarks.rowwise().mean();
    for (int i = 0; i < count; ++i) {
        OccluderSpec o;
        o.shape = rng.uniform() < 0.5 ? "ellipse" : "rectangle";
        if (c.placement == "jaw") {
            // A point of the jaw line, the shape's long side along it, shifted across it from mostly inside
            // the face to just beside it: an edge of the shape runs near the face's own outline.
            const int segment = rng.uniform_int(0, morph::kNumJawLandmarks - 2);
            const Eigen::Vector2d a = landmarks.col(segment), b = landmarks.col(segment + 1);
            const Eigen::Vector2d on_line = a + rng.uniform() * (b - a);
            const Eigen::Vector2d along = (b - a).norm() > 0 ? Eigen::Vector2d((b - a).normalized()) : Eigen::Vector2d::UnitX();
            Eigen::Vector2d outward(along.y(), -along.x());
            if (outward.dot(on_line - face_centre) < 0) outward = -outward;
            const double across = rng.uniform(0.15, 0.5);  // before `along_line`: GCC's order (see sample_degradation)
            const double along_line = rng.uniform(0.5, 1.0);
            o.half_size = 0.5 * face_size * c.max_size * Eigen::Vector2d(along_line, across);
            o.centre = on_line + rng.uniform(-0.5, 1.0) * o.half_size.y() * outward;
            o.angle = std::atan2(along.y(), along.x()) * 180.0 / std::numbers::pi + rng.normal(0, 15.0);
        } else {
            // Centred on a random landmark so the occluder covers part of the face.
            const int anchor = rng.uniform_int(0, static_cast<int>(landmarks.cols()) - 1);
            const double dy = rng.normal(0, 0.05 * face_size);  // y before x: GCC's order (see sample_degradation)
            const double dx = rng.normal(0, 0.05 * face_size);
            o.centre = landmarks.col(anchor) + Eigen::Vector2d(dx, dy);
            const double height = rng.uniform(0.15, 1.0) * c.max_size;
            const double width = rng.uniform(0.15, 1.0) * c.max_size;
            o.half_size = 0.5 * face_size * Eigen::Vector2d(width, height);
            o.angle = rng.uniform(0.0, 180.0);
        }
        o.colour = random_colour(rng);
        out.push_back(o);
    }
    // After every shape, so that the shapes are those of fill = "colour"; never 0, which means flat colour.
    if (c.fill == "image")
        for (auto& o : out) o.image_seed = rng.next_u64() | 1U;
    if (c.fill == "skin")
        for (auto& o : out) o.skin_shade = rng.uniform(0.8, 1.1);
    return out;
}


// A key of a clip's trajectories (synth/config.h SequenceConfig): pose, expression and the face
// centre's offset from the clip's place (shares of the image side).
struct TrajectoryKey {
    morph::EulerAngles angles;
    std::vector<float> psi;
    Eigen::Vector2d drift = Eigen::Vector2d::Zero();
};

// Key k >= 1 of clip `clip`, from key k - 1: held, or a step toward a fresh draw from the pose
// distribution (so that every key stays inside it) with a fresh expression and drift.
TrajectoryKey next_key(const SynthConfig& config, const morph::MorphableModel& model, std::uint64_t clip, int k, const TrajectoryKey& previous) {
    const SequenceConfig& q = config.sequence;
    core::Rng clip_rng = core::make_rng(config.seed, clip, core::RandomStream::kSequence);
    core::Rng rng(clip_rng.next_u64(), static_cast<std::uint64_t>(k), 0);
    if (rng.uniform() < q.hold_share) return previous;
    const auto step = [&](double from, const AngleDistribution& distribution, double limit) {
        return from + std::clamp(sample_angle(rng, distribution) - from, -limit, limit);
    };
    TrajectoryKey key;
    key.angles.yaw = step(previous.angles.yaw, config.pose.yaw, q.max_turn_deg);
    key.angles.pitch = step(previous.angles.pitch, config.pose.pitch, 0.5 * q.max_turn_deg);
    key.angles.roll = step(previous.angles.roll, config.pose.roll, 0.5 * q.max_turn_deg);
    key.psi = config.expression.source == "texture" ? previous.psi : sample_expression(config, model, rng);
    const double drift_y = rng.uniform(-q.drift, q.drift);  // y before x: GCC's order (see sample_degradation)
    const double drift_x = rng.uniform(-q.drift, q.drift);
    key.drift = Eigen::Vector2d(drift_x, drift_y);
    return key;
}

std::vector<float> blend(const std::vector<float>& a, const std::vector<float>& b, double w) {
    std::vector<float> out(std::max(a.size(), b.size()), 0.0f);  // empty = neutral = zeros
    for (std::size_t c = 0; c < out.size(); ++c) {
        const double from = c < a.size() ? a[c] : 0.0;
        const double to = c < b.size() ? b[c] : 0.0;
        out[c] = static_cast<float>(from + w * (to - from));
    }
    return out;
}

// The state at `frame`: keys every key_seconds, eased between them (zero velocity at a key, so a
// held interval is exactly still).
TrajectoryKey trajectory_at(const SynthConfig& config, const morph::MorphableModel& model, std::uint64_t clip, int frame, const TrajectoryKey& first) {
    const double position = frame / config.sequence.fps / config.sequence.key_seconds;
    const int segment = static_cast<int>(std::floor(position));
    TrajectoryKey from = first;
    for (int k = 1; k <= segment; ++k) from = next_key(config, model, clip, k, from);
    const double u = position - segment;
    if (u <= 0) return from;
    const TrajectoryKey to = next_key(config, model, clip, segment + 1, from);
    const double w = u * u * (3 - 2 * u);
    TrajectoryKey state;
    state.angles.yaw = from.angles.yaw + w * (to.angles.yaw - from.angles.yaw);
    state.angles.pitch = from.angles.pitch + w * (to.angles.pitch - from.angles.pitch);
    state.angles.roll = from.angles.roll + w * (to.angles.roll - from.angles.roll);
    state.psi = blend(from.psi, to.psi, w);
    state.drift = from.drift + w * (to.drift - from.drift);
    return state;
}
}  // namespace

std::string sample_key(std::int64_t index) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "s%08lld", static_cast<long long>(index));
    return buffer;
}

Eigen::Vector3d colour_of_temperature(double kelvin) {
    // Planck's law at representative wavelengths of the R, G, B primaries, relative to 6500 K so
    // that daylight is white.
    constexpr double h = 6.62607015e-34, c = 2.99792458e8, k = 1.380649e-23;
    const auto radiance = [&](double nm, double temperature) {
        const double lambda = nm * 1e-9;
        return 1.0 / (std::pow(lambda, 5) * std::expm1(h * c / (lambda * k * temperature)));
    };
    const std::array<double, 3> wavelengths{610.0, 550.0, 465.0};
    Eigen::Vector3d rgb;
    for (int i = 0; i < 3; ++i) {
        const double nm = wavelengths[static_cast<std::size_t>(i)];
        rgb[i] = radiance(nm, kelvin) / radiance(nm, 6500.0);
    }
    return rgb / rgb.maxCoeff();
}

std::optional<morph::SkinColourCheck> make_albedo_check(const SynthConfig& config, const morph::MorphableModel& model) {
    if (!config.albedo.reject_implausible || model.num_albedo_components() == 0) return std::nullopt;
    morph::SkinColourCheck check(model);
    const morph::SkinColourVerdict mean = check.check({});
    if (!mean.plausible())
        throw core::Error("model '" + model.name + "': its mean colour already fails the skin colour check (" + morph::flaw_names(mean.flaws) +
                    "); set albedo.reject_implausible = false to sample it unchecked");
    return check;
}

morph::AlbedoDraw sample_albedo(const SynthConfig& config, const morph::MorphableModel& model, std::int64_t index, const morph::SkinColourCheck* albedo_check) {
    const auto i = static_cast<std::uint64_t>(index);
    core::Rng first = core::make_rng(config.seed, i, core::RandomStream::kAlbedo);
    core::Rng redraw = core::make_rng(config.seed, i, core::RandomStream::kAlbedoRedraw);
    return morph::draw_albedo(first, redraw, model.num_albedo_components(), config.albedo.truncation, config.albedo.scale, albedo_check,
                       kMaxAlbedoRedraws);
}

HeadPartsSpec sample_head_parts(const SynthConfig& config, std::int64_t index, const morph::EulerAngles& head) {
    core::Rng rng = core::make_rng(config.seed, static_cast<std::uint64_t>(index), core::RandomStream::kHead);
    HeadPartsSpec h;
    h.hair = rng.uniform() < config.head.hair_probability;
    h.hair_choice = rng.next_u64();
    h.clothing_choice = rng.next_u64();
    // Hair colours of people (sRGB), dark ones most often; half the textured samples take their
    // texture's scalp colour instead, so that the hair meets the hairline in the photograph.
    static constexpr std::array<double, 9> kWeights{0.25, 0.25, 0.15, 0.1, 0.07, 0.05, 0.05, 0.05, 0.03};
    const std::array<Eigen::Vector3d, 9> shades{Eigen::Vector3d(20, 17, 15),    Eigen::Vector3d(45, 32, 24),    Eigen::Vector3d(85, 60, 42),
                                                Eigen::Vector3d(130, 95, 65),   Eigen::Vector3d(165, 130, 90),  Eigen::Vector3d(200, 170, 120),
                                                Eigen::Vector3d(120, 55, 30),   Eigen::Vector3d(140, 138, 135), Eigen::Vector3d(190, 188, 185)};
    double pick = rng.uniform();
    std::size_t shade = 0;
    while (shade + 1 < kWeights.size() && pick >= kWeights[shade]) pick -= kWeights[shade++];
    const double gain = rng.uniform(0.85, 1.15);
    for (int c = 0; c < 3; ++c) h.hair_colour[c] = core::srgb_decode(std::min(1.0, gain * shades[shade][c] / 255.0));
    h.hair_colour_from_texture = rng.uniform() < 0.5;
    const auto fabric = [&rng] {
        // Any hue; greys, darks and muted colours as often as bright ones.
        // Value, saturation, hue: GCC's order (see sample_degradation).
        const auto value = static_cast<float>(rng.uniform(0.08, 0.9));
        const auto saturation = static_cast<float>(rng.uniform(0, 0.9));
        const auto hue = static_cast<float>(rng.uniform(0, 360));
        cv::Mat3f hsv(1, 1, cv::Vec3f(hue, saturation, value));
        cv::Mat3f rgb;
        cv::cvtColor(hsv, rgb, cv::COLOR_HSV2RGB);
        const cv::Vec3f c = rgb(0, 0);
        return Eigen::Vector3d(core::srgb_decode(c[0]), core::srgb_decode(c[1]), core::srgb_decode(c[2]));
    };
    h.clothing_colour = fabric();
    h.clothing_colour2 = fabric();
    const double pattern = rng.uniform();
    h.clothing_pattern = pattern < 0.5 ? 0 : pattern < 0.8 ? 1 : 2;
    h.pattern_period = rng.uniform(0.02, 0.08);
    h.pattern_seed = rng.next_u64();
    h.shirt = rng.uniform() < 0.9;
    h.neckline = rng.uniform(525, 575);
    h.neckline_dip = rng.uniform(0, 60);
    // The torso turns with the head, less: people turn their heads on their shoulders.
    h.torso.yaw = head.yaw * rng.uniform(0.0, 0.6);
    h.torso.pitch = head.pitch * rng.uniform(0.0, 0.5);
    h.torso.roll = head.roll * rng.uniform(0.0, 0.5);
    return h;
}

SampleSpec sample_scene(const SynthConfig& config, const morph::MorphableModel& model, std::int64_t index, const morph::SkinColourCheck* albedo_check,
                        Eigen::Matrix3Xf* shape, std::span<const TextureFit> texture_fits) {
    const int frames = config.sequence.frames;
    // What is drawn once per clip is drawn with the clip's number (the sample's index without clips).
    const std::int64_t draw = frames > 0 ? index / frames : index;
    const auto i = static_cast<std::uint64_t>(draw);
    SampleSpec s;
    s.seed = config.seed;
    s.index = index;
    s.key = sample_key(index);
    if (config.identity.source != "texture") {  // else the texture's shape, below
        core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kIdentity);
        s.alpha = scaled(morph::sample_coefficients(rng, model.num_shape_components(), config.identity.truncation), config.identity.scale);
    }
    if (config.expression.source != "texture") {  // else the texture's, below
        core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kExpression);
        s.psi = sample_expression(config, model, rng);
    }
    if (model.num_albedo_components() > 0) {
        std::optional<morph::SkinColourCheck> local_check;
        if (albedo_check == nullptr && config.albedo.reject_implausible) {
            local_check = make_albedo_check(config, model);
            albedo_check = &*local_check;
        }
        morph::AlbedoDraw albedo = sample_albedo(config, model, draw, config.albedo.reject_implausible ? albedo_check : nullptr);
        s.beta = std::move(albedo.beta);
        s.albedo_redraws = albedo.redraws;
        s.albedo_shrink = albedo.shrink;
    } else {
        core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kAlbedo);
        s.skin_tone = sample_skin_tone(rng);
    }
    if (!config.albedo.texture_folder.empty() || !config.albedo.texture_bank.empty()) {
        core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kTexture);
        s.texture_choice = rng.next_u64();
        const double jitter = config.albedo.texture_tone_jitter;
        if (jitter > 0)
            for (int c = 0; c < 3; ++c) s.texture_gain[c] = rng.uniform(1 - jitter, 1 + jitter);
        // Its own stream, so that the texture and gain draws above stay those of datasets without mixing.
        core::Rng mix = core::make_rng(config.seed, i, core::RandomStream::kTextureMix);
        if (chance(mix, config.albedo.texture_mix_probability)) {
            s.texture_mix_choice = mix.next_u64();
            s.texture_mix_weight = mix.uniform();
        }
    }
    const auto texture_fit = [&](const char* key) -> const TextureFit& {
        if (!s.texture_choice || texture_fits.empty())
            throw core::Error(std::string(key) + " = \"texture\": no texture bank fits were given (albedo.texture_bank)");
        return texture_fits[*s.texture_choice % texture_fits.size()];
    };
    const auto texture_number = [&] { return std::to_string(*s.texture_choice % texture_fits.size()); };
    if (config.identity.source == "texture") {
        const std::vector<float>& fitted = texture_fit("identity.source").shape;
        if (static_cast<int>(fitted.size()) != model.num_shape_components())
            throw core::Error("identity.source = \"texture\": the bank's texture " + texture_number() + " has " + std::to_string(fitted.size()) +
                        " shape coefficients, model '" + model.name + "' " + std::to_string(model.num_shape_components()) +
                        " (a bank made before shapes were stored: rebuild it)");
        s.alpha = fitted;
        if (config.identity.texture_jitter > 0) {
            core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kIdentity);  // unused otherwise with this source
            for (float& a : s.alpha) a += static_cast<float>(config.identity.texture_jitter * rng.normal());
        }
    }
    if (config.expression.source == "texture") {
        const std::optional<std::vector<float>>& fitted = texture_fit("expression.source").expression;
        if (!fitted || static_cast<int>(fitted->size()) != model.num_expression_components())
            throw core::Error("expression.source = \"texture\": the bank's texture " + texture_number() + " has " +
                        (fitted ? std::to_string(fitted->size()) + " expression coefficients" : std::string("no stored expression")) +
                        ", model '" + model.name + "' " + std::to_string(model.num_expression_components()) +
                        " (a bank made before expressions were stored: rebuild it)");
        s.psi = *fitted;
    }
    {
        core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kPose);
        // Random poses are centred on zero: validate() keeps a normal's mean inside [min, max], so the
        // distributions are the configured ones, unchanged.
        const morph::EulerAngles centre = config.pose.source == "texture" ? texture_fit("pose.source").angles : morph::EulerAngles{};
        s.angles.yaw = sample_angle(rng, centred_on(config.pose.yaw, centre.yaw));
        s.angles.pitch = sample_angle(rng, centred_on(config.pose.pitch, centre.pitch));
        s.angles.roll = sample_angle(rng, centred_on(config.pose.roll, centre.roll));
        s.pose.rotation = morph::rotation_from_euler(s.angles);
    }

    const auto& cam = config.camera;
    core::Rng rng = core::make_rng(config.seed, i, core::RandomStream::kCamera);
    s.fov = rng.uniform(cam.fov_min, cam.fov_max);
    s.intrinsics = morph::intrinsics_from_fov(s.fov, cam.width, cam.height);
    s.intrinsics.cx += cam.principal_point_jitter * cam.width * rng.uniform(-1.0, 1.0);
    s.intrinsics.cy += cam.principal_point_jitter * cam.height * rng.uniform(-1.0, 1.0);
    const double face_scale = rng.uniform(cam.face_scale_min, cam.face_scale_max);
    const double jitter = config.pose.translation_jitter;
    const double shift_y = rng.uniform(-1.0, 1.0);  // y before x: GCC's order (see sample_degradation)
    const double shift_x = rng.uniform(-1.0, 1.0);
    const Eigen::Vector2d target_centre(0.5 * (cam.width - 1) + jitter * cam.width * shift_x,
                                        0.5 * (cam.height - 1) + jitter * cam.height * shift_y);
    const double target_size = face_scale * std::hypot(cam.width, cam.height);

    // Place the face: the landmarks' box in rotated camera axes gives the size in mm; a first
    // distance from the pinhole scale, then one correction from the true perspective projection.
    Eigen::Matrix3Xf vertices = model.shape_instance(s.alpha, s.psi);
    const Eigen::Matrix3Xf landmarks = model.landmark_positions(vertices);
    if (landmarks.cols() == 0) throw core::Error("model '" + model.name + "' has no landmarks; synth needs the 68 iBUG landmarks");
    const Eigen::Matrix3Xd rotated = (morph::model_to_camera_flip() * s.pose.rotation) * landmarks.cast<double>();
    const Eigen::Vector3d low = rotated.rowwise().minCoeff();
    const Eigen::Vector3d high = rotated.rowwise().maxCoeff();
    const Eigen::Vector3d box_centre = 0.5 * (low + high);
    const double size_mm = std::hypot(high.x() - low.x(), high.y() - low.y());
    const double focal = 0.5 * (s.intrinsics.fx + s.intrinsics.fy);
    double distance = focal * size_mm / target_size;
    Eigen::Matrix2Xd projected;
    for (int pass = 0; pass < 2; ++pass) {
        const double depth = distance + box_centre.z();
        s.pose.translation = Eigen::Vector3d((target_centre.x() - s.intrinsics.cx) * depth / s.intrinsics.fx,
                                             (target_centre.y() - s.intrinsics.cy) * depth / s.intrinsics.fy, depth) -
                             box_centre;
        projected = project(s.intrinsics, s.pose, landmarks);
        const double achieved = (projected.rowwise().maxCoeff() - projected.rowwise().minCoeff()).norm();
        if (pass == 0 && achieved > 0) distance *= achieved / target_size;
    }
    s.lighting = sample_lighting(config, draw);
    s.background = sample_background(config, draw);
    s.degradation = sample_degradation(config, draw);
    s.occluders = sample_occluders(config, draw, projected);  // in a clip: still objects in front of the camera
    if (frames > 0) {
        // The clip was placed at its first key; the frame turns the head about the model's origin,
        // changes its expression and moves it in the image plane at the placed depth.
        const int frame = static_cast<int>(index % frames);
        const TrajectoryKey state = trajectory_at(config, model, i, frame, {s.angles, s.psi, Eigen::Vector2d::Zero()});
        s.angles = state.angles;
        s.pose.rotation = morph::rotation_from_euler(s.angles);
        s.psi = state.psi;
        const double depth = s.pose.translation.z();
        s.pose.translation.x() += state.drift.x() * cam.width * depth / s.intrinsics.fx;
        s.pose.translation.y() += state.drift.y() * cam.height * depth / s.intrinsics.fy;
        s.sequence = SequencePosition{draw, frame, frame / config.sequence.fps};
        if (shape) vertices = model.shape_instance(s.alpha, s.psi);
    }
    if (config.head.body) s.head_parts = sample_head_parts(config, draw, s.angles);
    if (shape) *shape = std::move(vertices);
    return s;
}

}  // namespace facesynth::synth
