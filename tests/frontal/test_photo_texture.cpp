// Textures for synth's texture bank taken from renders of the built-in model, whose albedo is known.
#include "frontal/evaluate.h"
#include "frontal/photo_texture.h"
#include "morph/builtin.h"
#include "morph/landmarks.h"
#include "core/error.h"
#include "morph/regions.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

namespace facesynth::frontal {
namespace {

constexpr int kTextureSize = 256;


class PhotoTextureTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        model_ = std::make_unique<morph::MorphableModel>(morph::builtin_model());
        frontaliser_ = std::make_unique<Frontaliser>(*model_);
        face_ = std::make_unique<TexturedFace>(make_textured_face(*model_, *frontaliser_, 11, 2, kTextureSize));
    }
    static void TearDownTestSuite() {
        face_.reset();
        frontaliser_.reset();
        model_.reset();
    }
    static SyntheticView view(double yaw, const render::Lighting& lighting = unlit()) {
        ViewOptions options;
        options.lighting = lighting;
        return render_view(frontaliser_->renderer(), *model_, *face_, yaw, options);
    }
    // The face texels seen squarely in a frontal view (plain isomap alpha >= 128, cos θ >= 0.5) with a
    // face label: where a texture from that view must match the truth.
    static cv::Mat face_mask() {
        const SyntheticView v = view(0);
        FrontaliseOptions options;
        options.isomap.size = kTextureSize;
        const Frontalisation f = frontaliser_->frontalise(v.image, v.landmarks, options);
        const UvRaster& raster = frontaliser_->uv_raster(kTextureSize);
        cv::Mat mask(kTextureSize, kTextureSize, CV_8UC1, cv::Scalar(0));
        for (const UvRaster::TriangleTexels& tri : raster.triangles) {
            const auto region = static_cast<morph::Region>(model_->vertex_labels[static_cast<std::size_t>(tri.vertices[0])]);
            if (region != morph::Region::kSkin && region != morph::Region::kNose && region != morph::Region::kLips) continue;
            for (int k = tri.first; k < tri.first + tri.count; ++k) {
                const int index = raster.texels[static_cast<std::size_t>(k)].index;
                if (f.isomap.ptr<cv::Vec4b>()[index][3] >= 128) mask.ptr<uchar>()[index] = 255;
            }
        }
        return mask;
    }
    // Mean absolute difference in display levels (linear^(1/2.2), as the renderer shows albedo unlit)
    // between a bank texture and the true isomap over `mask`, after scaling each channel of the texture
    // by its median ratio to the truth (shading removal keeps the photograph's mean level, not the
    // albedo's absolute one).
    static double display_error(const cv::Mat& texture_rgb, const cv::Mat& mask) {
        std::vector<std::array<double, 3>> texture, truth;
        for (int r = 0; r < kTextureSize; ++r)
            for (int c = 0; c < kTextureSize; ++c) {
                if (mask.at<uchar>(r, c) == 0) continue;
                const cv::Vec3b t = texture_rgb.at<cv::Vec3b>(r, c);
                const cv::Vec3b d = face_->true_isomap.at<cv::Vec3b>(r, c);  // B G R display values
                texture.push_back({core::srgb_decode(t[0] / 255.0), core::srgb_decode(t[1] / 255.0), core::srgb_decode(t[2] / 255.0)});
                truth.push_back({std::pow(d[2] / 255.0, 2.2), std::pow(d[1] / 255.0, 2.2), std::pow(d[0] / 255.0, 2.2)});
            }
        std::array<double, 3> gain{};
        for (std::size_t c = 0; c < 3; ++c) {
            std::vector<double> ratios;
            for (std::size_t i = 0; i < texture.size(); ++i)
                if (texture[i][c] > 1e-4) ratios.push_back(truth[i][c] / texture[i][c]);
            std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2), ratios.end());
            gain[c] = ratios[ratios.size() / 2];
        }
        double sum = 0;
        for (std::size_t i = 0; i < texture.size(); ++i)
            for (std::size_t c = 0; c < 3; ++c)
                sum += 255.0 * std::abs(std::pow(std::min(1.0, texture[i][c] * gain[c]), 1 / 2.2) - std::pow(truth[i][c], 1 / 2.2));
        return sum / (3.0 * static_cast<double>(texture.size()));
    }
    static PhotoTextureOptions options(bool remove_shading) {
        PhotoTextureOptions o;
        o.size = kTextureSize;
        o.remove_shading = remove_shading;
        return o;
    }

    static std::unique_ptr<morph::MorphableModel> model_;
    static std::unique_ptr<Frontaliser> frontaliser_;
    static std::unique_ptr<TexturedFace> face_;
};
std::unique_ptr<morph::MorphableModel> PhotoTextureTest::model_;
std::unique_ptr<Frontaliser> PhotoTextureTest::frontaliser_;
std::unique_ptr<TexturedFace> PhotoTextureTest::face_;

TEST_F(PhotoTextureTest, TextureOfAnUnlitFrontalRenderMatchesTheKnownAlbedo) {
    const SyntheticView v = view(0);
    const cv::Mat mask = face_mask();
    ASSERT_GT(cv::countNonZero(mask), 3000);
    for (const bool remove_shading : {false, true}) {
        const PhotoTexture t = extract_photo_texture(*frontaliser_, v.image, v.landmarks, options(remove_shading));
        ASSERT_TRUE(t.rejection.empty()) << t.rejection;
        ASSERT_EQ(t.texture.type(), CV_8UC3);
        ASSERT_EQ(t.texture.rows, kTextureSize);
        const double error = display_error(t.texture, mask);
        std::printf("unlit frontal render, shading removal %s: mean error %.2f levels, coverage %.2f, shading range %.2f\n",
                    remove_shading ? "on" : "off", error, t.face_coverage, t.shading_range);
        // Fit error and resampling only (measured 2.9 levels without removal, 3.1 with).
        EXPECT_LT(error, 5.0);
        EXPECT_GT(t.face_coverage, 0.6);
        EXPECT_LT(t.skin_outliers, 0.2);
        EXPECT_NEAR(t.yaw_deg, 0.0, 5.0);
    }
}

TEST_F(PhotoTextureTest, ShadingRemovalTakesASideLightOutOfTheTexture) {
    // A strong light from the subject's left (viewer's right), as the environment's band-1 term.
    render::Lighting lighting = unlit();
    lighting.ambient = {0.15f, 0.15f, 0.15f};
    lighting.sh[0] = {2.4f, 2.4f, 2.4f};
    lighting.sh[3] = {1.8f, 1.8f, 1.8f};
    const SyntheticView v = view(0, lighting);
    const cv::Mat mask = face_mask();
    const PhotoTexture kept = extract_photo_texture(*frontaliser_, v.image, v.landmarks, options(false));
    const PhotoTexture removed = extract_photo_texture(*frontaliser_, v.image, v.landmarks, options(true));
    ASSERT_TRUE(kept.rejection.empty()) << kept.rejection;
    ASSERT_TRUE(removed.rejection.empty()) << removed.rejection;
    const double error_kept = display_error(kept.texture, mask), error_removed = display_error(removed.texture, mask);
    std::printf("side-lit render: mean error %.2f levels with the shading kept, %.2f removed; shading range %.2f\n", error_kept, error_removed,
                removed.shading_range);
    EXPECT_GT(removed.shading_range, 1.5);
    EXPECT_LT(error_removed, 0.6 * error_kept);
    EXPECT_LT(error_removed, 6.0);
}

TEST_F(PhotoTextureTest, TurnedFaceIsCompletedFromItsMirrorSide) {
    const SyntheticView v = view(35);
    const PhotoTexture t = extract_photo_texture(*frontaliser_, v.image, v.landmarks, options(true));
    ASSERT_TRUE(t.rejection.empty()) << t.rejection;
    EXPECT_LT(t.seen_share, t.face_coverage);  // the mirror added what the camera did not see
    EXPECT_GT(t.face_coverage, 0.6);
}

// What surrounds the face in a photograph (here: saturated green) never reaches the model's ears and
// neck: with skin_beyond_face they take the face's own skin colour; without it the neck shows the green
// (the render's ears are its own, so they show skin either way).
TEST_F(PhotoTextureTest, EarsAndNeckTakeTheFacesSkinNotWhatSurroundsIt) {
    const SyntheticView v = view(0);
    cv::Mat background = v.image.clone();
    background.setTo(cv::Scalar(0, 255, 0));  // B G R
    v.image.copyTo(background, v.mask);
    const auto mean_of_region = [&](const PhotoTexture& t, morph::Region wanted) {
        const UvRaster& raster = frontaliser_->uv_raster(kTextureSize);
        cv::Vec3d sum(0, 0, 0);
        int n = 0;
        for (const UvRaster::TriangleTexels& tri : raster.triangles) {
            if (static_cast<morph::Region>(model_->vertex_labels[static_cast<std::size_t>(tri.vertices[0])]) != wanted) continue;
            for (int k = tri.first; k < tri.first + tri.count; ++k, ++n) {
                const cv::Vec3b p = t.texture.ptr<cv::Vec3b>()[raster.texels[static_cast<std::size_t>(k)].index];  // R G B
                sum += cv::Vec3d(p[0], p[1], p[2]);
            }
        }
        return n > 0 ? sum / n : sum;
    };
    PhotoTextureOptions o = options(true);
    o.skin_beyond_face = true;
    const PhotoTexture clean = extract_photo_texture(*frontaliser_, background, v.landmarks, o);
    o.skin_beyond_face = false;
    const PhotoTexture smeared = extract_photo_texture(*frontaliser_, background, v.landmarks, o);
    ASSERT_TRUE(clean.rejection.empty()) << clean.rejection;
    ASSERT_TRUE(smeared.rejection.empty()) << smeared.rejection;
    for (const morph::Region region : {morph::Region::kEars, morph::Region::kNeck}) {
        const cv::Vec3d c = mean_of_region(clean, region), s = mean_of_region(smeared, region);
        std::printf("%s: mean R G B %.0f %.0f %.0f with skin_beyond_face, %.0f %.0f %.0f without; skin %.0f %.0f %.0f\n",
                    std::string(morph::region_name(region)).c_str(), c[0], c[1], c[2], s[0], s[1], s[2], clean.skin_srgb[0],
                    clean.skin_srgb[1], clean.skin_srgb[2]);
        // Within 10 levels: texels on a triangle's edge blend with the neighbouring region's.
        for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c[ch], clean.skin_srgb[static_cast<std::size_t>(ch)], 10.0) << ch;
        if (region == morph::Region::kNeck) {
            // Without it, the green shows (G - R rises, the neck being part green part skin: measured 9 levels;
            // 29 before the lower face wrapped round the teeth, 2026-12-06, which turns the jaw's sides away
            // from the camera, so fewer neck texels are seen against the background).
            EXPECT_GT((s[1] - s[0]) - (c[1] - c[0]), 5.0);
        }
    }
}

// A dark fringe across one side of the forehead is dropped and filled from the other side with
// drop_occluders; a dark beard on the chin stays either way (below the nose it belongs to the face).
TEST_F(PhotoTextureTest, DroppedOccludersLeaveTheForeheadButNotTheBeard) {
    const SyntheticView v = view(0);
    const Eigen::Matrix2Xd& l = v.landmarks;
    const double brow_y = std::min(l(1, 19), l(1, 24)), nose_to_brow = l(1, 30) - brow_y;
    const cv::Rect fringe(cv::Point(static_cast<int>(l(0, 17)), static_cast<int>(brow_y - 0.45 * nose_to_brow)),
                          cv::Point(static_cast<int>(l(0, 21)), static_cast<int>(brow_y - 0.12 * nose_to_brow)));
    const cv::Rect beard(cv::Point(static_cast<int>(l(0, 48)), static_cast<int>(l(1, 57) + 2)),
                         cv::Point(static_cast<int>(l(0, 54)), static_cast<int>(l(1, 8) - 3)));
    PhotoTextureOptions keep = options(true), drop = keep;
    drop.drop_occluders = true;
    const PhotoTexture truth = extract_photo_texture(*frontaliser_, v.image, l, keep);
    ASSERT_TRUE(truth.rejection.empty()) << truth.rejection;
    for (const cv::Rect& patch : {fringe, beard}) {
        cv::Mat painted = v.image.clone();
        painted(patch).setTo(cv::Scalar(30, 40, 60));  // B G R: dark brown
        const PhotoTexture kept = extract_photo_texture(*frontaliser_, painted, l, keep);
        const PhotoTexture dropped = extract_photo_texture(*frontaliser_, painted, l, drop);
        ASSERT_TRUE(kept.rejection.empty() && dropped.rejection.empty()) << kept.rejection << dropped.rejection;
        // Over the texels the paint reached: how far each texture lies from the unpainted one.
        double kept_off = 0, dropped_off = 0;
        int texels = 0;
        for (int i = 0; i < kTextureSize * kTextureSize; ++i) {
            const cv::Vec3b t = truth.texture.ptr<cv::Vec3b>()[i], k = kept.texture.ptr<cv::Vec3b>()[i], d = dropped.texture.ptr<cv::Vec3b>()[i];
            const double k_off = cv::norm(cv::Vec3d(k) - cv::Vec3d(t), cv::NORM_L1) / 3, d_off = cv::norm(cv::Vec3d(d) - cv::Vec3d(t), cv::NORM_L1) / 3;
            if (k_off < 30) continue;
            kept_off += k_off, dropped_off += d_off, ++texels;
        }
        ASSERT_GT(texels, 100);
        kept_off /= texels, dropped_off /= texels;
        std::printf("%s: %d texels painted, %.1f levels off kept, %.1f dropped; dropped share %.3f\n", patch == fringe ? "fringe" : "beard", texels,
                    kept_off, dropped_off, dropped.dropped_share);
        if (patch == fringe) {
            EXPECT_LT(dropped_off, 0.3 * kept_off);
            EXPECT_GT(dropped.dropped_share, kept.dropped_share);
        } else {
            EXPECT_GT(dropped_off, 0.8 * kept_off);
        }
    }
}

TEST_F(PhotoTextureTest, JawMarginDropsAnEdgePaintedAlongTheJawLine) {
    const SyntheticView v = view(0);
    const Eigen::Matrix2Xd& l = v.landmarks;
    std::vector<cv::Point> jaw;
    for (int i = 0; i < morph::kNumJawLandmarks; ++i) jaw.emplace_back(static_cast<int>(std::lround(l(0, i))), static_cast<int>(std::lround(l(1, i))));
    cv::Mat painted = v.image.clone();
    cv::polylines(painted, jaw, false, cv::Scalar(20, 25, 35), 3);  // a dark edge on the annotated jaw line, as a shadow
    PhotoTextureOptions keep = options(true), margin = keep;
    margin.jaw_margin = 0.06;
    // Each against the unpainted face's texture made with the same options: what the paint changed.
    const PhotoTexture truth_kept = extract_photo_texture(*frontaliser_, v.image, l, keep);
    const PhotoTexture truth_margin = extract_photo_texture(*frontaliser_, v.image, l, margin);
    const PhotoTexture kept = extract_photo_texture(*frontaliser_, painted, l, keep);
    const PhotoTexture dropped = extract_photo_texture(*frontaliser_, painted, l, margin);
    ASSERT_TRUE(truth_kept.rejection.empty() && truth_margin.rejection.empty() && kept.rejection.empty() && dropped.rejection.empty())
        << kept.rejection << dropped.rejection;
    double kept_off = 0, dropped_off = 0;
    int texels = 0;
    for (int i = 0; i < kTextureSize * kTextureSize; ++i) {
        const cv::Vec3b tk = truth_kept.texture.ptr<cv::Vec3b>()[i], tm = truth_margin.texture.ptr<cv::Vec3b>()[i];
        const cv::Vec3b k = kept.texture.ptr<cv::Vec3b>()[i], d = dropped.texture.ptr<cv::Vec3b>()[i];
        const double k_off = cv::norm(cv::Vec3d(k) - cv::Vec3d(tk), cv::NORM_L1) / 3, d_off = cv::norm(cv::Vec3d(d) - cv::Vec3d(tm), cv::NORM_L1) / 3;
        if (k_off < 30) continue;
        kept_off += k_off, dropped_off += d_off, ++texels;
    }
    ASSERT_GT(texels, 50);
    kept_off /= texels, dropped_off /= texels;
    std::printf("jaw edge: %d texels painted, %.1f levels off kept, %.1f with the margin\n", texels, kept_off, dropped_off);
    EXPECT_LT(dropped_off, 0.2 * kept_off);
    // The band is dropped after coverage and occlusion are counted: a bank keeps the same photographs.
    EXPECT_DOUBLE_EQ(dropped.face_coverage, kept.face_coverage);
    EXPECT_DOUBLE_EQ(dropped.skin_outliers, kept.skin_outliers);
}

TEST_F(PhotoTextureTest, UnusablePhotographsAreRejectedWithTheReason) {
    PhotoTextureOptions o = options(true);
    o.max_abs_yaw_deg = 30;
    const PhotoTexture turned = extract_photo_texture(*frontaliser_, view(45).image, view(45).landmarks, o);
    EXPECT_EQ(turned.rejection.rfind("pose:", 0), 0u) << turned.rejection;
    EXPECT_TRUE(turned.texture.empty());

    const SyntheticView v = view(0);
    o = options(true);
    o.min_face_coverage = 0.99;
    const PhotoTexture partial = extract_photo_texture(*frontaliser_, v.image, v.landmarks, o);
    EXPECT_EQ(partial.rejection.rfind("coverage:", 0), 0u) << partial.rejection;

    const Eigen::Matrix2Xd collapsed = Eigen::Matrix2Xd::Constant(2, 68, 100.0);
    const PhotoTexture degenerate = extract_photo_texture(*frontaliser_, v.image, collapsed, options(true));
    EXPECT_FALSE(degenerate.rejection.empty());
    EXPECT_THROW((void)extract_photo_texture(*frontaliser_, v.image, Eigen::Matrix2Xd::Zero(2, 5), options(true)), core::Error);
}

TEST(PushPullFill, HolesTakeTheirNeighboursColourAndKnownTexelsStay) {
    cv::Mat colour(32, 32, CV_32FC3, cv::Scalar::all(0));
    cv::Mat weight(32, 32, CV_32FC1, cv::Scalar(0));
    colour(cv::Rect(0, 0, 32, 16)).setTo(cv::Scalar(0.2, 0.4, 0.6));
    weight(cv::Rect(0, 0, 32, 16)).setTo(1);
    push_pull_fill(colour, weight);
    EXPECT_EQ(colour.at<cv::Vec3f>(3, 3), cv::Vec3f(0.2f, 0.4f, 0.6f));
    const cv::Vec3f far = colour.at<cv::Vec3f>(31, 31);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(far[c], 0.2f * static_cast<float>(c + 1), 1e-4);
    cv::Mat empty_weight(8, 8, CV_32FC1, cv::Scalar(0));
    cv::Mat empty_colour(8, 8, CV_32FC3, cv::Scalar::all(0));
    EXPECT_THROW(push_pull_fill(empty_colour, empty_weight), core::Error);
}

// 68 distinct points on a face-sized layout (eye corners 37 and 46 at 80 px).
Eigen::Matrix2Xd feature_layout() {
    Eigen::Matrix2Xd p(2, 68);
    for (int k = 0; k < 68; ++k) p.col(k) = Eigen::Vector2d(60 + 11 * (k % 12), 50 + 17 * (k / 12));
    p.col(36) = Eigen::Vector2d(80, 90);
    p.col(45) = Eigen::Vector2d(160, 90);
    return p;
}

TEST(AlignPhotoToFit, MovesTheAnnotatedFeaturesOntoTheFittedPoints) {
    const Eigen::Matrix2Xd projected = feature_layout();
    // The photograph's features sit 3 px right and 2 px above where the fit projects them.
    const Eigen::Matrix2Xd annotated = projected.colwise() + Eigen::Vector2d(3, -2);
    cv::Mat photo(240, 260, CV_8UC3, cv::Scalar::all(0));
    const Eigen::Vector2d nose = annotated.col(30);
    cv::circle(photo, cv::Point(static_cast<int>(nose.x()), static_cast<int>(nose.y())), 3, cv::Scalar::all(255), cv::FILLED);
    const cv::Mat aligned = align_photo_to_fit(photo, annotated, projected);
    cv::Mat grey;
    cv::cvtColor(aligned, grey, cv::COLOR_BGR2GRAY);
    const cv::Moments g = cv::moments(grey, false);
    ASSERT_GT(g.m00, 0);
    EXPECT_NEAR(g.m10 / g.m00, std::floor(nose.x()) - 3, 0.5);
    EXPECT_NEAR(g.m01 / g.m00, std::floor(nose.y()) + 2, 0.5);
    // Far from the features nothing moves.
    cv::Mat corner(photo.size(), CV_8UC3, cv::Scalar::all(0));
    cv::rectangle(corner, cv::Rect(0, 0, 8, 8), cv::Scalar::all(200), cv::FILLED);
    EXPECT_EQ(cv::norm(align_photo_to_fit(corner, annotated, projected)(cv::Rect(0, 0, 12, 12)), corner(cv::Rect(0, 0, 12, 12)), cv::NORM_INF), 0);
}

// The jaw (iBUG 1-17) moves only with with_jaw: the photograph's chin then lands on the model's.
TEST(AlignPhotoToFit, TheJawOutlineMovesOnlyWhenAsked) {
    Eigen::Matrix2Xd projected(2, 68);
    for (int k = 17; k < 68; ++k) projected.col(k) = Eigen::Vector2d(60 + 11 * (k % 12), 40 + 10 * ((k - 17) / 12));
    projected.col(36) = Eigen::Vector2d(80, 60);
    projected.col(45) = Eigen::Vector2d(160, 60);
    for (int k = 0; k < 17; ++k) projected.col(k) = Eigen::Vector2d(40 + 10 * k, 250);  // 190 px below the features
    Eigen::Matrix2Xd annotated = projected;
    annotated.leftCols(17).colwise() += Eigen::Vector2d(0, -6);  // the annotated chin 6 px above the fitted one
    cv::Mat photo(300, 260, CV_8UC3, cv::Scalar::all(0));
    const Eigen::Vector2d chin = annotated.col(8);
    cv::circle(photo, cv::Point(static_cast<int>(chin.x()), static_cast<int>(chin.y())), 3, cv::Scalar::all(255), cv::FILLED);
    const auto dot_height = [](const cv::Mat& image) {
        cv::Mat grey;
        cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
        const cv::Moments m = cv::moments(grey, false);
        return m.m01 / m.m00;
    };
    EXPECT_NEAR(dot_height(align_photo_to_fit(photo, annotated, projected)), chin.y(), 0.5);
    EXPECT_NEAR(dot_height(align_photo_to_fit(photo, annotated, projected, true)), chin.y() + 6, 0.7);
}

TEST(AlignPhotoToFit, AnExactFitLeavesThePhotographAsItIs) {
    const Eigen::Matrix2Xd points = feature_layout();
    cv::Mat photo(240, 260, CV_8UC3);
    cv::randu(photo, cv::Scalar::all(0), cv::Scalar::all(255));
    EXPECT_EQ(cv::norm(align_photo_to_fit(photo, points, points), photo, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace facesynth::frontal
