// synth's head.body: MakeHuman's neck, shoulders, clothing and hair placed on the face, leaving the
// face's landmarks and labels as they are.
#include "common/test_data.h"
#include "common/toy_model.h"
#include "core/atomic_file.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "core/srgb.h"
#include "morph/regions.h"
#include "render/lighting.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/head_parts.h"
#include "synth/sample.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <set>
#include <string>

namespace facesynth::synth {
namespace {

int pixels_labelled(const cv::Mat& labels, morph::Region region) {
    return cv::countNonZero(labels == static_cast<std::uint8_t>(region));
}

bool is_face_region(morph::Region r) {
    return r == morph::Region::kSkin || r == morph::Region::kBrows || r == morph::Region::kEyes || r == morph::Region::kLips || r == morph::Region::kNose ||
           r == morph::Region::kMouthInterior;
}

// The neck's and the face's pixels at least `margin` pixels inside their regions (away from the
// outlines, where anti-aliasing and the regions' borders mix surfaces).
struct Interiors {
    cv::Mat neck, face;
};
Interiors neck_and_face_interiors(const cv::Mat& regions, int margin) {
    Interiors in{regions == static_cast<std::uint8_t>(morph::Region::kNeck), cv::Mat::zeros(regions.size(), CV_8UC1)};
    for (int y = 0; y < regions.rows; ++y)
        for (int x = 0; x < regions.cols; ++x)
            in.face.at<std::uint8_t>(y, x) = is_face_region(static_cast<morph::Region>(regions.at<std::uint8_t>(y, x))) ? 255 : 0;
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin + 1, 2 * margin + 1));
    cv::erode(in.neck, in.neck, kernel);
    cv::erode(in.face, in.face, kernel);
    return in;
}

TEST(HeadParts, AssetHoldsTheBodyOutfitsAndHairStylesWithAnchors) {
    const HeadParts parts = read_head_parts(default_head_parts_file());
    EXPECT_EQ(parts.anchors.cols(), kNumHeadAnchors);
    EXPECT_EQ(parts.skin.size(), 1u);
    EXPECT_EQ(parts.clothing.size(), 4u);
    EXPECT_EQ(parts.hair.size(), 10u);
    EXPECT_EQ(parts.head.size(), 2u);  // head and ears, for face-only models
    // The eyes 6 cm apart at the same height, the ears behind and below them, the nose tip in front.
    const auto a = [&](HeadAnchor anchor) { return Eigen::Vector3f(parts.anchors.col(static_cast<int>(anchor))); };
    EXPECT_NEAR((a(HeadAnchor::kLeftEye) - a(HeadAnchor::kRightEye)).norm(), 62, 4);
    EXPECT_LT(a(HeadAnchor::kLeftEar).z(), a(HeadAnchor::kLeftEye).z() - 50);
    EXPECT_GT(a(HeadAnchor::kNoseTip).z(), a(HeadAnchor::kNasion).z());
    EXPECT_LT(a(HeadAnchor::kNeckJoint).y(), a(HeadAnchor::kNoseTip).y() - 80);
    for (const HeadPart& part : parts.parts) {
        EXPECT_GT(part.triangles.size(), 100u) << part.name;
        EXPECT_EQ(part.uv.cols(), part.vertices.cols()) << part.name;
        EXPECT_TRUE(part.vertices.allFinite()) << part.name;
        EXPECT_GE(part.head_weight.minCoeff(), 0.0f) << part.name;
        EXPECT_LE(part.head_weight.maxCoeff(), 1.0f) << part.name;
    }
}

TEST(HeadParts, DamagedOrMissingFilesAreErrorsNamingThem) {
    const auto dir = testkit::fresh_temp_dir("head_parts_damaged");
    const std::string good = core::read_file(default_head_parts_file());
    const auto write = [&](const std::string& name, const std::string& bytes) {
        std::ofstream(dir / name, std::ios::binary) << bytes;
        return dir / name;
    };
    const std::string truncated = testkit::error_message_of([&] { (void)read_head_parts(write("truncated.bin", good.substr(0, good.size() / 2))); });
    EXPECT_NE(truncated.find("truncated.bin"), std::string::npos) << truncated;
    const std::string wrong = testkit::error_message_of([&] { (void)read_head_parts(write("wrong.bin", "NOTPARTS" + good.substr(8))); });
    EXPECT_NE(wrong.find("not a head parts file"), std::string::npos) << wrong;
    const std::string missing = testkit::error_message_of([&] { (void)read_head_parts(dir / "missing.bin"); });
    EXPECT_NE(missing.find("missing.bin"), std::string::npos) << missing;
    const std::string trailing = testkit::error_message_of([&] { (void)read_head_parts(write("trailing.bin", good + "x")); });
    EXPECT_NE(trailing.find("trailing"), std::string::npos) << trailing;
}

// The anchors of the parts land on the face's own (eyes, nose, nasion within a few mm; the model's
// ears are flaps of another shape, so within a centimetre), for random faces of the built-in model.
TEST(HeadParts, PlacementPutsTheAnchorsOnTheFacesOwn) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const HeadParts parts = read_head_parts(default_head_parts_file());
    const HeadPlacement placement(model, parts);
    core::Rng rng(3, 0, 0);
    for (int face = 0; face < 5; ++face) {
        std::vector<float> alpha(static_cast<std::size_t>(model.num_shape_components()));
        for (float& a : alpha) a = static_cast<float>(rng.normal(0, 1));
        const Eigen::Matrix3Xf shape = model.shape_instance(alpha, {});
        const Eigen::Matrix4f m = placement.transform(shape);
        const Eigen::Matrix3Xf placed = (m.topLeftCorner<3, 3>() * parts.anchors).colwise() + Eigen::Vector3f(m.topRightCorner<3, 1>());
        const Eigen::Matrix3Xf l = model.landmark_positions(shape);
        EXPECT_LT((placed.col(static_cast<int>(HeadAnchor::kRightEye)) - l.middleCols(36, 6).rowwise().mean()).norm(), 8) << face;
        EXPECT_LT((placed.col(static_cast<int>(HeadAnchor::kNoseTip)) - l.col(30)).norm(), 10) << face;
        const float scale = m.topLeftCorner<3, 3>().col(0).norm();
        EXPECT_GT(scale, 0.85f) << face;
        EXPECT_LT(scale, 1.25f) << face;
    }
}

TEST(HeadParts, LeaveTheFacesLandmarksAndLabelsAndAddNeckClothingAndHair) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig plain;
    plain.camera.width = plain.camera.height = 128;
    plain.output.labels = true;
    SynthConfig dressed = plain;
    apply_override(dressed, "head.body=true");
    apply_override(dressed, "head.hair_probability=1");
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator a(plain, model, none, none, options), b(dressed, model, none, none, options);
    int hidden_by_parts = 0, revealed_jaw_points = 0, face_pixels = 0, face_pixels_relabelled_skin = 0, clothing = 0, hair = 0;
    for (std::int64_t index = 0; index < 6; ++index) {
        const Sample without = a.generate(index), with = b.generate(index);
        EXPECT_EQ(without.labels.landmarks_contour, with.labels.landmarks_contour) << "sample " << index;
        EXPECT_EQ(without.labels.landmarks_fixed, with.labels.landmarks_fixed) << "sample " << index;
        // The parts may hide landmarks (hair, collars), never reveal one inside the face. A jaw point
        // on the outline may become visible: its pixel showed background there, now the neck behind it.
        for (std::size_t i = 0; i < 68; ++i) {
            const bool revealed = with.labels.visible_fixed[i] && !without.labels.visible_fixed[i];
            if (i < 17) revealed_jaw_points += revealed;
            else EXPECT_FALSE(revealed) << "sample " << index << " point " << i;
            hidden_by_parts += without.labels.visible_fixed[i] && !with.labels.visible_fixed[i];
        }
        EXPECT_GT(pixels_labelled(with.regions, morph::Region::kNeck) + pixels_labelled(with.regions, morph::Region::kClothing), 200) << "sample " << index;
        clothing += pixels_labelled(with.regions, morph::Region::kClothing) > 100;
        hair += pixels_labelled(with.regions, morph::Region::kHair) > pixels_labelled(without.regions, morph::Region::kHair);
        // A face pixel keeps its label or is covered by hair or clothing; the body's skin stays behind it.
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x) {
                const auto before = static_cast<morph::Region>(without.regions.at<std::uint8_t>(y, x));
                if (!is_face_region(before)) continue;
                ++face_pixels;
                face_pixels_relabelled_skin += with.regions.at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(morph::Region::kNeck);
            }
        const Sample again = b.generate(index);
        EXPECT_EQ(cv::norm(again.image, with.image, cv::NORM_INF), 0) << "sample " << index << " is not reproducible";
        EXPECT_FALSE(with.hair.empty());
        EXPECT_FALSE(with.clothing.empty());
    }
    EXPECT_GE(clothing, 5);
    EXPECT_GE(hair, 5);
    EXPECT_LT(face_pixels_relabelled_skin, face_pixels / 50) << "the body's skin shows through the face";
    EXPECT_LT(hidden_by_parts, 6 * 68 / 4) << "the parts hide too many landmarks";
    EXPECT_LE(revealed_jaw_points, 6);
}

// lighting.face_light = "even" (textures that keep their photograph's light): the face is exactly what
// the environment's uniform light alone makes it, the neck is shaded by the drawn lights.
TEST(HeadParts, AnEvenFaceLightLeavesTheFaceUnlitAndLightsTheNeck) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig lit;
    lit.camera.width = lit.camera.height = 128;
    lit.output.labels = true;
    for (const char* key : {"head.body=true", "head.hair_probability=0", "lighting.face_light=even", "lighting.directional_min=1",
                            "lighting.shadow_probability=1", "render.antialiasing=none"})
        apply_override(lit, key);
    lit.degrade.blur_probability = lit.degrade.jpeg_probability = lit.degrade.downscale_probability = 0;
    validate(lit);
    // The same draws with the face's light alone everywhere.
    SynthConfig even = lit;
    for (const char* key : {"lighting.face_light=sampled", "lighting.directional_min=0", "lighting.directional_max=0", "lighting.sh_strength=0",
                            "lighting.specular_max=0"})
        apply_override(even, key);
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator a(lit, model, none, none, options), b(even, model, none, none, options);
    double neck_change = 0;
    int neck_pixels = 0, face_pixels = 0;
    for (std::int64_t index = 0; index < 4; ++index) {
        const Sample with = a.generate(index), without = b.generate(index);
        ASSERT_TRUE(with.spec.lighting.head_parts.has_value());
        EXPECT_FALSE(without.spec.lighting.head_parts.has_value());
        EXPECT_TRUE(with.spec.lighting.lighting.lights.empty());
        EXPECT_FALSE(with.spec.lighting.head_parts->lights.empty());
        // Scaled so that a surface facing the camera gets the face's light.
        const auto mean = [](const std::array<float, 3>& rgb) { return (rgb[0] + rgb[1] + rgb[2]) / 3; };
        EXPECT_NEAR(mean(render::diffuse_shading(*with.spec.lighting.head_parts, {0, 0, 1})),
                    mean(render::diffuse_shading(with.spec.lighting.lighting, {0, 0, 1})), 1e-4);
        ASSERT_EQ(cv::norm(without.regions, with.regions, cv::NORM_INF), 0) << "sample " << index;
        const auto [neck, face] = neck_and_face_interiors(with.regions, 2);
        for (int y = 0; y < face.rows; ++y)
            for (int x = 0; x < face.cols; ++x) {
                const double change = cv::norm(cv::Vec3d(with.image.at<cv::Vec3b>(y, x)) - cv::Vec3d(without.image.at<cv::Vec3b>(y, x)), cv::NORM_L1);
                if (face.at<std::uint8_t>(y, x)) {
                    ASSERT_EQ(change, 0.0) << "sample " << index << ": the face changed at " << x << "," << y;
                    ++face_pixels;
                }
                if (neck.at<std::uint8_t>(y, x)) neck_change += change / 3, ++neck_pixels;
            }
    }
    ASSERT_GT(face_pixels, 2000);
    ASSERT_GT(neck_pixels, 100);
    EXPECT_GT(neck_change / neck_pixels, 3.0) << "the drawn lights did not shade the neck";
    SynthConfig wrong;
    apply_override(wrong, "lighting.face_light=flat");
    EXPECT_NE(testkit::error_message_of([&] { validate(wrong); }).find("lighting.face_light"), std::string::npos);
}

// A face-only model without labels or ears (the toy model) wears MakeHuman's head and ears too, and
// its own face stays skin.
TEST(HeadParts, FaceOnlyModelsWearTheHeadAndEars) {
    const morph::MorphableModel model = testkit::make_toy_model();
    ASSERT_TRUE(model.vertex_labels.empty());
    SynthConfig config;
    config.camera.width = config.camera.height = 128;
    config.output.labels = true;
    apply_override(config, "head.body=true");
    apply_override(config, "pose.yaw.distribution=uniform");
    apply_override(config, "pose.yaw.min=50");
    apply_override(config, "pose.yaw.max=60");
    const ImageLibrary none;
    SampleGenerator generator(config, model, none, none, {render::Backend::kEgl, false});
    int ears = 0, skin = 0;
    for (std::int64_t index = 0; index < 3; ++index) {
        const Sample s = generator.generate(index);
        ears += pixels_labelled(s.regions, morph::Region::kEars);
        skin += pixels_labelled(s.regions, morph::Region::kSkin);
        EXPECT_GT(pixels_labelled(s.regions, morph::Region::kNeck) + pixels_labelled(s.regions, morph::Region::kClothing), 100) << index;
    }
    EXPECT_GT(ears, 30);
    EXPECT_GT(skin, 1000);
}

TEST(HeadParts, ConfigErrorsNameTheKeyOrFile) {
    SynthConfig both;
    apply_override(both, "head.body=true");
    apply_override(both, "head.neck=true");
    const std::string message = testkit::error_message_of([&] { validate(both); });
    EXPECT_NE(message.find("head.body"), std::string::npos) << message;
    for (const char* value : {"1.5", "-0.1", "nan"}) {
        SynthConfig occlusion;
        const std::string occlusion_message = testkit::error_message_of([&] {
            apply_override(occlusion, std::string("head.ambient_occlusion=") + value);
            validate(occlusion);
        });
        EXPECT_NE(occlusion_message.find("head.ambient_occlusion"), std::string::npos) << value << ": " << occlusion_message;
    }

    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig missing;
    apply_override(missing, "head.body=true");
    apply_override(missing, "head.parts_file=/nonexistent/parts.bin");
    const ImageLibrary none;
    const std::string file_message = testkit::error_message_of([&] { SampleGenerator g(missing, model, none, none, {render::Backend::kEgl, false}); });
    EXPECT_NE(file_message.find("/nonexistent/parts.bin"), std::string::npos) << file_message;
}

// head.hair_styles: the samples wear only the named hair meshes; an unknown name is an error naming the
// key and the styles there are.
TEST(HeadParts, HairStylesRestrictTheMeshesDrawn) {
    const HeadParts parts = read_head_parts(default_head_parts_file());
    const std::vector<int> chosen = hair_parts_named(parts, "long01, bob01");
    ASSERT_EQ(chosen.size(), 2u);
    EXPECT_EQ(parts.parts[static_cast<std::size_t>(chosen[0])].name, "bob01");  // in the asset's order
    EXPECT_EQ(parts.parts[static_cast<std::size_t>(chosen[1])].name, "long01");
    const std::string message = testkit::error_message_of([&] { (void)hair_parts_named(parts, "bob01,mohawk"); });
    EXPECT_NE(message.find("head.hair_styles: no hair style 'mohawk'"), std::string::npos) << message;
    EXPECT_NE(message.find("short04"), std::string::npos) << message;
    EXPECT_NE(testkit::error_message_of([&] { (void)hair_parts_named(parts, " , "); }).find("head.hair_styles"), std::string::npos);

    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig config;
    config.camera.width = config.camera.height = 64;
    apply_override(config, "head.body=true");
    apply_override(config, "head.hair_probability=1");
    apply_override(config, "head.hair_styles=long01,bob02");
    const ImageLibrary none;
    SampleGenerator generator(config, model, none, none, {render::Backend::kEgl, false});
    std::set<std::string> worn;
    for (int index = 0; index < 12; ++index) worn.insert(generator.generate(index).hair);
    EXPECT_EQ(worn, (std::set<std::string>{"bob02", "long01"}));
}

TEST(HeadParts, AmbientOcclusionShadesTheNeckUnderTheChinAndLeavesOpenSkinAlone) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const HeadParts parts = read_head_parts(default_head_parts_file());
    const HeadPlacement placement(model, parts);
    const std::vector<Eigen::VectorXf> visibility = skin_ambient_visibility(parts, placement);
    ASSERT_EQ(visibility.size(), parts.parts.size());
    // In the asset's frame (mm, y up, z to the front; the neck joint at y 589, the shoulders near 520):
    // the front of the neck just under the jaw against the chest's front and the shoulders' tops.
    const Eigen::Vector3f neck_joint = parts.anchors.col(static_cast<int>(HeadAnchor::kNeckJoint));
    std::vector<float> under_chin, chest;
    for (std::size_t p = 0; p < parts.parts.size(); ++p) {
        const HeadPart& part = parts.parts[p];
        if (part.kind != HeadPartKind::kSkin) {
            EXPECT_EQ(visibility[p].size(), 0) << part.name;
            continue;
        }
        ASSERT_EQ(visibility[p].size(), part.vertices.cols()) << part.name;
        EXPECT_GE(visibility[p].minCoeff(), 0.0f);
        EXPECT_LE(visibility[p].maxCoeff(), 1.0f);
        for (Eigen::Index v = 0; v < part.vertices.cols(); ++v) {
            const Eigen::Vector3f q = part.vertices.col(v) - neck_joint;
            if (std::abs(q.x()) < 20 && q.y() > 5 && q.y() < 40 && q.z() > 20) under_chin.push_back(visibility[p][v]);
            if (std::abs(q.x()) < 60 && q.y() < -90 && q.y() > -160 && q.z() > 40) chest.push_back(visibility[p][v]);
        }
    }
    ASSERT_FALSE(under_chin.empty());
    ASSERT_FALSE(chest.empty());
    const auto mean = [](const std::vector<float>& x) { return std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size()); };
    std::printf("ambient visibility: neck under the chin %.2f (%zu vertices), chest %.2f (%zu)\n", mean(under_chin), under_chin.size(), mean(chest), chest.size());
    EXPECT_LT(mean(under_chin), 0.75);
    EXPECT_GT(mean(chest), 0.85);
    EXPECT_GT(mean(chest) - mean(under_chin), 0.2);
}

TEST(HeadParts, AmbientOcclusionDarkensTheNeckOnlyWithVertexColoursAndInTheAtlas) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig plain;
    plain.camera.width = plain.camera.height = 128;
    plain.output.labels = true;
    apply_override(plain, "head.body=true");
    apply_override(plain, "head.hair_probability=0");
    // Edge anti-aliasing blends the next surface behind an outline into it, the neck's too, and blur,
    // downscaling and JPEG blocks spread the neck's grey into the face: neither here.
    apply_override(plain, "render.antialiasing=none");
    plain.degrade.blur_probability = plain.degrade.jpeg_probability = plain.degrade.downscale_probability = 0;
    SynthConfig occluded = plain;
    apply_override(occluded, "head.ambient_occlusion=1");
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator a(plain, model, none, none, options), b(occluded, model, none, none, options);
    double neck_before = 0, neck_after = 0, face_change = 0;
    int neck_pixels = 0, face_pixels = 0;
    for (std::int64_t index = 0; index < 4; ++index) {
        const Sample without = a.generate(index), with = b.generate(index);
        EXPECT_EQ(without.labels.landmarks_contour, with.labels.landmarks_contour) << "sample " << index;
        ASSERT_EQ(cv::norm(without.regions, with.regions, cv::NORM_INF), 0) << "sample " << index << ": occlusion moved a region";
        cv::Mat grey_without, grey_with;
        cv::cvtColor(without.image, grey_without, cv::COLOR_RGB2GRAY);
        cv::cvtColor(with.image, grey_with, cv::COLOR_RGB2GRAY);
        const auto [neck, face] = neck_and_face_interiors(with.regions, 3);
        for (int y = 0; y < face.rows; ++y)
            for (int x = 0; x < face.cols; ++x) {
                if (neck.at<std::uint8_t>(y, x)) neck_before += grey_without.at<std::uint8_t>(y, x), neck_after += grey_with.at<std::uint8_t>(y, x), ++neck_pixels;
                if (face.at<std::uint8_t>(y, x)) face_change += std::abs(grey_with.at<std::uint8_t>(y, x) - grey_without.at<std::uint8_t>(y, x)), ++face_pixels;
            }
    }
    ASSERT_GT(neck_pixels, 100);
    ASSERT_GT(face_pixels, 2000);
    std::printf("neck grey %.1f -> %.1f (%d pixels); face pixels change by %.3f on average\n", neck_before / neck_pixels, neck_after / neck_pixels,
                neck_pixels, face_change / face_pixels);
    EXPECT_LT(neck_after, 0.95 * neck_before);
    EXPECT_EQ(face_change, 0.0) << "the face itself changed";

    // With a texture the shade rides in the skin's v into a patch that darkens upward: sampling the atlas
    // at a shaded vertex's uv gives the skin colour times its shade (mottling ±4 %, 8-bit encoding).
    const HeadParts parts = read_head_parts(default_head_parts_file());
    const HeadPlacement placement(model, parts);
    const std::vector<Eigen::VectorXf> visibility = skin_ambient_visibility(parts, placement);
    HeadPartsSpec spec;
    spec.shirt = false;
    const Eigen::Vector3d skin(0.4, 0.3, 0.25);
    DressedParts open, shaded;
    const Eigen::Matrix4f at = placement.transform(model.shape_instance({}, {}));
    dress_head(parts, spec, at, Eigen::Matrix3d::Identity(), skin, skin, false, open);
    dress_head(parts, spec, at, Eigen::Matrix3d::Identity(), skin, skin, false, shaded, {visibility, 1.0});
    DressedParts unshaded;
    dress_head(parts, spec, at, Eigen::Matrix3d::Identity(), skin, skin, false, unshaded, {visibility, 0.0});
    EXPECT_EQ(unshaded.uv, open.uv) << "strength 0 must leave the parts as they were";
    EXPECT_EQ(unshaded.colours, open.colours);
    const cv::Mat face(400, 400, CV_8UC3, cv::Scalar(128, 128, 128));
    cv::Mat atlas;
    make_parts_atlas(face, spec, skin, skin, atlas, true);
    const std::size_t skin_part = static_cast<std::size_t>(parts.skin.front());
    int checked = 0;
    for (Eigen::Index v = 0; v < parts.parts[skin_part].vertices.cols(); v += 7) {
        const float shade = shaded.colours(0, v) / open.colours(0, v);
        EXPECT_NEAR(shade, 1 - (1 - visibility[skin_part][v]), 1e-5) << "vertex " << v;
        const int x = std::clamp(static_cast<int>(shaded.uv(0, v) * static_cast<float>(atlas.cols)), 0, atlas.cols - 1);
        const int y = std::clamp(static_cast<int>(shaded.uv(1, v) * static_cast<float>(atlas.rows)), 0, atlas.rows - 1);
        const double red = core::srgb_decode(atlas.at<cv::Vec3b>(y, x)[0] / 255.0);
        EXPECT_NEAR(red / skin.x(), std::max(0.2, static_cast<double>(shade)), 0.07) << "vertex " << v;
        ++checked;
    }
    EXPECT_GT(checked, 100);
}

}  // namespace
}  // namespace facesynth::synth
