// Texture mixing (synth/texture_mix.h, albedo.texture_mix_probability): the features stay, the coarse
// colour moves by the weight, and synth's other draws do not change. Textures from greyscale
// photographs make greyscale pictures and never grey a coloured face.
#include "common/test_data.h"
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"
#include "synth/scene.h"
#include "synth/texture_mix.h"
#include "core/error.h"
#include "core/srgb.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace facesynth::synth {
namespace {

// A flat colour with a dark "brow" bar: the bar is a feature, the flat colour the coarse part.
cv::Mat texture(cv::Scalar skin, bool with_bar) {
    cv::Mat t(128, 128, CV_8UC3, skin);
    if (with_bar) t(cv::Rect(40, 60, 48, 4)).setTo(cv::Scalar(20, 20, 20));
    return t;
}

TEST(TextureMix, MovesTheCoarseColourByTheWeightAndKeepsTheFeatures) {
    const cv::Mat features = texture(cv::Scalar(200, 150, 120), true), colour = texture(cv::Scalar(100, 70, 50), false);
    cv::Mat none, half, all;
    mix_coarse_colour(features, colour, 0.0, none);
    mix_coarse_colour(features, colour, 0.5, half);
    mix_coarse_colour(features, colour, 1.0, all);
    EXPECT_EQ(cv::norm(none, features, cv::NORM_INF), 0);
    // Far from the bar the skin takes the other texture's colour by the weight.
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(all.at<cv::Vec3b>(10, 10)[c], colour.at<cv::Vec3b>(10, 10)[c], 1) << "channel " << c;
        // Half way in linear albedo: the geometric mean of the two.
        const double expected = 255 * core::srgb_encode(std::sqrt(core::srgb_decode(features.at<cv::Vec3b>(10, 10)[c] / 255.0) *
                                                                  core::srgb_decode(colour.at<cv::Vec3b>(10, 10)[c] / 255.0)));
        EXPECT_NEAR(half.at<cv::Vec3b>(10, 10)[c], expected, 1) << "channel " << c;
    }
    // The bar stays a dark feature: as many times darker than the skin beside it as before (linear).
    const auto linear = [](const cv::Mat& t, int y) { return core::srgb_decode(t.at<cv::Vec3b>(y, 64)[0] / 255.0); };
    EXPECT_NEAR(linear(all, 61) / linear(all, 70), linear(features, 61) / linear(features, 70), 0.01);
    // Other sizes are resized; other types refused.
    cv::Mat small;
    cv::resize(colour, small, cv::Size(64, 64));
    mix_coarse_colour(features, small, 1.0, all);
    EXPECT_EQ(all.size(), features.size());
    EXPECT_THROW(mix_coarse_colour(features, cv::Mat(8, 8, CV_8UC1), 1.0, all), core::Error);
}

TEST(TextureMix, DrawsOnItsOwnStream) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig plain;
    plain.albedo.texture_folder = "unused";  // only the draws are looked at: no texture is loaded
    SynthConfig mixing = plain;
    apply_override(mixing, "albedo.texture_mix_probability=0.5");
    int mixed = 0;
    for (std::int64_t index = 0; index < 40; ++index) {
        const SampleSpec a = sample_scene(plain, model, index), b = sample_scene(mixing, model, index);
        EXPECT_EQ(a.texture_choice, b.texture_choice);
        EXPECT_FALSE(a.texture_mix_choice);
        EXPECT_EQ(a.pose.rotation, b.pose.rotation);
        if (b.texture_mix_choice) {
            ++mixed;
            EXPECT_GE(b.texture_mix_weight, 0.0);
            EXPECT_LE(b.texture_mix_weight, 1.0);
        }
    }
    EXPECT_GT(mixed, 8);
    EXPECT_LT(mixed, 32);
    SynthConfig wrong;
    apply_override(wrong, "albedo.texture_mix_probability=1.5");
    EXPECT_NE(testkit::error_message_of([&] { validate(wrong); }).find("albedo.texture_mix_probability"), std::string::npos);
}

TEST(TextureMix, GreyscaleImagesAreTellableFromColouredOnes) {
    cv::Mat grey(64, 64, CV_8UC3, cv::Scalar(90, 90, 90));
    grey.at<cv::Vec3b>(3, 3) = cv::Vec3b(90, 92, 91);  // rounding and chroma noise
    EXPECT_TRUE(is_greyscale(grey));
    cv::Mat tinted = grey.clone();
    tinted(cv::Rect(0, 0, 64, 2)).setTo(cv::Scalar(90, 60, 40));  // 3 % coloured
    EXPECT_FALSE(is_greyscale(tinted));
    EXPECT_FALSE(is_greyscale(texture(cv::Scalar(200, 150, 120), true)));
}

TEST(TextureMix, GreyscalePhotographsTexturesMakeGreyscalePictures) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig config;
    config.camera.width = config.camera.height = 96;
    config.albedo.texture_bank = "given below";
    apply_override(config, "albedo.texture_mix_probability=1");
    const ImageLibrary textures({texture(cv::Scalar(128, 128, 128), true), texture(cv::Scalar(200, 150, 120), true)}, {"grey.png", "colour.png"},
                                {TextureFit{}, TextureFit{}});  // a bank's
    ASSERT_TRUE(textures.greyscale(0));
    ASSERT_FALSE(textures.greyscale(1));
    const ImageLibrary none;
    SampleGenerator generator(config, model, none, textures, render::RendererOptions{render::Backend::kEgl, false});
    int grey = 0, coloured = 0;
    for (std::int64_t index = 0; index < 12; ++index) {
        const Sample s = generator.generate(index);
        ASSERT_TRUE(s.spec.texture_choice.has_value());
        const bool from_grey = textures.greyscale(*s.spec.texture_choice);
        EXPECT_EQ(s.spec.degradation.greyscale, from_grey) << "sample " << index;
        EXPECT_EQ(is_greyscale(s.image), from_grey) << "sample " << index;
        if (!from_grey) {
            EXPECT_NE(s.texture_mix, "grey.png") << "sample " << index;  // a grey mix would grey the face alone
        }
        ++(from_grey ? grey : coloured);
    }
    EXPECT_GT(grey, 0);
    EXPECT_GT(coloured, 0);
    // A plain uv texture folder is rendered as it is: a grey uv map is a grey face, not a grey picture.
    SynthConfig folder = config;
    folder.albedo.texture_bank.clear();
    folder.albedo.texture_folder = "given above";
    SampleGenerator plain(folder, model, none, textures, render::RendererOptions{render::Backend::kEgl, false});
    for (std::int64_t index = 0; index < 12; ++index) EXPECT_FALSE(plain.generate(index).spec.degradation.greyscale) << "sample " << index;
}

}  // namespace
}  // namespace facesynth::synth
