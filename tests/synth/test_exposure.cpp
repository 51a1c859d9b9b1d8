// Face-metered exposure (synth/exposure.h, lighting.face_luminance_mean): the metered grey level, the
// gain that reaches a target, its limits, the silhouette's coverage, and synth's samples with it.
#include "common/test_data.h"
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/exposure.h"
#include "synth/sample.h"
#include "synth/scene.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>

namespace facesynth::synth {
namespace {

// A square "face" of the given colour, fully covered, with its 4 corners as landmarks.
struct Layer {
    cv::Mat rgb, coverage;
    Eigen::Matrix2Xd landmarks;
};
Layer square_face(cv::Vec3b colour) {
    Layer layer;
    layer.rgb = cv::Mat(64, 64, CV_8UC3, cv::Scalar::all(0));
    layer.coverage = cv::Mat::zeros(64, 64, CV_8UC1);
    layer.rgb(cv::Rect(8, 8, 48, 48)).setTo(cv::Scalar(colour[0], colour[1], colour[2]));
    layer.coverage(cv::Rect(8, 8, 48, 48)).setTo(255);
    layer.landmarks.resize(2, 4);
    layer.landmarks << 10, 50, 50, 10, 10, 10, 50, 50;
    return layer;
}

TEST(FaceExposure, MetersTheGreyLevelInsideTheLandmarksHull) {
    const Layer layer = square_face({200, 100, 50});
    EXPECT_NEAR(face_luminance(layer.rgb, layer.coverage, layer.landmarks), (0.299 * 200 + 0.587 * 100 + 0.114 * 50) / 255, 1e-9);
    const cv::Mat uncovered = cv::Mat::zeros(64, 64, CV_8UC1);
    EXPECT_TRUE(std::isnan(face_luminance(layer.rgb, uncovered, layer.landmarks)));
}

TEST(FaceExposure, ReachesTheTargetWithOneLinearGain) {
    Layer layer = square_face({100, 100, 100});
    const double gain = expose_face(layer.rgb, layer.coverage, layer.landmarks, 0.6, 2.2);
    EXPECT_NEAR(face_luminance(layer.rgb, layer.coverage, layer.landmarks), 0.6, 0.003);
    EXPECT_NEAR(gain, std::pow(0.6 * 255 / 100, 2.2), 0.05);
    EXPECT_EQ(layer.rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));  // nothing outside the face layer
    // Darker as well.
    Layer bright = square_face({220, 200, 180});
    EXPECT_LT(expose_face(bright.rgb, bright.coverage, bright.landmarks, 0.5, 2.2), 1.0);
    EXPECT_NEAR(face_luminance(bright.rgb, bright.coverage, bright.landmarks), 0.5, 0.003);
}

TEST(FaceExposure, StopsAtTwoStopsAndClipsAtWhite) {
    Layer dark = square_face({10, 10, 10});
    EXPECT_NEAR(expose_face(dark.rgb, dark.coverage, dark.landmarks, 0.5, 2.2), 4.0, 1e-3);
    EXPECT_LT(face_luminance(dark.rgb, dark.coverage, dark.landmarks), 0.1);
    Layer pale = square_face({250, 120, 120});
    (void)expose_face(pale.rgb, pale.coverage, pale.landmarks, 0.8, 2.2);
    EXPECT_EQ(pale.rgb.at<cv::Vec3b>(30, 30)[0], 255);
}

TEST(FaceExposure, KeepsTheSilhouettesCoverage) {
    Layer layer = square_face({100, 100, 100});
    layer.coverage.at<std::uint8_t>(8, 30) = 128;
    layer.rgb.at<cv::Vec3b>(8, 30) = cv::Vec3b(50, 50, 50);  // premultiplied: colour 99.6 at half coverage
    const double gain = expose_face(layer.rgb, layer.coverage, layer.landmarks, 0.6, 2.2);
    const double encoded = std::pow(gain, 1 / 2.2);
    EXPECT_NEAR(layer.rgb.at<cv::Vec3b>(8, 30)[0], 50 * encoded, 1.0);
    EXPECT_NEAR(layer.rgb.at<cv::Vec3b>(30, 30)[0], 100 * encoded, 1.0);
}

TEST(FaceExposure, ConfigKeysAreCheckedAndLeaveTheOtherDrawsAlone) {
    SynthConfig off;
    SynthConfig on = off;
    apply_override(on, "lighting.face_luminance_mean=0.5");
    validate(on);
    const morph::MorphableModel model = morph::load_model("builtin");
    for (std::int64_t index = 0; index < 20; ++index) {
        const SampleSpec a = sample_scene(off, model, index), b = sample_scene(on, model, index);
        EXPECT_EQ(a.lighting.face_luminance, 0);
        EXPECT_GE(b.lighting.face_luminance, 0.1);
        EXPECT_LE(b.lighting.face_luminance, 0.9);
        EXPECT_EQ(a.lighting.lighting.sh, b.lighting.lighting.sh);
        EXPECT_EQ(a.pose.rotation, b.pose.rotation);
        EXPECT_EQ(a.degradation.noise_sigma, b.degradation.noise_sigma);
    }
    SynthConfig wrong;
    apply_override(wrong, "lighting.face_luminance_mean=0.95");
    EXPECT_NE(testkit::error_message_of([&] { validate(wrong); }).find("lighting.face_luminance_mean"), std::string::npos);
}

TEST(FaceExposure, SamplesFacesAtTheirDrawnGreyLevel) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig config;
    config.camera.width = config.camera.height = 128;
    for (double* p : {&config.degrade.blur_probability, &config.degrade.noise_probability, &config.degrade.jpeg_probability,
                      &config.degrade.gamma_probability, &config.degrade.colour_jitter_probability, &config.degrade.downscale_probability})
        *p = 0;  // the degradations would move the grey level
    apply_override(config, "lighting.face_luminance_mean=0.5");
    const ImageLibrary none;
    SampleGenerator generator(config, model, none, none, render::RendererOptions{render::Backend::kEgl, false});
    for (std::int64_t index = 0; index < 4; ++index) {
        const Sample s = generator.generate(index);
        const double target = s.spec.lighting.face_luminance;
        const double reached = face_luminance(s.image, s.mask, chosen_landmarks(s.labels, config.landmarks.mode));
        if (s.exposure_gain > 0.26 && s.exposure_gain < 3.9) {
            EXPECT_NEAR(reached, target, 0.01) << "sample " << index;
        }
        EXPECT_NE(s.exposure_gain, 1.0) << "sample " << index;
    }
}

}  // namespace
}  // namespace facesynth::synth
