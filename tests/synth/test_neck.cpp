// synth's head.neck: a neck under the jaw that leaves the face's landmarks and labels as they are.
#include "morph/model_io.h"
#include "morph/regions.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/neck.h"
#include "synth/sample.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace facesynth::synth {
namespace {

int count_region_pixels(const cv::Mat& labels, morph::Region region) {
    int n = 0;
    for (int y = 0; y < labels.rows; ++y)
        for (int x = 0; x < labels.cols; ++x) n += labels.at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(region);
    return n;
}

TEST(Neck, LeavesTheFacesLandmarksAndLabelsAndAddsNeckPixelsBelowTheChin) {
    const morph::MorphableModel model = morph::load_model("builtin");
    SynthConfig plain;
    plain.camera.width = plain.camera.height = 128;
    plain.output.labels = true;
    apply_override(plain, "pose.pitch.min=-10");  // the neck may hide jaw points of a face looking far down
    apply_override(plain, "pose.pitch.max=10");
    SynthConfig with_neck = plain;
    apply_override(with_neck, "head.neck=true");
    const ImageLibrary none;
    const render::RendererOptions options{render::Backend::kEgl, false};
    SampleGenerator a(plain, model, none, none, options), b(with_neck, model, none, none, options);
    int visibility_changes = 0;
    for (std::int64_t index = 0; index < 6; ++index) {
        const Sample without = a.generate(index), with = b.generate(index);
        EXPECT_EQ(without.labels.landmarks_contour, with.labels.landmarks_contour) << "sample " << index;
        EXPECT_EQ(without.labels.landmarks_fixed, with.labels.landmarks_fixed) << "sample " << index;
        for (std::size_t i = 0; i < 68; ++i) visibility_changes += without.labels.visible_contour[i] != with.labels.visible_contour[i];
        const int neck_pixels = count_region_pixels(with.regions, morph::Region::kNeck) - count_region_pixels(without.regions, morph::Region::kNeck);
        EXPECT_GT(neck_pixels, 100) << "sample " << index;
        // The face's own labels are only ever covered by nothing new: every pixel labelled as a face part
        // without the neck keeps its label with it.
        int changed_face_pixels = 0;
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x) {
                const auto l = static_cast<morph::Region>(without.regions.at<std::uint8_t>(y, x));
                if (l != morph::Region::kBackground && l != morph::Region::kNeck) changed_face_pixels += with.regions.at<std::uint8_t>(y, x) != without.regions.at<std::uint8_t>(y, x);
            }
        // Outline pixels at the jaw only: 25 at most (sample 4, turned away: the neck's top edge in front of
        // the far jaw's angle, which sits further back since the lower face wraps round the teeth; 21 before).
        EXPECT_LT(changed_face_pixels, 32) << "sample " << index;
        // The neck lies below the chin in the image (y grows downward).
        double neck_y = 0;
        int n = 0;
        for (int y = 0; y < 128; ++y)
            for (int x = 0; x < 128; ++x)
                if (with.regions.at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(morph::Region::kNeck) &&
                    without.regions.at<std::uint8_t>(y, x) == 0)
                    neck_y += y, ++n;
        EXPECT_GT(neck_y / std::max(n, 1), with.labels.landmarks_fixed(1, 57)) << "sample " << index;
    }
    EXPECT_LE(visibility_changes, 6);
}

TEST(Neck, TemplateIsClosedRoundTheNeckAndTakesItsLookFromUnderTheChin) {
    const morph::MorphableModel model = morph::load_model("builtin");
    const auto neck = make_neck_template(model);
    ASSERT_TRUE(neck);
    EXPECT_EQ(static_cast<int>(neck->source.size()), neck->rings * neck->segments);
    EXPECT_EQ(static_cast<int>(neck->triangles.size()), 2 * (neck->rings - 1) * neck->segments);
    const Eigen::Matrix3Xf mean = morph::as_points(model.shape.mean);
    const float mouth_y = model.landmark_positions(mean)(1, 57);
    for (int v : neck->source) {
        ASSERT_GE(v, 0);
        ASSERT_LT(v, model.num_vertices());
        EXPECT_LT(mean(1, v), mouth_y);
    }
    morph::Mesh mesh;
    mesh.vertices = mean;
    append_neck_vertices(*neck, model, mesh);
    EXPECT_EQ(mesh.vertices.cols(), model.num_vertices() + neck->rings * neck->segments);
    EXPECT_TRUE(mesh.vertices.allFinite());
    EXPECT_EQ(labels_with_neck(model, *neck).back(), static_cast<std::uint8_t>(morph::Region::kNeck));
    morph::MorphableModel bare = model;
    bare.landmarks.clear();
    EXPECT_FALSE(make_neck_template(bare));
}

}  // namespace
}  // namespace facesynth::synth
