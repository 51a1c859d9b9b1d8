// Synth's render keys reach the renderer: render.antialiasing = "edges" (the default) blends the outline
// (fractional coverage in the mask) and leaves the geometry and the landmarks as they are; occluders
// drawn over the rendered picture.
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

// Spread of the image's grey values inside an occluder's shape, a few pixels in from its edge.
double spread_inside(const cv::Mat& image, const OccluderSpec& o) {
    cv::Mat inside = cv::Mat::zeros(image.size(), CV_8UC1);
    const cv::RotatedRect box(cv::Point2f(static_cast<float>(o.centre.x()), static_cast<float>(o.centre.y())),
                              cv::Size2f(static_cast<float>(2 * o.half_size.x()), static_cast<float>(2 * o.half_size.y())),
                              static_cast<float>(o.angle));
    cv::ellipse(inside, box, cv::Scalar(255), cv::FILLED);  // the ellipse inside either shape
    cv::erode(inside, inside, cv::Mat(), cv::Point(-1, -1), 3);
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
    cv::Scalar mean, stddev;
    cv::meanStdDev(grey, mean, stddev, inside);
    return stddev[0];
}

// occluders.fill = "image": each shape shows a crop of a background image (here stripes), where
// "colour" gives one flat colour; the landmarks and their occlusion flags are the same.
TEST(SampleRenderSettings, ImageFilledOccludersShowACropOfABackgroundImage) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig flat;
    flat.camera.width = flat.camera.height = 128;
    flat.background.type = "images";
    flat.background.folder = "(in memory)";
    flat.occluders.probability = 1;
    flat.occluders.max_count = 1;
    flat.occluders.max_size = 0.6;
    for (auto* p : {&flat.degrade.blur_probability, &flat.degrade.noise_probability, &flat.degrade.jpeg_probability,
                    &flat.degrade.gamma_probability, &flat.degrade.colour_jitter_probability, &flat.degrade.downscale_probability})
        *p = 0;
    SynthConfig filled = flat;
    filled.occluders.fill = "image";
    cv::Mat stripes(200, 300, CV_8UC3);
    for (int y = 0; y < stripes.rows; ++y) stripes.row(y).setTo(cv::Scalar::all(y / 4 % 2 ? 230 : 20));
    const ImageLibrary backgrounds({stripes}, {"stripes.png"});
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator with_flat(flat, model, backgrounds, none, options), with_image(filled, model, backgrounds, none, options);
    for (std::int64_t index = 0; index < 3; ++index) {
        const Sample a = with_flat.generate(index), b = with_image.generate(index);
        ASSERT_EQ(b.spec.occluders.size(), 1U) << "sample " << index;
        EXPECT_LT(spread_inside(a.image, a.spec.occluders[0]), 1.0) << "sample " << index;
        EXPECT_GT(spread_inside(b.image, b.spec.occluders[0]), 40.0) << "sample " << index;
        EXPECT_EQ(a.labels.landmarks_even, b.labels.landmarks_even) << "sample " << index;
        EXPECT_EQ(a.labels.occluded, b.labels.occluded) << "sample " << index;
        EXPECT_EQ(cv::norm(a.mask, b.mask, cv::NORM_INF), 0.0) << "sample " << index;
    }
}

}  // namespace
}  // namespace facesynth::synth
