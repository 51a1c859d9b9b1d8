// The meta file of one sample (synth/dataset.h sample_meta).
#include "synth/dataset.h"

#include "morph/landmarks.h"
#include "synth/dataset_layout.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <concepts>
#include <cstdio>
#include <string_view>

namespace facesynth::synth {
namespace {

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

}  // namespace

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
    if (s.lighting.head_parts) lighting["head_parts"] = *s.lighting.head_parts;  // lighting.face_light = "even" only
    if (s.lighting.face_luminance > 0) {  // keys only with the metering, so that other datasets' meta is unchanged
        lighting["face_luminance_target"] = s.lighting.face_luminance;
        lighting["exposure_gain"] = sample.exposure_gain;
    }
    const auto& b = s.background;
    const auto& d = s.degradation;
    const auto box = landmark_box(chosen_landmarks(labels, mode), k.width, k.height);
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
    if (!sample.texture.empty()) j.key("greyscale").raw(d.greyscale ? "true" : "false");  // only with textures: other datasets' meta unchanged
    j.key("jpeg_quality").integer(d.jpeg_quality);
    j.key("noise_sigma").number(d.noise_sigma);
    j.key("sharpen_amount").number(d.sharpen_amount);
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
    if (mode == "even") j.key("landmarks_3d_even").points(labels.landmarks_3d_even);  // only then, so that other datasets' meta is unchanged
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
        if (o.image_seed != 0) j.key("image_seed").integer(o.image_seed);
        j.key("shape").string(o.shape);
        if (o.skin_shade > 0) j.key("skin_shade").number(o.skin_shade);
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
    j.key("sequence");
    if (!s.sequence) {
        j.null();
    } else {
        j.begin_object();
        j.key("clip").integer(s.sequence->clip);
        j.key("frame").integer(s.sequence->frame);
        j.key("time_s").number(s.sequence->time_s);
        j.end_object();
    }
    j.key("skin_tone");
    if (s.skin_tone) j.point(*s.skin_tone);
    else j.null();
    j.key("texture");
    if (sample.texture.empty()) j.null();
    else j.string(sample.texture);
    j.key("texture_gain").point(s.texture_gain);
    if (config.albedo.texture_mix_probability > 0) {  // keys only with mixing, so that other datasets' meta is unchanged
        j.key("texture_mix");
        if (sample.texture_mix.empty()) j.null();
        else j.string(sample.texture_mix);
        j.key("texture_mix_weight").number(s.texture_mix_weight);
    }
    j.key("translation").point(s.pose.translation);
    j.key("visibility").integers(chosen_visibility(labels, mode));
    j.key("visibility_contour").integers(labels.visible_contour);
    j.key("visibility_fixed").integers(labels.visible_fixed);
    j.key("yaw").number(s.angles.yaw);
    j.end_object();
    return j.text();
}

}  // namespace facesynth::synth
