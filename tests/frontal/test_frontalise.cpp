// The frontalisation pipeline on synthetic renders of the built-in model, whose true texture is known.
#include "frontal/evaluate.h"
#include "frontal/frontalise.h"
#include "frontal/image_metrics.h"
#include "common/test_data.h"
#include "morph/builtin.h"
#include "core/error.h"
#include "morph/pose.h"
#include "render/zbuffer.h"
#include "train/face_box.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>

#include <cstdlib>
#include <memory>
#include <span>
#include <vector>

namespace facesynth::frontal {
namespace {

class FrontaliseTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        model_ = std::make_unique<morph::MorphableModel>(morph::builtin_model());
        frontaliser_ = std::make_unique<Frontaliser>(*model_);
        region_ = std::make_unique<morph::JawContourRegion>(morph::jaw_contour_region(*model_));
        face_ = std::make_unique<TexturedFace>(make_textured_face(*model_, *frontaliser_, 7, 3, kIsomapSize));
    }
    static void TearDownTestSuite() {
        face_.reset();
        region_.reset();
        frontaliser_.reset();
        model_.reset();
    }
    static SyntheticView view(double yaw) { return render_view(frontaliser_->renderer(), *model_, *face_, yaw, {}, region_.get()); }
    static FrontaliseOptions options(bool mirror = false) {
        FrontaliseOptions o;
        o.isomap.size = kIsomapSize;
        o.mirror_fill = mirror;
        return o;
    }
    // Writes an image for a person to look at when FACESYNTH_TEST_IMAGES names a folder.
    static void keep(const std::string& name, const cv::Mat& image) {
        if (const char* dir = std::getenv("FACESYNTH_TEST_IMAGES")) cv::imwrite(std::string(dir) + "/" + name, image);
    }
    // uv of a surface point on the subject's left cheek (viewer's right at frontal pose): halfway between
    // the left eye's outer corner (iBUG 46) and the left mouth corner (iBUG 55).
    static cv::Point far_cheek_texel() {
        Eigen::Vector2f uv = Eigen::Vector2f::Zero();
        for (int landmark : {45, 54}) {
            const morph::SurfacePoint& p = model_->landmarks[static_cast<std::size_t>(landmark)];
            for (std::size_t k = 0; k < 3; ++k) uv += 0.5f * p.weights[k] * model_->uv.col(p.vertices[k]);
        }
        return {static_cast<int>(uv.x() * kIsomapSize), static_cast<int>(uv.y() * kIsomapSize)};
    }
    static double visible_fraction(const cv::Mat& isomap, cv::Point centre, int half) {
        int visible = 0, total = 0;
        for (int dy = -half; dy <= half; ++dy)
            for (int dx = -half; dx <= half; ++dx, ++total) visible += isomap.at<cv::Vec4b>(centre.y + dy, centre.x + dx)[3] > 0;
        return static_cast<double>(visible) / total;
    }

    static constexpr int kIsomapSize = 256;
    static std::unique_ptr<morph::MorphableModel> model_;
    static std::unique_ptr<Frontaliser> frontaliser_;
    static std::unique_ptr<morph::JawContourRegion> region_;
    static std::unique_ptr<TexturedFace> face_;
};
std::unique_ptr<morph::MorphableModel> FrontaliseTest::model_;
std::unique_ptr<Frontaliser> FrontaliseTest::frontaliser_;
std::unique_ptr<morph::JawContourRegion> FrontaliseTest::region_;
std::unique_ptr<TexturedFace> FrontaliseTest::face_;

TEST_F(FrontaliseTest, IsomapOfAFrontalRenderMatchesTheKnownTexture) {
    const SyntheticView v = view(0);
    const Frontalisation result = frontaliser_->frontalise(v.image, v.landmarks, options());
    keep("frontal_input.png", v.image);
    keep("frontal_isomap.png", result.isomap);
    keep("frontal_true_isomap.png", face_->true_isomap);
    const IsomapComparison error = compare_isomap(result.isomap, face_->true_isomap, layout_mask(frontaliser_->uv_raster(kIsomapSize)));
    // The face seen from the front covers a good part of the whole-head layout; its colours are the
    // albedo's within a few levels (fit error and resampling only: the lighting is unlit).
    std::printf("isomap at yaw 0: L1 %.2f, PSNR %.2f dB, coverage %.3f\n", error.l1, error.psnr_db, error.coverage);
    EXPECT_GT(error.coverage, 0.25);
    EXPECT_LT(error.l1, 6.0);
    EXPECT_GT(error.psnr_db, 28.0);
}

TEST_F(FrontaliseTest, FrontalRenderOfAFrontalInputReproducesTheTruth) {
    const SyntheticView v = view(0);
    const Frontalisation result = frontaliser_->frontalise(v.image, v.landmarks, options());
    const TrueFrontal truth = render_true_frontal(*frontaliser_, *face_, 256, unlit());
    keep("frontal_output.png", result.frontal.image);
    keep("frontal_truth.png", truth.render.image);
    const ImageComparison c = compare_images(result.frontal.image, truth.render.image, truth.face_mask);
    std::printf("frontal from yaw 0: SSIM %.3f, PSNR %.2f dB, L1 %.2f\n", c.ssim, c.psnr_db, c.l1);
    EXPECT_GT(c.pixels, 256 * 256 / 5);
    // Measured: SSIM 0.86, PSNR 18.7 dB; the loss is at the outline, where the fitted face is narrower
    // than the true one (docs/frontalise.md).
    EXPECT_GT(c.ssim, 0.83);
    EXPECT_GT(c.psnr_db, 18.0);
}

TEST_F(FrontaliseTest, FarCheekIsOccludedAtYaw60AndMirrorFillRestoresIt) {
    const cv::Point cheek = far_cheek_texel();
    const Frontalisation frontal = frontaliser_->frontalise(view(0).image, view(0).landmarks, options());
    keep("yaw0_isomap.png", frontal.isomap);
    EXPECT_GT(visible_fraction(frontal.isomap, cheek, 3), 0.9) << "the cheek is visible from the front " << cheek;

    const SyntheticView v = view(60);
    const Frontalisation turned = frontaliser_->frontalise(v.image, v.landmarks, options());
    keep("yaw60_input.png", v.image);
    keep("yaw60_isomap.png", turned.isomap);
    EXPECT_NEAR(turned.fit.pose.angles.yaw, 60, 6);
    EXPECT_EQ(visible_fraction(turned.isomap, cheek, 3), 0.0) << "the far cheek is hidden at yaw 60";
    // The near cheek (mirror texel) stays visible.
    const cv::Point near_cheek(kIsomapSize - 1 - cheek.x, cheek.y);
    EXPECT_GT(visible_fraction(turned.isomap, near_cheek, 3), 0.9);

    const Frontalisation filled = frontaliser_->frontalise(v.image, v.landmarks, options(true));
    keep("yaw60_isomap_mirror.png", filled.isomap);
    keep("yaw60_frontal_mirror.png", filled.frontal.image);
    EXPECT_GT(filled.mirror_filled_texels, 1000);
    EXPECT_EQ(visible_fraction(filled.isomap, cheek, 3), 1.0);
    // The built-in albedo is nearly symmetric: the filled cheek has the true colour within a few levels.
    const cv::Vec4b got = filled.isomap.at<cv::Vec4b>(cheek);
    const cv::Vec3b want = face_->true_isomap.at<cv::Vec3b>(cheek);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(got[ch], want[ch], 20) << "channel " << ch;
}

// The isomap as first written (docs/history/frontalise-runs.md, before the speed work): a full render (colour, ids,
// normals, depth) as the z-buffer pass, and every texel interpolated straight from the vertices in
// row-major order. extract_isomap must give the same texels.
cv::Mat reference_isomap(const cv::Mat& bgr, const morph::MorphableModel& model, const Eigen::Matrix3Xf& vertices, const ImageCamera& camera,
                         const UvRaster& raster, render::Renderer& renderer, const IsomapOptions& options) {
    const Eigen::Matrix3Xf normals = morph::vertex_normals(vertices, model.triangles);
    const Eigen::Matrix3f rotation = camera.pose.rotation.cast<float>();
    const Eigen::Matrix3Xf camera_xyz = morph::model_to_camera_flip().cast<float>() * rotation * vertices;
    const Eigen::Matrix2Xf image_xy = (camera.affine.matrix.topLeftCorner<2, 3>().cast<float>() * vertices).colwise() +
                                      camera.affine.matrix.block<2, 1>(0, 3).cast<float>();
    const Eigen::Matrix3Xf view_normals = rotation * normals;
    const float scale = static_cast<float>(camera.pose.scale);
    const Eigen::Vector2f t = camera.pose.translation.cast<float>();
    const Eigen::Vector2f low = (scale * camera_xyz.topRows<2>()).rowwise().minCoeff() + t;
    const Eigen::Vector2f high = (scale * camera_xyz.topRows<2>()).rowwise().maxCoeff() + t;
    const float shrink = std::min(1.0f, static_cast<float>(options.max_depth_side) / std::max(high.x() - low.x(), high.y() - low.y()));
    const Eigen::Vector2f origin = low.array() - 1.0f;
    render::Camera depth_camera;
    depth_camera.projection = render::Projection::kOrthographic;
    depth_camera.pose.rotation = camera.pose.rotation;
    depth_camera.pose.translation = Eigen::Vector3d(0, 0, 1000);
    const double focal = static_cast<double>(scale) * shrink;
    depth_camera.intrinsics = {focal, focal, static_cast<double>((t.x() - origin.x()) * shrink), static_cast<double>((t.y() - origin.y()) * shrink),
                               static_cast<int>(std::ceil((high.x() - origin.x()) * shrink)) + 2,
                               static_cast<int>(std::ceil((high.y() - origin.y()) * shrink)) + 2};
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    settings.geometry = true;
    morph::Mesh mesh;
    mesh.vertices = vertices;
    mesh.triangles = model.triangles;
    const cv::Mat depth = renderer.render(mesh, depth_camera, settings).depth.clone();
    cv::Mat inside = depth > 0;
    cv::erode(inside, inside, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    const float cx = static_cast<float>(depth_camera.intrinsics.cx), cy = static_cast<float>(depth_camera.intrinsics.cy);
    cv::Mat isomap(raster.size, raster.size, CV_8UC4, cv::Scalar::all(0));
    struct CornersAndWeights {
        int index = 0;
        std::array<int, 3> vertices{};
        std::array<float, 3> weights{};
    };
    std::vector<CornersAndWeights> texels;
    for (const UvRaster::TriangleTexels& triangle : raster.triangles)
        for (int i = triangle.first; i < triangle.first + triangle.count; ++i)
            texels.push_back({raster.texels[static_cast<std::size_t>(i)].index, triangle.vertices, raster.texels[static_cast<std::size_t>(i)].weights});
    std::sort(texels.begin(), texels.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
    for (const CornersAndWeights& texel : texels) {
        auto interpolate = [&](const auto& values) {
            return (texel.weights[0] * values.col(texel.vertices[0]) + texel.weights[1] * values.col(texel.vertices[1]) +
                    texel.weights[2] * values.col(texel.vertices[2])).eval();
        };
        const Eigen::Vector3f normal = interpolate(view_normals);
        if (!(normal.norm() > 0)) continue;
        const float cosine = normal.z() / normal.norm();
        if (cosine < static_cast<float>(options.min_cosine)) continue;
        const Eigen::Vector3f position = interpolate(camera_xyz);
        const int px = static_cast<int>(position.x() * static_cast<float>(focal) + cx + 1.5f) - 1;
        const int py = static_cast<int>(position.y() * static_cast<float>(focal) + cy + 1.5f) - 1;
        if (px < 0 || py < 0 || px >= depth.cols || py >= depth.rows || !inside.at<std::uint8_t>(py, px)) continue;
        const float slope = std::min(10.0f, std::sqrt(1 - cosine * cosine) / cosine);
        if (position.z() + 1000.0f > depth.at<float>(py, px) + static_cast<float>(options.depth_tolerance_mm) + slope / static_cast<float>(focal)) continue;
        const Eigen::Vector2f at = interpolate(image_xy);
        if (!(at.x() >= 0 && at.y() >= 0 && at.x() <= static_cast<float>(bgr.cols - 1) && at.y() <= static_cast<float>(bgr.rows - 1))) continue;
        cv::Mat pixel;
        cv::getRectSubPix(bgr, cv::Size(1, 1), cv::Point2f(at.x(), at.y()), pixel, CV_32F);
        const cv::Vec3f colour = pixel.at<cv::Vec3f>(0, 0);
        isomap.ptr<cv::Vec4b>()[texel.index] = cv::Vec4b(cv::saturate_cast<std::uint8_t>(colour[0]), cv::saturate_cast<std::uint8_t>(colour[1]),
                                                         cv::saturate_cast<std::uint8_t>(colour[2]),
                                                         std::max<std::uint8_t>(1, cv::saturate_cast<std::uint8_t>(255 * cosine)));
    }
    return isomap;
}

TEST_F(FrontaliseTest, IsomapMatchesTheStraightforwardExtraction) {
    const UvRaster& raster = frontaliser_->uv_raster(kIsomapSize);
    for (double yaw : {0.0, -35.0, 60.0}) {
        const SyntheticView v = view(yaw);
        const fit::FitResult fit = frontaliser_->fitter().fit(v.landmarks, options().fit);
        const Eigen::Matrix3Xf vertices = fit::fitted_shape(*model_, fit);
        const ImageCamera camera{fit.camera, fit.pose};
        const cv::Mat got = frontaliser_->extract_isomap(v.image, vertices, camera, options().isomap);
        const cv::Mat want = reference_isomap(v.image, *model_, vertices, camera, raster, frontaliser_->renderer(), options().isomap);
        int visible = 0, disagree = 0, colour_off = 0;
        for (const UvRaster::Texel& texel : raster.texels) {
            const cv::Vec4b a = got.ptr<cv::Vec4b>()[texel.index], b = want.ptr<cv::Vec4b>()[texel.index];
            visible += b[3] > 0;
            if ((a[3] > 0) != (b[3] > 0)) {
                ++disagree;
                continue;
            }
            for (int ch = 0; ch < 4; ++ch) colour_off += std::abs(a[ch] - b[ch]) > 1;
        }
        std::printf("yaw %.0f: %d visible texels, %d differ in visibility, %d channels by more than 1\n", yaw, visible, disagree, colour_off);
        // Only float rounding differs (interpolation order): a texel exactly at a threshold may flip.
        EXPECT_GT(visible, 20000) << "yaw " << yaw;
        EXPECT_LE(disagree, visible / 1000) << "yaw " << yaw;
        EXPECT_EQ(colour_off, 0) << "yaw " << yaw;
    }
}

// The multi-view detector (train/face_box.h) on renders at ±60° yaw showing the whole head: the
// frontal Haar cascade misses the face, the profile cascade (on the image, or on its mirror for the
// other side) finds it, with the view that says where the nose points.
TEST_F(FrontaliseTest, MultiViewDetectorFindsFacesAtYaw60ThatTheFrontalCascadeMisses) {
    // Several identities, so that the assertion is about the detectors, not one face's colouring.
    const train::FaceDetector frontal_only(train::DetectorKind::kFrontal);
    const train::FaceDetector multi_view(train::DetectorKind::kMultiView);
    constexpr int kFaces = 10;  // with 6, one face's brows or colouring swung the count across the bar
    int frontal_total = 0, multi_view_total = 0;
    for (const double yaw : {-60.0, 60.0}) {
        int frontal_found = 0, multi_view_found = 0;
        for (int index = 0; index < kFaces; ++index) {
            const TexturedFace face = make_textured_face(*model_, *frontaliser_, 7, static_cast<std::uint64_t>(index), kIsomapSize);
            ViewOptions whole_head;
            whole_head.framing = 2.5;
            const SyntheticView v = render_view(frontaliser_->renderer(), *model_, face, yaw, whole_head, region_.get());
            keep("detector_yaw" + std::to_string(static_cast<int>(yaw)) + "_" + std::to_string(index) + ".png", v.image);
            const cv::Mat gray = train::to_gray8(v.image);
            frontal_found += train::match_detection(frontal_only.detect(gray), v.landmarks).has_value() ? 1 : 0;
            const auto found = train::match_detection(multi_view.detect(gray), v.landmarks);
            // Counted only with the right profile view: negative yaw turns the nose toward the image's
            // left (docs/conventions.md).
            if (!found || found->view != (yaw < 0 ? train::FaceView::kNoseLeft : train::FaceView::kNoseRight)) continue;
            ++multi_view_found;
            EXPECT_LT((found->centre - v.landmarks.rowwise().mean()).norm(), 0.3 * found->width) << "yaw " << yaw << ", face " << index;
        }
        std::printf("yaw %+.0f: frontal cascade found %d, multi-view %d of %d faces with the right view\n", yaw, frontal_found, multi_view_found, kFaces);
        frontal_total += frontal_found;
        multi_view_total += multi_view_found;
    }
    // Over both sides (the random textures are not symmetric: at +60° the frontal cascade caught 1 of
    // 10, at -60° none; the profile cascades 3 and 5; with the chin 4 mm lower, before the built-in
    // model's chin moved to gnathion, 4, 0, 5 and 7): the frontal cascade misses most, the multi-view
    // detector finds at least 40 %, and clearly more.
    EXPECT_LE(frontal_total, 2 * kFaces / 4);
    EXPECT_GE(multi_view_total, 2 * kFaces * 8 / 20);
    EXPECT_GE(multi_view_total, frontal_total + 6);
}

// dlib's HOG detector (train/dlib_face_detector.h) on renders of several identities: a frontal face
// comes from a frontal filter, a face turned 45° from the turned-face filter whose view says where
// the nose points (negative yaw: the image's left).
TEST_F(FrontaliseTest, DlibDetectorFindsFrontalAnd45DegreeFacesWithTheirViews) {
    const train::FaceDetector dlib_detector(train::DetectorKind::kDlib);
    constexpr int kFaces = 4;
    std::vector<TexturedFace> faces;
    for (int index = 0; index < kFaces; ++index)
        faces.push_back(make_textured_face(*model_, *frontaliser_, 11, static_cast<std::uint64_t>(index), kIsomapSize));
    for (const double yaw : {0.0, -45.0, 45.0}) {
        const train::FaceView expected =
            yaw == 0 ? train::FaceView::kFrontal : (yaw < 0 ? train::FaceView::kNoseLeft : train::FaceView::kNoseRight);
        int found_with_view = 0;
        for (int index = 0; index < kFaces; ++index) {
            const TexturedFace& face = faces[static_cast<std::size_t>(index)];
            ViewOptions whole_head;
            whole_head.framing = 2.5;
            const SyntheticView v = render_view(frontaliser_->renderer(), *model_, face, yaw, whole_head, region_.get());
            keep("dlib_yaw" + std::to_string(static_cast<int>(yaw)) + "_" + std::to_string(index) + ".png", v.image);
            const auto found = train::match_detection(dlib_detector.detect(train::to_gray8(v.image)), v.landmarks);
            if (!found || found->view != expected) continue;
            ++found_with_view;
            EXPECT_LT((found->centre - v.landmarks.rowwise().mean()).norm(), 0.3 * found->width) << "yaw " << yaw << ", face " << index;
        }
        std::printf("yaw %+.0f: dlib found %d of %d faces with view %s\n", yaw, found_with_view, kFaces, train::view_name(expected));
        EXPECT_GE(found_with_view, kFaces - 1) << "yaw " << yaw;
    }
}

TEST_F(FrontaliseTest, FramingIsTheSameForEveryFace) {
    const render::Camera a = frontaliser_->frontal_camera(256);
    const render::Camera b = frontaliser_->frontal_camera(256);
    EXPECT_EQ(a.intrinsics.fx, b.intrinsics.fx);
    EXPECT_EQ(a.pose.translation, b.pose.translation);
    EXPECT_TRUE(a.pose.rotation.isIdentity());
}

TEST_F(FrontaliseTest, MirrorFillWithoutASymmetryMapSaysSo) {
    morph::MorphableModel asymmetric = *model_;
    asymmetric.symmetry.clear();
    Frontaliser frontaliser(asymmetric);
    cv::Mat isomap(64, 64, CV_8UC4, cv::Scalar::all(0));
    try {
        (void)frontaliser.mirror_fill(isomap);
        FAIL() << "expected an error";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("symmetry"), std::string::npos) << e.what();
    }
}

TEST_F(FrontaliseTest, PartialSymmetryMapIsCompletedLikeSurreys) {
    // Keep each pair one way only, and drop both directions for every third pair: the involution and the
    // nearest mirrored vertex must give back the built-in model's exact map.
    morph::MorphableModel partial = *model_;
    int dropped = 0;
    for (int v = 0; v < partial.num_vertices(); ++v) {
        const int m = model_->symmetry[static_cast<std::size_t>(v)];
        if (m > v) partial.symmetry[static_cast<std::size_t>(m)] = -1;
        if (m > v && v % 3 == 0) partial.symmetry[static_cast<std::size_t>(v)] = -1, ++dropped;
    }
    ASSERT_GT(dropped, 500);
    const std::vector<int> completed = completed_symmetry(partial);
    int same = 0;
    for (std::size_t v = 0; v < completed.size(); ++v) same += completed[v] == model_->symmetry[v];
    EXPECT_GT(same, 0.99 * static_cast<double>(completed.size()));
}

// A view with context is the same photograph on a larger sensor: its centre crop is the standard
// view, pixel for pixel up to anti-aliasing rounding, and the landmarks move by the crop offset.
TEST_F(FrontaliseTest, ViewWithContextHasTheStandardViewAsItsCentre) {
    ViewOptions standard;
    standard.size = 192;
    const ViewOptions wide = with_context(standard, 2.5);
    EXPECT_EQ(wide.size, 320);
    EXPECT_NEAR(wide.framing, 2.5, 1e-9);
    const SyntheticView a = render_view(frontaliser_->renderer(), *model_, *face_, 35, standard, region_.get());
    const SyntheticView b = render_view(frontaliser_->renderer(), *model_, *face_, 35, wide, region_.get());
    const int offset = (wide.size - standard.size) / 2;
    const cv::Mat centre = b.image(cv::Rect(offset, offset, standard.size, standard.size));
    cv::Mat difference;
    cv::absdiff(centre, a.image, difference);
    double largest = 0;
    cv::minMaxLoc(difference.reshape(1), nullptr, &largest);
    EXPECT_LE(largest, 2) << "the centre of the wide view is the standard view";
    EXPECT_LT((b.landmarks.array() - offset - a.landmarks.array()).abs().maxCoeff(), 1e-6);
    EXPECT_THROW((void)with_context(standard, 1.2), core::Error);
}

// The isomap's visibility pass rasterises on the CPU; the renderer's depth-only pass is the reference.
// Coverage may differ only at pixel centres within rounding of the outline, depth only by rounding.
TEST_F(FrontaliseTest, CpuZBufferAgreesWithTheRenderersDepthPass) {
    for (double yaw : {0.0, -35.0, 60.0, 80.0}) {
        const morph::EulerAngles angles{yaw, 12, -7};
        render::Camera camera;
        camera.projection = render::Projection::kOrthographic;
        camera.pose.rotation = morph::rotation_from_euler(angles);
        camera.pose.translation = Eigen::Vector3d(0, 0, 1000);
        camera.intrinsics = {1.3, 1.3, 120.25, 131.5, 240, 260};
        render::RenderSettings settings;
        settings.depth_only = true;
        const cv::Mat want = frontaliser_->renderer().render(face_->mesh, camera, settings).depth.clone();
        const Eigen::Matrix3Xf camera_xyz = (morph::model_to_camera_flip() * camera.pose.rotation).cast<float>() * face_->mesh.vertices;
        const Eigen::Matrix2Xf pixels = (1.3f * camera_xyz.topRows<2>()).colwise() + Eigen::Vector2f(120.25f, 131.5f);
        const Eigen::RowVectorXf z = camera_xyz.row(2).array() + 1000.0f;
        const cv::Mat got = render::orthographic_zbuffer(pixels, std::span(z.data(), static_cast<std::size_t>(z.size())), model_->triangles, 240, 260);
        const int covered = cv::countNonZero(want > 0);
        const int coverage_differs = cv::countNonZero((want > 0) != (got > 0));
        cv::Mat difference;
        cv::absdiff(want, got, difference);
        double largest = 0;
        const cv::Mat both = (want > 0) & (got > 0);
        cv::minMaxLoc(difference, nullptr, &largest, nullptr, nullptr, both);
        const int depth_differs = cv::countNonZero((difference > 0.1) & both);
        std::printf("yaw %.0f: %d pixels covered, %d differ in coverage, depth within %.4f mm, %d by more than 0.1 mm\n", yaw, covered,
                    coverage_differs, largest, depth_differs);
        EXPECT_GT(covered, 10000) << "yaw " << yaw;
        EXPECT_LE(coverage_differs, covered / 1000) << "yaw " << yaw;
        // A pixel centre exactly on an edge between a near and a far triangle may go to either (the
        // rasterisers' tie rules differ): measured 1 such pixel of 49052 at yaw -35, none elsewhere.
        EXPECT_LE(depth_differs, covered / 10000) << "yaw " << yaw;
    }
    EXPECT_THROW((void)render::orthographic_zbuffer(Eigen::Matrix2Xf::Zero(2, 3), std::vector<float>(2, 0.0f), model_->triangles, 8, 8), core::Error);
}

TEST(ImageMetrics, IdenticalImagesAreAPerfectMatchAndNoiseLowersEveryScore) {
    cv::Mat a(64, 64, CV_8UC3);
    cv::randu(a, 0, 255);
    cv::Mat mask(64, 64, CV_8UC1, cv::Scalar(255));
    const ImageComparison same = compare_images(a, a, mask);
    EXPECT_DOUBLE_EQ(same.l1, 0);
    EXPECT_DOUBLE_EQ(same.psnr_db, 100);
    EXPECT_NEAR(same.ssim, 1.0, 1e-6);
    cv::Mat noise(64, 64, CV_8UC3), b;
    cv::randu(noise, 0, 40);
    cv::add(a, noise, b);
    const ImageComparison noisy = compare_images(a, b, mask);
    EXPECT_GT(noisy.l1, 1);
    EXPECT_LT(noisy.psnr_db, 40);
    EXPECT_LT(noisy.ssim, 0.99);
    EXPECT_THROW((void)compare_images(a, b, cv::Mat(64, 64, CV_8UC1, cv::Scalar(0))), core::Error);
}

}  // namespace
}  // namespace facesynth::frontal
