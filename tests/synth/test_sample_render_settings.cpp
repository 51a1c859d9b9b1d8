// Synth's render keys reach the renderer: render.antialiasing = "edges" (the default) blends the outline
// (fractional coverage in the mask) and leaves the geometry and the landmarks as they are.
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace facesynth::synth {
namespace {

int partly_covered(const cv::Mat& mask) {
    int count = 0;
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) count += mask.at<std::uint8_t>(y, x) != 0 && mask.at<std::uint8_t>(y, x) != 255;
    return count;
}

TEST(SampleRenderSettings, EdgeAntialiasingKeyBlendsTheOutlineOnly) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig antialiased;
    antialiased.camera.width = antialiased.camera.height = 128;
    ASSERT_EQ(antialiased.render.antialiasing, "edges");  // the default
    SynthConfig aliased = antialiased;
    apply_override(aliased, "render.antialiasing=none");
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator with(antialiased, model, none, none, options), without(aliased, model, none, none, options);
    for (std::int64_t index = 0; index < 3; ++index) {
        const Sample a = with.generate(index), b = without.generate(index);
        EXPECT_EQ(partly_covered(b.mask), 0) << "sample " << index;
        EXPECT_GT(partly_covered(a.mask), 50) << "sample " << index;
        EXPECT_GT(cv::norm(a.image, b.image, cv::NORM_INF), 0.0) << "sample " << index;
        EXPECT_EQ(a.labels.landmarks_contour, b.labels.landmarks_contour) << "sample " << index;
        EXPECT_EQ(a.labels.visible_contour, b.labels.visible_contour) << "sample " << index;
    }
}

}  // namespace
}  // namespace facesynth::synth
