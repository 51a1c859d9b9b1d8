#include "fit/contour.h"
#include "fit/fit.h"

#include "common/toy_model.h"
#include "morph/builtin.h"
#include "morph/jaw_contour.h"
#include "morph/pose.h"
#include "morph/landmarks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace facesynth::fit {
namespace {

TEST(Contour, EdgeTopologyOfAClosedMeshHasTwoTrianglesPerEdge) {
    const morph::MorphableModel m = testkit::make_toy_model({});
    const auto edges = edge_topology(m.triangles, m.num_vertices());
    EXPECT_EQ(edges.size() * 2, m.triangles.size() * 3);
    for (const auto& e : edges) {
        EXPECT_LT(e.a, e.b);
        EXPECT_GE(e.left, 0);
        EXPECT_GE(e.right, 0);
    }
    // An open mesh: one triangle has three boundary edges.
    const auto open = edge_topology({morph::Triangle{0, 1, 2}}, 3);
    ASSERT_EQ(open.size(), 3u);
    for (const auto& e : open) EXPECT_EQ(e.right, -1);
}

TEST(Contour, OccludingVerticesOfAFrontalEllipsoidLieOnItsOutline) {
    const morph::MorphableModel m = testkit::make_toy_model({});
    const ContourFinder finder(m);
    const auto mean = morph::as_points(m.shape.mean);
    const auto ids = finder.occluding_vertices(Eigen::Matrix3d::Identity());
    ASSERT_GT(ids.size(), 20u);
    for (int id : ids) EXPECT_LT(std::abs(mean(2, id)), 15.0f) << "vertex " << id;  // near the z = 0 outline
    // Turned 90°: the outline is the x = 0 meridian.
    const auto side = finder.occluding_vertices(morph::rotation_from_euler({90, 0, 0}));
    for (int id : side) EXPECT_LT(std::abs(mean(0, id)), 15.0f) << "vertex " << id;
}

// Jaw landmarks placed on the silhouette of a turned head, as annotators mark them: for each jaw point,
// the outermost projected face-region vertex (morph/jaw_contour.h) at the image height of the fixed
// jaw landmark.
Eigen::Matrix2Xd silhouette_landmarks(const morph::MorphableModel& m, const ScaledOrthographic& camera) {
    const Eigen::Matrix3Xf shape = m.shape_instance({});
    const AffineCamera a = camera.to_affine();
    Eigen::Matrix2Xd lm(2, 68);
    for (int l = 0; l < 68; ++l) lm.col(l) = a.project(m.landmarks[static_cast<std::size_t>(l)].position(shape).cast<double>());
    Eigen::Matrix2Xd all(2, shape.cols());
    for (Eigen::Index v = 0; v < shape.cols(); ++v) all.col(v) = a.project(shape.col(v).cast<double>());
    // Only the side turned away from the camera (yaw > 0: the subject's left, iBUG 10-17) moves; the
    // near side stays on the fixed jaw line (morph/jaw_contour.h).
    std::vector<char> in_region(static_cast<std::size_t>(shape.cols()), 0);
    for (int v : morph::jaw_contour_region(m).vertices) in_region[static_cast<std::size_t>(v)] = 1;
    for (int j = morph::kChinLandmark + 1; j < morph::kNumJawLandmarks; ++j) {
        const double y = lm(1, j);
        double best = j < morph::kChinLandmark ? std::numeric_limits<double>::max() : -std::numeric_limits<double>::max();
        for (Eigen::Index v = 0; v < shape.cols(); ++v) {
            if (!in_region[static_cast<std::size_t>(v)] || std::abs(all(1, v) - y) > 2.0) continue;
            best = j < morph::kChinLandmark ? std::min(best, all(0, v)) : std::max(best, all(0, v));
        }
        lm(0, j) = best;
    }
    return lm;
}

TEST(Contour, ContourModeFollowsTheSilhouetteBetterThanFixedJawPoints) {
    const morph::MorphableModel m = testkit::make_toy_model({.shape_components = 6});
    const Fitter fitter(m);
    const morph::EulerAngles angles{40, 0, 0};
    const ScaledOrthographic camera{2.0, morph::rotation_from_euler(angles), {256, 256}, angles};
    const Eigen::Matrix2Xd lm = silhouette_landmarks(m, camera);
    FitOptions o;
    o.fit_expression = false;
    o.iterations = 10;
    o.jaw = JawMode::kFixed;
    const FitResult fixed = fitter.fit(lm, o);
    o.jaw = JawMode::kContour;
    const FitResult contour = fitter.fit(lm, o);
    EXPECT_LT(contour.reprojection_rms_px, fixed.reprojection_rms_px);
    EXPECT_LT(std::abs(contour.pose.angles.yaw - angles.yaw), std::abs(fixed.pose.angles.yaw - angles.yaw) + 1e-9);
    EXPECT_NEAR(contour.pose.angles.yaw, angles.yaw, 3.0);
    // The jaw correspondences moved away from the fixed vertices on the far side.
    int moved = 0;
    for (int j = 9; j < morph::kNumJawLandmarks; ++j)
        moved += contour.correspondences[static_cast<std::size_t>(j)].vertices[0] != m.landmarks[static_cast<std::size_t>(j)].vertices[0];
    EXPECT_GT(moved, 0);
}


// The fitter searches all far-side jaw points in one pass over the region's edges; the hits must be
// those of the one-point search, bit for bit, whether the queries' directions agree (affine camera)
// or differ (a perspective camera turns the face's x axis differently at each point).
TEST(Contour, BatchedContourSearchGivesTheSameHitsAsOnePointAtATime) {
    const morph::MorphableModel model = morph::builtin_model();
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    ASSERT_FALSE(region.vertices.empty());
    const Eigen::Matrix3Xf mean = morph::as_points(model.shape.mean);
    int found = 0;
    for (double yaw : {-70.0, -40.0, -10.0, 25.0, 55.0}) {
        const morph::EulerAngles angles{yaw, 8, -5};
        const Eigen::Matrix<double, 2, 3> m = 2.5 * (morph::model_to_camera_flip() * morph::rotation_from_euler(angles)).topRows<2>();
        Eigen::Matrix2Xd projected(2, static_cast<Eigen::Index>(region.vertices.size()));
        for (std::size_t r = 0; r < region.vertices.size(); ++r)
            projected.col(static_cast<Eigen::Index>(r)) = m * mean.col(region.vertices[r]).cast<double>() + Eigen::Vector2d(200, 210);
        const Eigen::Vector2d across = (m * Eigen::Vector3d::UnitX()).normalized();
        for (double spread : {0.0, 1e-12, 0.05}) {  // directions equal, equal up to rounding, different
            std::vector<morph::JawContourQuery> queries;
            for (int j = 0; j < morph::kNumJawLandmarks; ++j) {
                if (j == morph::kChinLandmark) continue;
                const Eigen::Vector2d fixed = m * model.landmarks[static_cast<std::size_t>(j)].position(mean).cast<double>() + Eigen::Vector2d(200, 210);
                const Eigen::Vector2d outward = (j < morph::kChinLandmark ? -across : across) + spread * (j - 8) * Eigen::Vector2d(across.y(), -across.x());
                queries.push_back({fixed, outward});
            }
            const auto batch = morph::jaw_contour_points(region, projected, queries);
            ASSERT_EQ(batch.size(), queries.size());
            for (std::size_t q = 0; q < queries.size(); ++q) {
                const auto one = morph::jaw_contour_point(region, projected, queries[q].fixed_pixel, queries[q].outward);
                ASSERT_EQ(one.has_value(), batch[q].has_value()) << "yaw " << yaw << " query " << q;
                if (!one) continue;
                ++found;
                EXPECT_EQ(one->point.vertices, batch[q]->point.vertices) << "yaw " << yaw << " query " << q;
                EXPECT_EQ(one->point.weights, batch[q]->point.weights) << "yaw " << yaw << " query " << q;
                EXPECT_EQ(one->pixel, batch[q]->pixel) << "yaw " << yaw << " query " << q;
            }
        }
    }
    EXPECT_GT(found, 200);  // most lines meet the region
}

}  // namespace
}  // namespace facesynth::fit
