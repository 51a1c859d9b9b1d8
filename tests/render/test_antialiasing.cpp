// Anti-aliasing by supersampling (RenderSettings::supersampling): the geometry maps are those of a
// plain render, and the silhouette over a background approaches a 16-sample reference as MSAA 4 does.
#include "morph/error.h"
#include "morph/model_io.h"
#include "render_fixtures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace facesynth {
namespace {

using testkit::make_camera;

const Mesh& builtin_mean() {
    static const Mesh mesh = load_model("builtin").instance({});
    return mesh;
}

render::Frame render_with(const render::Camera& camera, int msaa, int supersampling) {
    render::RenderSettings settings;
    settings.msaa_samples = msaa;
    settings.supersampling = supersampling;
    settings.normals = false;
    return testkit::shared_renderer().render(builtin_mean(), camera, settings);
}

// The premultiplied face composited over a mid-grey background, as synth composites it.
cv::Mat over_grey(const render::Frame& frame) {
    cv::Mat out(frame.rgb.size(), CV_32FC3);
    for (int y = 0; y < out.rows; ++y)
        for (int x = 0; x < out.cols; ++x) {
            const float uncovered = 1.0f - frame.mask.at<std::uint8_t>(y, x) / 255.0f;
            const cv::Vec3b c = frame.rgb.at<cv::Vec3b>(y, x);
            for (int k = 0; k < 3; ++k) out.at<cv::Vec3f>(y, x)[k] = static_cast<float>(c[k]) + 128.0f * uncovered;
        }
    return out;
}

// Sum of squared differences over the pixels the reference covers partly (0 < mask < 255).
struct EdgeError {
    double squared = 0;
    long values = 0;
    [[nodiscard]] double psnr() const { return 10.0 * std::log10(255.0 * 255.0 / (squared / static_cast<double>(values))); }
};

void add_edge_error(const render::Frame& reference, const render::Frame& frame, EdgeError& error) {
    const cv::Mat a = over_grey(reference), b = over_grey(frame);
    for (int y = 0; y < a.rows; ++y)
        for (int x = 0; x < a.cols; ++x) {
            const auto coverage = reference.mask.at<std::uint8_t>(y, x);
            if (coverage == 0 || coverage == 255) continue;
            for (int k = 0; k < 3; ++k) {
                const double d = a.at<cv::Vec3f>(y, x)[k] - b.at<cv::Vec3f>(y, x)[k];
                error.squared += d * d;
                ++error.values;
            }
        }
}

TEST(AntiAliasing, SupersamplingKeepsTheGeometryMapsOfAPlainRender) {
    const render::Camera camera = make_camera(35, -10, 5, 211, 173);
    const render::Frame plain = render_with(camera, 0, 1);
    const render::Frame fine = render_with(camera, 0, 2);
    ASSERT_EQ(fine.rgb.size(), cv::Size(211, 173));
    ASSERT_EQ(fine.mask.size(), cv::Size(211, 173));
    EXPECT_EQ(cv::countNonZero(plain.triangle_ids != fine.triangle_ids), 0);
    EXPECT_EQ(cv::countNonZero(plain.labels != fine.labels), 0);
    EXPECT_EQ(cv::norm(plain.depth, fine.depth, cv::NORM_INF), 0.0);
    // Inside the face (all 3x3 neighbours covered) the coverage is full; on its rim it is partial.
    cv::Mat inside;
    cv::erode(plain.mask, inside, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((inside == 255) & (fine.mask != 255)), 0);
    EXPECT_GT(cv::countNonZero((fine.mask > 0) & (fine.mask < 255)), 200);
    // Far from the face both are background.
    cv::Mat near_face;
    cv::dilate(plain.mask, near_face, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((near_face == 0) & (fine.mask != 0)), 0);
}

TEST(AntiAliasing, SupersampledEdgesApproachASixteenSampleReferenceAsMsaaDoes) {
    EdgeError plain, msaa4, supersampled2;
    for (const double yaw : {-50.0, 0.0, 40.0}) {
        const render::Camera camera = make_camera(yaw, -10, 8, 256, 256);
        const render::Frame reference = render_with(camera, 0, 4);
        add_edge_error(reference, render_with(camera, 0, 1), plain);
        add_edge_error(reference, render_with(camera, 4, 1), msaa4);
        const render::Frame ss2 = render_with(camera, 0, 2);
        add_edge_error(reference, ss2, supersampled2);
        if (yaw == 40.0) testkit::save_for_inspection(ss2.rgb, "supersampled2_yaw40.png");
    }
    std::printf("silhouette PSNR against 4x4 supersampling: no AA %.1f dB, MSAA 4 %.1f dB, supersampling 2 %.1f dB (%ld values)\n",
                plain.psnr(), msaa4.psnr(), supersampled2.psnr(), plain.values);
    EXPECT_GT(msaa4.psnr(), plain.psnr() + 5.0);
    EXPECT_GT(supersampled2.psnr(), plain.psnr() + 5.0);
    EXPECT_GT(supersampled2.psnr(), msaa4.psnr() - 3.0);
}

TEST(AntiAliasing, BadSupersamplingSettingsAreErrors) {
    const render::Camera camera = make_camera(0, 0, 0, 64, 64);
    render::RenderSettings settings;
    settings.msaa_samples = 0;
    settings.supersampling = 5;
    EXPECT_THROW((void)testkit::shared_renderer().render(builtin_mean(), camera, settings), Error);
    settings.supersampling = 0;
    EXPECT_THROW((void)testkit::shared_renderer().render(builtin_mean(), camera, settings), Error);
    settings.supersampling = 2;
    settings.msaa_samples = 4;
    try {
        (void)testkit::shared_renderer().render(builtin_mean(), camera, settings);
        FAIL() << "supersampling with MSAA must be refused";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("supersampling"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace facesynth
