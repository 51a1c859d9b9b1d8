// Anti-aliasing by supersampling and by analytic silhouette edges (render::Antialiasing): the geometry maps are those of a plain render, and the
// silhouette over a background approaches a 16-sample reference as MSAA 4 does.
#include "common/test_data.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "render/edge_antialiasing.h"
#include "render_fixtures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace facesynth {
namespace {

using testkit::make_camera;

const morph::Mesh& builtin_mean() {
    static const morph::Mesh mesh = morph::load_model("builtin").instance({});
    return mesh;
}

using render::Antialiasing;

render::Frame render_with(const render::Camera& camera, Antialiasing antialiasing, const morph::Mesh& mesh = builtin_mean()) {
    render::RenderSettings settings;
    settings.antialiasing = antialiasing;
    settings.normals = false;
    return testkit::shared_renderer().render(mesh, camera, settings);
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

void add_error(const cv::Mat& reference_over_grey, const cv::Mat& selected, const render::Frame& frame, EdgeError& error) {
    const cv::Mat b = over_grey(frame);
    for (int y = 0; y < b.rows; ++y)
        for (int x = 0; x < b.cols; ++x) {
            if (selected.at<std::uint8_t>(y, x) == 0) continue;
            for (int k = 0; k < 3; ++k) {
                const double d = reference_over_grey.at<cv::Vec3f>(y, x)[k] - b.at<cv::Vec3f>(y, x)[k];
                error.squared += d * d;
                ++error.values;
            }
        }
}

// The pixels where anti-aliasing matters, interior edges included: those whose 16-sample reference
// differs from the plain render by more than 8 levels in some channel (over grey).
cv::Mat changed_by_antialiasing(const render::Frame& reference, const render::Frame& plain) {
    cv::Mat difference;
    cv::absdiff(over_grey(reference), over_grey(plain), difference);
    std::vector<cv::Mat> channels;
    cv::split(difference, channels);
    const cv::Mat largest = cv::max(cv::max(channels[0], channels[1]), channels[2]);
    return largest > 8.0f;
}

TEST(AntiAliasing, SupersamplingKeepsTheGeometryMapsOfAPlainRender) {
    const render::Camera camera = make_camera(35, -10, 5, 211, 173);
    const render::Frame plain = render_with(camera, Antialiasing::none());
    const render::Frame fine = render_with(camera, Antialiasing::supersampling(2));
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

// PSNR against the 16-sample reference (4x4 supersampling) of each anti-aliasing method, over two
// pixel selections: partly covered by the reference (the outer outline), and changed by
// anti-aliasing (outline, the face over itself, and shading or texture detail inside).
struct Comparison {
    struct Methods {
        EdgeError plain, msaa4, supersampled2, edge;
    };
    Methods outline, changed;

    void print(const char* what) const {
        std::printf("%s, PSNR against 4x4 supersampling over the partly covered pixels (%ld values): no AA %.1f dB, "
                    "MSAA 4 %.1f dB, supersampling 2 %.1f dB, edge AA %.1f dB\n",
                    what, outline.plain.values, outline.plain.psnr(), outline.msaa4.psnr(), outline.supersampled2.psnr(),
                    outline.edge.psnr());
        std::printf("%s, over the pixels anti-aliasing changes by > 8 levels (%ld values): no AA %.1f dB, MSAA 4 %.1f dB, "
                    "supersampling 2 %.1f dB, edge AA %.1f dB\n",
                    what, changed.plain.values, changed.plain.psnr(), changed.msaa4.psnr(), changed.supersampled2.psnr(),
                    changed.edge.psnr());
    }
};

Comparison compare_antialiasing(const morph::Mesh& mesh, const std::string& inspection_name) {
    Comparison result;
    for (const double yaw : {-50.0, 0.0, 40.0}) {
        const render::Camera camera = make_camera(yaw, -10, 8, 256, 256);
        const render::Frame reference = render_with(camera, Antialiasing::supersampling(4), mesh);
        const render::Frame plain = render_with(camera, Antialiasing::none(), mesh);
        const render::Frame msaa4 = render_with(camera, Antialiasing::msaa(4), mesh);
        const render::Frame supersampled2 = render_with(camera, Antialiasing::supersampling(2), mesh);
        const render::Frame edge = render_with(camera, Antialiasing::edges(), mesh);
        const cv::Mat reference_over_grey = over_grey(reference);
        const cv::Mat selections[2] = {(reference.mask > 0) & (reference.mask < 255), changed_by_antialiasing(reference, plain)};
        Comparison::Methods* methods[2] = {&result.outline, &result.changed};
        for (int s = 0; s < 2; ++s) {
            add_error(reference_over_grey, selections[s], plain, methods[s]->plain);
            add_error(reference_over_grey, selections[s], msaa4, methods[s]->msaa4);
            add_error(reference_over_grey, selections[s], supersampled2, methods[s]->supersampled2);
            add_error(reference_over_grey, selections[s], edge, methods[s]->edge);
        }
        if (yaw == 40.0) {
            testkit::save_for_inspection(supersampled2.rgb, inspection_name + "_supersampled2_yaw40.png");
            testkit::save_for_inspection(edge.rgb, inspection_name + "_edge_aa_yaw40.png");
        }
    }
    return result;
}

// Measured (built-in mean face, yaw -50/0/40, 256²): outline no AA 22.5 dB, MSAA 4 31.7, supersampling 2
// 31.6, edge AA 35.4; pixels changed by anti-aliasing 21.7 / 28.4 / 31.3 / 31.3 (docs/render.md).
TEST(AntiAliasing, SupersampledAndEdgeAntialiasedOutlinesApproachASixteenSampleReferenceAsMsaaDoes) {
    const Comparison c = compare_antialiasing(builtin_mean(), "builtin");
    c.print("built-in");
    EXPECT_GT(c.outline.msaa4.psnr(), c.outline.plain.psnr() + 5.0);
    EXPECT_GT(c.outline.supersampled2.psnr(), c.outline.plain.psnr() + 5.0);
    EXPECT_GT(c.outline.supersampled2.psnr(), c.outline.msaa4.psnr() - 3.0);
    EXPECT_GT(c.outline.edge.psnr(), 34.0);
    EXPECT_GT(c.changed.edge.psnr(), 30.0);
}

// Measured (Surrey mean face): outline no AA 28.7 dB, MSAA 4 38.1, supersampling 2 36.1, edge AA 39.9;
// pixels changed by anti-aliasing 25.5 / 36.9 / 34.6 / 37.9.
TEST(AntiAliasing, EdgeAntialiasedSurreyOutlinesApproachASixteenSampleReference) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const morph::Mesh mesh = morph::load_model(sfm.string()).instance({});
    const Comparison c = compare_antialiasing(mesh, "surrey");
    c.print("Surrey");
    EXPECT_GT(c.outline.edge.psnr(), 38.5);
    EXPECT_GT(c.changed.edge.psnr(), 36.5);
}

TEST(AntiAliasing, EdgeAntialiasingKeepsTheGeometryMapsOfAPlainRender) {
    const render::Camera camera = make_camera(35, -10, 5, 211, 173);
    const render::Frame plain = render_with(camera, Antialiasing::none());
    const render::Frame edge = render_with(camera, Antialiasing::edges());
    EXPECT_EQ(cv::countNonZero(plain.triangle_ids != edge.triangle_ids), 0);
    EXPECT_EQ(cv::countNonZero(plain.labels != edge.labels), 0);
    EXPECT_EQ(cv::norm(plain.depth, edge.depth, cv::NORM_INF), 0.0);
    // Full coverage stays full wherever the plain render's 3x3 neighbourhood is covered (the face over
    // itself blends colour only), the outline gets partial coverage, and far from the face nothing changes.
    cv::Mat inside, near_face;
    cv::erode(plain.mask, inside, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((inside == 255) & (edge.mask != 255)), 0);
    EXPECT_GT(cv::countNonZero((edge.mask > 0) & (edge.mask < 255)), 200);
    cv::dilate(plain.mask, near_face, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((near_face == 0) & (edge.mask != 0)), 0);
    // Interior silhouettes (ears, nose, chin at this view) change colours where the mask stays full.
    cv::Mat changed;
    cv::absdiff(plain.rgb, edge.rgb, changed);
    changed = changed.reshape(1, changed.rows * changed.cols);
    cv::reduce(changed, changed, 1, cv::REDUCE_MAX);
    changed = changed.reshape(1, plain.rgb.rows);
    EXPECT_GT(cv::countNonZero((changed > 8) & (inside == 255)), 20);
    // Without the geometry maps (depth read internally) the image is the same.
    render::RenderSettings colour_only;
    colour_only.antialiasing = Antialiasing::edges();
    colour_only.geometry = false;
    const render::Frame bare = testkit::shared_renderer().render(builtin_mean(), camera, colour_only);
    EXPECT_EQ(cv::norm(bare.rgb, edge.rgb, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(bare.mask, edge.mask, cv::NORM_INF), 0.0);
    EXPECT_TRUE(bare.depth.empty());
}

// A quad in the plane z = `z` (model space, facing the viewer), centred on (cx, cy), half-size `half`.
void add_quad(morph::Mesh& mesh, float cx, float cy, float z, float half, const Eigen::Vector3f& colour) {
    const int first = mesh.num_vertices();
    mesh.vertices.conservativeResize(3, first + 4);
    mesh.colours.conservativeResize(3, first + 4);
    const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};  // counter-clockwise seen from +z
    for (int i = 0; i < 4; ++i) {
        mesh.vertices.col(first + i) = Eigen::Vector3f(cx + half * corners[i][0], cy + half * corners[i][1], z);
        mesh.colours.col(first + i) = colour;
    }
    mesh.triangles.push_back({first, first + 1, first + 2});
    mesh.triangles.push_back({first, first + 2, first + 3});
}

render::RenderSettings edge_settings(bool edge_antialiasing) {
    render::RenderSettings settings;
    settings.antialiasing = edge_antialiasing ? Antialiasing::edges() : Antialiasing::none();
    settings.normals = false;
    return settings;
}

// Exact coverage of pixel (x, y) by the convex polygon `corners` (pixels, either winding), from
// 32x32 samples.
double polygon_coverage(const Eigen::Matrix2Xd& corners, int x, int y) {
    int inside = 0;
    constexpr int kSamples = 32;
    for (int i = 0; i < kSamples; ++i)
        for (int j = 0; j < kSamples; ++j) {
            const Eigen::Vector2d p(x - 0.5 + (i + 0.5) / kSamples, y - 0.5 + (j + 0.5) / kSamples);
            int positive = 0, negative = 0;
            for (Eigen::Index k = 0; k < corners.cols(); ++k) {
                const Eigen::Vector2d a = corners.col(k), b = corners.col((k + 1) % corners.cols());
                const double side = (b - a).x() * (p - a).y() - (b - a).y() * (p - a).x();
                (side > 0 ? positive : negative) += 1;
            }
            inside += positive == 0 || negative == 0;
        }
    return static_cast<double>(inside) / (kSamples * kSamples);
}

// Persson's coverage (0.5 - distance along the minor axis, at the pixel column's centre) is exact
// while a straight edge crosses the pixel from one side to the opposite one; where it leaves
// through the top or bottom it misses a small triangle (at most 1/8 of a pixel at 45 degrees).
TEST(EdgeAntialiasing, StraightOutlineGetsTheShareOfEachPixelItCovers) {
    morph::Mesh quad;
    add_quad(quad, 0, 0, 0, 40, Eigen::Vector3f(0.5f, 0.5f, 0.5f));
    for (const double roll : {7.0, 31.0, 58.0, 80.0}) {
        render::Camera camera = make_camera(0, 0, roll, 96, 80);
        camera.projection = render::Projection::kOrthographic;
        camera.intrinsics.fx = camera.intrinsics.fy = 0.9;
        camera.pose.translation.x() = 3.3;  // off the pixel grid
        const render::Frame frame = testkit::shared_renderer().render(quad, camera, edge_settings(true));
        const Eigen::Matrix2Xd corners = render::project_points(camera, quad.vertices);
        double error_sum = 0, worst = 0;
        int count = 0;
        for (int y = 0; y < frame.mask.rows; ++y)
            for (int x = 0; x < frame.mask.cols; ++x) {
                const double exact = polygon_coverage(corners, x, y);
                bool near_corner = false;
                for (Eigen::Index k = 0; k < corners.cols(); ++k)
                    near_corner = near_corner || (corners.col(k) - Eigen::Vector2d(x, y)).norm() < 2.0;
                // On the image's border the pixel across the edge is outside: such pixels keep their value.
                const bool on_border = x == 0 || y == 0 || x == frame.mask.cols - 1 || y == frame.mask.rows - 1;
                if (exact == 0 || exact == 1 || near_corner || on_border) continue;
                const double error = std::abs(frame.mask.at<std::uint8_t>(y, x) / 255.0 - exact);
                error_sum += error;
                worst = std::max(worst, error);
                ++count;
            }
        std::printf("roll %.0f: %d outline pixels, coverage error mean %.4f, max %.4f\n", roll, count, error_sum / count, worst);
        EXPECT_GT(count, 100);
        EXPECT_LT(error_sum / count, 0.03) << "roll " << roll;  // measured 0.002-0.021
        EXPECT_LT(worst, 0.1) << "roll " << roll;  // measured 0.014-0.078
    }
}

TEST(EdgeAntialiasing, HiddenSilhouetteEdgesBlendNothing) {
    // A small far quad entirely behind a large near one: its border edges are silhouettes, but hidden.
    morph::Mesh mesh;
    add_quad(mesh, 0, 0, 0, 60, Eigen::Vector3f(0.8f, 0.2f, 0.1f));
    add_quad(mesh, 5, -3, -40, 30, Eigen::Vector3f(0.1f, 0.2f, 0.8f));
    const render::Camera camera = make_camera(10, -5, 3, 128, 128);
    render::Frame plain = testkit::shared_renderer().render(mesh, camera, edge_settings(false));
    const render::Frame edge = testkit::shared_renderer().render(mesh, camera, edge_settings(true));
    cv::Mat inside;
    cv::erode(plain.mask, inside, cv::Mat::ones(3, 3, CV_8U));
    cv::Mat changed;
    cv::absdiff(plain.rgb, edge.rgb, changed);
    cv::cvtColor(changed, changed, cv::COLOR_RGB2GRAY);
    EXPECT_EQ(cv::countNonZero((inside == 255) & (changed != 0)), 0);
    EXPECT_GT(cv::countNonZero(changed), 50);  // the near quad's outline is anti-aliased
    // The same pass run by hand on the plain frame: it saw the far quad's edges and found them hidden.
    render::EdgeAntialiasing antialiasing;
    const render::EdgeAntialiasingStats stats = antialiasing.apply(mesh, camera, true, plain.depth, plain.rgb, plain.mask);
    EXPECT_EQ(stats.silhouette_edges, 8);
    EXPECT_GT(stats.hidden_steps, 40);
    EXPECT_EQ(cv::norm(plain.rgb, edge.rgb, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(plain.mask, edge.mask, cv::NORM_INF), 0.0);
}

TEST(EdgeAntialiasing, SurfaceOverSurfaceBlendsColoursAndKeepsFullCoverage) {
    // A small red quad in front of a large blue one: along the red outline both colours mix, and
    // the coverage stays full; the blue quad's own outline over the background gets partial coverage.
    morph::Mesh mesh;
    add_quad(mesh, 0, 0, 0, 20, Eigen::Vector3f(0.9f, 0.05f, 0.05f));
    add_quad(mesh, 0, 0, -30, 60, Eigen::Vector3f(0.05f, 0.05f, 0.9f));
    const render::Camera camera = make_camera(0, 0, 17, 128, 128);
    const render::Frame plain = testkit::shared_renderer().render(mesh, camera, edge_settings(false));
    const render::Frame edge = testkit::shared_renderer().render(mesh, camera, edge_settings(true));
    cv::Mat inside;
    cv::erode(plain.mask, inside, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((inside == 255) & (edge.mask != 255)), 0);
    int mixed = 0;
    for (int y = 0; y < edge.rgb.rows; ++y)
        for (int x = 0; x < edge.rgb.cols; ++x) {
            const cv::Vec3b c = edge.rgb.at<cv::Vec3b>(y, x), p = plain.rgb.at<cv::Vec3b>(y, x);
            if (inside.at<std::uint8_t>(y, x) == 255 && c != p && c[0] > 40 && c[2] > 40) ++mixed;
        }
    EXPECT_GT(mixed, 40);
    EXPECT_GT(cv::countNonZero((edge.mask > 0) & (edge.mask < 255)), 100);
    testkit::save_for_inspection(edge.rgb, "edge_aa_quads.png");
}

TEST(EdgeAntialiasing, WithBackFacesDrawnTheOutlineOfABackFacingSurfaceIsAntialiased) {
    morph::Mesh quad;
    add_quad(quad, 0, 0, 0, 40, Eigen::Vector3f(0.5f, 0.5f, 0.5f));
    const render::Camera camera = make_camera(180, 0, 23, 96, 96);  // seen from behind
    render::RenderSettings settings = edge_settings(true);
    EXPECT_EQ(cv::countNonZero(testkit::shared_renderer().render(quad, camera, settings).mask), 0);  // culled
    settings.cull_back_faces = false;
    const render::Frame edge = testkit::shared_renderer().render(quad, camera, settings);
    settings.antialiasing = Antialiasing::none();
    const render::Frame plain = testkit::shared_renderer().render(quad, camera, settings);
    EXPECT_GT(cv::countNonZero((edge.mask > 0) & (edge.mask < 255)), 60);  // a 24-pixel square: 84
    cv::Mat inside;
    cv::erode(plain.mask, inside, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero((inside == 255) & (edge.mask != 255)), 0);
}

TEST(EdgeAntialiasing, TopologyPairsEdgesWithTheirTriangles) {
    morph::Mesh quad;
    add_quad(quad, 0, 0, 0, 1, Eigen::Vector3f::Zero());
    render::EdgeTopology topology;
    topology.build(quad);
    EXPECT_TRUE(topology.matches(quad));
    ASSERT_EQ(topology.edges.size(), 5u);
    int borders = 0;
    for (const auto& edge : topology.edges) {
        borders += edge.triangle[1] < 0;
        EXPECT_NE(edge.opposite[0], edge.a);
        EXPECT_NE(edge.opposite[0], edge.b);
    }
    EXPECT_EQ(borders, 4);
    // A third triangle on the diagonal makes it no surface edge: it is left out.
    quad.vertices.conservativeResize(3, 5);
    quad.vertices.col(4) = Eigen::Vector3f(0, 0, 1);
    quad.triangles.push_back({0, 2, 4});
    EXPECT_FALSE(topology.matches(quad));
    topology.build(quad);
    EXPECT_EQ(topology.edges.size(), 6u);
    quad.triangles.push_back({0, 2, 9});
    EXPECT_THROW(topology.build(quad), core::Error);
}

// Each method's sample count is bounded (MSAA 2-16, supersampling 2-4, none and edges 1), and a
// count out of range is refused with the method named.
TEST(AntiAliasing, SampleCountsOutOfTheMethodsRangeAreErrors) {
    const render::Camera camera = make_camera(0, 0, 0, 64, 64);
    render::RenderSettings settings;
    for (const Antialiasing bad : {Antialiasing::supersampling(5), Antialiasing::supersampling(1), Antialiasing::msaa(1),
                                   Antialiasing::msaa(17), Antialiasing{Antialiasing::Method::kEdges, 4}, Antialiasing{Antialiasing::Method::kNone, 2}}) {
        settings.antialiasing = bad;
        const std::string name(render::antialiasing_name(bad.method));
        const std::string message = testkit::error_message_of([&] { (void)testkit::shared_renderer().render(builtin_mean(), camera, settings); });
        EXPECT_NE(message.find(name + " anti-aliasing with " + std::to_string(bad.samples) + " samples"), std::string::npos) << message;
    }
    settings.antialiasing = Antialiasing::supersampling(4);
    EXPECT_NO_THROW((void)testkit::shared_renderer().render(builtin_mean(), camera, settings));
}

// Names and sample counts as synth's config and the CLI give them; 0 is the method's default.
TEST(AntiAliasing, FromNameResolvesDefaultsAndRefusesUnknownNames) {
    EXPECT_EQ(render::antialiasing_from("msaa", 0), Antialiasing::msaa(4));
    EXPECT_EQ(render::antialiasing_from("msaa", 8), Antialiasing::msaa(8));
    EXPECT_EQ(render::antialiasing_from("supersampling", 0), Antialiasing::supersampling(2));
    EXPECT_EQ(render::antialiasing_from("edges", 0), Antialiasing::edges());
    EXPECT_EQ(render::antialiasing_from("none", 1), Antialiasing::none());
    for (const Antialiasing a : {Antialiasing::none(), Antialiasing::msaa(4), Antialiasing::supersampling(3), Antialiasing::edges()})
        EXPECT_EQ(render::antialiasing_from(render::antialiasing_name(a.method), a.samples), a);
    EXPECT_NE(testkit::error_message_of([] { (void)render::antialiasing_from("fxaa", 0); }).find("'fxaa'"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([] { (void)render::antialiasing_from("msaa", 32); }).find("2 to 16"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([] { (void)render::antialiasing_from("edges", 2); }).find("no sample count"), std::string::npos);
}

}  // namespace
}  // namespace facesynth
