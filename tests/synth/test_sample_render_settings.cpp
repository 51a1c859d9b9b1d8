// Synth's render keys reach the renderer: render.antialiasing = "edges" (the default) blends the outline
// (fractional coverage in the mask) and leaves the geometry and the landmarks as they are; occluders
// drawn over the rendered picture.
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "morph/regions.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <vector>

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

// No degradation of the images: drawn colours stay as drawn.
void without_degradations(SynthConfig& config) {
    for (auto* p : {&config.degrade.blur_probability, &config.degrade.noise_probability, &config.degrade.jpeg_probability,
                    &config.degrade.gamma_probability, &config.degrade.colour_jitter_probability, &config.degrade.downscale_probability})
        *p = 0;
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
    without_degradations(flat);
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

// occluders.placement = "jaw" with fill = "skin": each shape lies across the jaw line, longer along it
// than across, in the face's own median skin colour (as rendered) times its shade; the landmarks are
// those of the same sample without occluders.
TEST(SampleRenderSettings, JawOccludersLieOnTheJawLineInTheFacesSkinColour) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig plain;
    plain.camera.width = plain.camera.height = 128;
    plain.output.labels = true;
    without_degradations(plain);
    SynthConfig jaw = plain;
    jaw.occluders.probability = 1;
    jaw.occluders.max_count = 1;
    jaw.occluders.max_size = 0.6;
    jaw.occluders.placement = "jaw";
    jaw.occluders.fill = "skin";
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator without(plain, model, none, none, options), with(jaw, model, none, none, options);
    for (std::int64_t index = 0; index < 4; ++index) {
        const Sample a = without.generate(index), b = with.generate(index);
        ASSERT_EQ(b.spec.occluders.size(), 1U) << "sample " << index;
        const OccluderSpec& o = b.spec.occluders[0];
        const Eigen::Matrix2Xd& points = b.labels.landmarks_fixed;
        double distance = 1e9;
        for (int i = 0; i + 1 < morph::kNumJawLandmarks; ++i) {
            const Eigen::Vector2d p = points.col(i), segment = points.col(i + 1) - p;
            const double t = std::clamp((o.centre - p).dot(segment) / segment.squaredNorm(), 0.0, 1.0);
            distance = std::min(distance, (o.centre - (p + t * segment)).norm());
        }
        EXPECT_LE(distance, o.half_size.y() + 1e-6) << "sample " << index;
        EXPECT_GE(o.half_size.x(), o.half_size.y()) << "sample " << index;
        ASSERT_GT(o.skin_shade, 0) << "sample " << index;
        // The face's median skin colour in the sample without the occluder.
        std::array<std::vector<int>, 3> channels;
        for (int y = 0; y < a.image.rows; ++y)
            for (int x = 0; x < a.image.cols; ++x)
                if (a.regions.at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(morph::Region::kSkin))
                    for (int c = 0; c < 3; ++c) channels[static_cast<std::size_t>(c)].push_back(a.image.at<cv::Vec3b>(y, x)[c]);
        cv::Mat inside = cv::Mat::zeros(b.image.size(), CV_8UC1);
        const cv::RotatedRect box(cv::Point2f(static_cast<float>(o.centre.x()), static_cast<float>(o.centre.y())),
                                  cv::Size2f(static_cast<float>(2 * o.half_size.x()), static_cast<float>(2 * o.half_size.y())),
                                  static_cast<float>(o.angle));
        cv::ellipse(inside, box, cv::Scalar(255), cv::FILLED);
        cv::erode(inside, inside, cv::Mat(), cv::Point(-1, -1), 2);
        ASSERT_GT(cv::countNonZero(inside), 10) << "sample " << index;
        const cv::Scalar shown = cv::mean(b.image, inside);
        for (std::size_t c = 0; c < 3; ++c) {
            auto& v = channels[c];
            ASSERT_FALSE(v.empty()) << "sample " << index;
            std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
            EXPECT_NEAR(shown[static_cast<int>(c)], std::min(255.0, v[v.size() / 2] * o.skin_shade), 1.0) << "sample " << index << " channel " << c;
        }
        EXPECT_EQ(a.labels.landmarks_even, b.labels.landmarks_even) << "sample " << index;
    }
}

}  // namespace
}  // namespace facesynth::synth
