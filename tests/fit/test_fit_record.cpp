// fit::fit_face (the `fit` command's protocol) and the fit records' JSON keys.
#include "fit/fit_record.h"

#include "common/toy_model.h"
#include "core/random.h"
#include "morph/camera.h"
#include "morph/sampling.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace facesynth::fit {
namespace {

struct PerspectiveFace {
    Eigen::Matrix2Xd landmarks;
    morph::Intrinsics intrinsics;
    morph::EulerAngles angles;
};

// A landmark that sits on a vertex, and that vertex.
std::pair<int, int> landmark_on_a_vertex(const morph::MorphableModel& m) {
    for (std::size_t i = 0; i < m.landmarks.size(); ++i)
        if (m.landmarks[i].weights[0] == 1.0f) return {static_cast<int>(i), m.landmarks[i].vertices[0]};
    ADD_FAILURE() << "no landmark on a vertex";
    return {0, 0};
}

PerspectiveFace perspective_face(const morph::MorphableModel& m) {
    core::Rng rng(77, 1);
    const std::vector<float> alpha = morph::sample_coefficients(rng, static_cast<std::size_t>(m.num_shape_components()), 2.0);
    PerspectiveFace face;
    face.intrinsics = morph::intrinsics_from_fov(30, 512, 512);
    face.angles = {25, -8, 5};
    const morph::CameraPose pose{morph::rotation_from_euler(face.angles), {10, -5, 600}};
    face.landmarks = project(face.intrinsics, pose, m.landmark_positions(m.shape_instance(alpha, {})));
    return face;
}

TEST(FitRecord, LinearFitGivesTheFinalValuesAndProjectsEveryVertexThroughTheAffineCamera) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 8});
    const PerspectiveFace face = perspective_face(m);
    LandmarkFitOptions o;
    o.fit.fit_expression = false;
    const LandmarkFit f = fit_face(Fitter(m), face.landmarks, o);
    EXPECT_FALSE(f.refined.has_value());
    EXPECT_EQ(f.alpha(), f.linear.alpha);
    EXPECT_EQ(f.reprojection_rms_px(), f.linear.reprojection_rms_px);
    ASSERT_EQ(f.vertices_px.cols(), m.num_vertices());
    const int v = landmark_on_a_vertex(m).second;
    EXPECT_TRUE(f.vertices_px.col(v).isApprox(f.linear.camera.project(f.mesh.vertices.col(v).cast<double>())));

    nlohmann::json j;
    write_json(j, f);
    EXPECT_FALSE(j.at("refined").get<bool>());
    EXPECT_FALSE(j.contains("focal_px"));
    EXPECT_EQ(j.at("affine_camera").size(), 3U);  // 3 x 4, homogeneous
    EXPECT_DOUBLE_EQ(j.at("yaw_deg").get<double>(), f.linear.pose.angles.yaw);
    EXPECT_DOUBLE_EQ(j.at("linear_reprojection_rms_px").get<double>(), j.at("reprojection_rms_px").get<double>());
}

TEST(FitRecord, RefinedFitReplacesTheFinalValuesAndReportsItsCamera) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 8});
    const PerspectiveFace face = perspective_face(m);
    LandmarkFitOptions o;
    o.fit.fit_expression = false;
    o.refine = true;
    o.refine_options.intrinsics = face.intrinsics;
    const LandmarkFit f = fit_face(Fitter(m), face.landmarks, o);
    ASSERT_TRUE(f.refined.has_value());
    EXPECT_EQ(f.alpha(), f.refined->alpha);
    EXPECT_NEAR(f.angles().yaw, face.angles.yaw, 0.5);
    EXPECT_LT(f.reprojection_rms_px(), f.linear.reprojection_rms_px);
    // The refined camera puts the fitted landmark vertices on the landmarks.
    const auto [landmark, v] = landmark_on_a_vertex(m);
    EXPECT_LT((f.vertices_px.col(v) - face.landmarks.col(landmark)).norm(), 0.5);

    nlohmann::json j;
    write_json(j, f);
    EXPECT_TRUE(j.at("refined").get<bool>());
    EXPECT_DOUBLE_EQ(j.at("focal_px").get<double>(), face.intrinsics.fx);
    EXPECT_EQ(j.at("translation_mm").size(), 3U);
    EXPECT_DOUBLE_EQ(j.at("reprojection_rms_px").get<double>(), f.refined->reprojection_rms_px);
    EXPECT_NE(j.at("linear_reprojection_rms_px").get<double>(), j.at("reprojection_rms_px").get<double>());
}

}  // namespace
}  // namespace facesynth::fit
