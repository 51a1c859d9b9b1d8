#include "morph/builtin.h"
#include "morph/landmarks.h"
#include "morph/mesh.h"
#include "morph/regions.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <set>

namespace facesynth {
namespace {

// The suite reads the model once and shares it.
class BuiltinModel : public ::testing::Test {
protected:
    static void SetUpTestSuite() { model_ = new morph::MorphableModel(morph::builtin_model()); }
    static void TearDownTestSuite() {
        delete model_;
        model_ = nullptr;
    }
    static const morph::MorphableModel& model() { return *model_; }
    static Eigen::Matrix3Xf mean_landmarks() { return model().landmark_positions(model().shape_instance({})); }
    // 1-based iBUG ids, as a person reads them.
    static double distance(const Eigen::Matrix3Xf& l, int a, int b) { return (l.col(a - 1) - l.col(b - 1)).norm(); }
    static Eigen::Vector3f point(const Eigen::Matrix3Xf& l, int id) { return l.col(id - 1); }
    static int blendshape_index(const std::string& name) {
        const auto& shapes = std::get<std::vector<morph::Blendshape>>(*model().expression);
        for (std::size_t i = 0; i < shapes.size(); ++i)
            if (shapes[i].name == name) return static_cast<int>(i);
        return -1;
    }
    static Eigen::Matrix3Xf landmarks_with(const std::string& name, float weight) {
        std::vector<float> psi(static_cast<std::size_t>(model().num_expression_components()), 0.0f);
        psi[static_cast<std::size_t>(blendshape_index(name))] = weight;
        return model().landmark_positions(model().shape_instance({}, psi));
    }

private:
    static inline morph::MorphableModel* model_ = nullptr;
};

TEST_F(BuiltinModel, SizesAndValidity) {
    const auto& m = model();
    EXPECT_NO_THROW(m.validate("builtin"));
    EXPECT_GE(m.num_vertices(), 3000);
    EXPECT_LE(m.num_vertices(), 8000);
    EXPECT_EQ(m.num_vertices(), morph::kBuiltinColumns * morph::kBuiltinRows);
    EXPECT_GE(m.num_shape_components(), 30);
    EXPECT_GE(m.num_albedo_components(), 10);
    EXPECT_EQ(m.landmarks.size(), 68u);
    EXPECT_EQ(m.uv.cols(), m.num_vertices());
    EXPECT_GE(m.uv.minCoeff(), 0.0f);
    EXPECT_LE(m.uv.maxCoeff(), 1.0f);
    const Eigen::Matrix3Xf v = m.shape_instance({});
    // Millimetres: a head some 15 cm wide.
    const double width = v.row(0).maxCoeff() - v.row(0).minCoeff();
    EXPECT_GT(width, 120.0);
    EXPECT_LT(width, 180.0);
}

// builtin_model() reads the copy the build generated; generating it again gives the same model, bit
// for bit, every time.
TEST_F(BuiltinModel, EmbeddedCopyIsTheModelGeneratedAgain) {
    ASSERT_TRUE(morph::builtin_model_is_embedded());
    const morph::MorphableModel generated = morph::generate_builtin_model();
    EXPECT_EQ(generated.checksum(), model().checksum());
    EXPECT_EQ(generated.vertex_labels, model().vertex_labels);
    EXPECT_EQ(generated.name, "builtin");
    EXPECT_EQ(morph::generate_builtin_model().checksum(), generated.checksum());
}

TEST_F(BuiltinModel, UvLayoutPutsTheMidlineAtHalfAndTheSubjectsRightBelow) {
    const auto& m = model();
    const Eigen::Matrix3Xf v = m.shape_instance({});
    for (int i = 0; i < m.num_vertices(); ++i) {
        if (std::abs(v(0, i)) < 1e-4f) {
            EXPECT_NEAR(m.uv(0, i), 0.5f, 1e-5f);
        } else {
            EXPECT_EQ(m.uv(0, i) < 0.5f, v(0, i) < 0.0f) << "vertex " << i;
        }
    }
    // v grows downward: the forehead's v is smaller than the chin's.
    const auto& l = m.landmarks;
    EXPECT_LT(m.uv(1, l[27].vertices[0]), m.uv(1, l[8].vertices[0]));
}

TEST_F(BuiltinModel, NormalsPointOutward) {
    const auto& m = model();
    const Eigen::Matrix3Xf v = m.shape_instance({});
    const Eigen::Matrix3Xf n = morph::vertex_normals(v, m.triangles);
    // Outward: away from the vertical axis through the head (the face is star-shaped around it).
    int outward = 0, counted = 0;
    for (int i = 0; i < m.num_vertices(); ++i) {
        const Eigen::Vector3f radial(v(0, i), 0.0f, v(2, i) + 20.0f);
        if (radial.norm() < 1e-3f || n.col(i).norm() < 0.5f) continue;
        ++counted;
        if (n.col(i).dot(radial) > 0.0f) ++outward;
    }
    EXPECT_GT(outward, 0.97 * counted);
    const Eigen::Matrix3Xf l = m.landmark_positions(v);
    // Nose tip and forehead face the viewer.
    const int tip = m.landmarks[30].vertices[0];
    EXPECT_GT(n(2, tip), 0.6f);
}

// Area (mm²) of triangles that face against their corners' normals: folds in the surface.
double folded_area(const Eigen::Matrix3Xf& v, const std::vector<morph::Triangle>& triangles) {
    const Eigen::Matrix3Xf n = morph::vertex_normals(v, triangles);
    double area = 0;
    for (const auto& t : triangles) {
        const Eigen::Vector3f face = (v.col(t[1]) - v.col(t[0])).cross(v.col(t[2]) - v.col(t[0]));
        const Eigen::Vector3f corners = n.col(t[0]) + n.col(t[1]) + n.col(t[2]);
        if (face.dot(corners) < 0.0f) area += 0.5 * face.norm();
    }
    return area;
}

TEST_F(BuiltinModel, SurfaceHasNoFoldsAtTheMeanOrTwoSigma) {
    const auto& m = model();
    EXPECT_LT(folded_area(m.shape_instance({}), m.triangles), 1.0);
    for (int k = 0; k < m.num_shape_components(); k += 3)
        for (float s : {-2.0f, 2.0f}) {
            std::vector<float> alpha(static_cast<std::size_t>(m.num_shape_components()), 0.0f);
            alpha[static_cast<std::size_t>(k)] = s;
            // A few mm² of lid-margin overhang at the canthi are allowed.
            EXPECT_LT(folded_area(m.shape_instance(alpha), m.triangles), 8.0) << "component " << k << " at " << s;
        }
    const int expressions = m.num_expression_components();
    for (int e = 0; e < expressions; ++e) {
        std::vector<float> psi(static_cast<std::size_t>(expressions), 0.0f);
        psi[static_cast<std::size_t>(e)] = 1.0f;
        EXPECT_LT(folded_area(m.shape_instance({}, psi), m.triangles), 12.0) << "blendshape " << e;
    }
}

TEST_F(BuiltinModel, SymmetryMapIsAnInvolutionMirroringX) {
    const auto& m = model();
    ASSERT_EQ(static_cast<int>(m.symmetry.size()), m.num_vertices());
    std::vector<float> alpha(static_cast<std::size_t>(m.num_shape_components()), 0.0f);
    alpha[0] = 1.5f;
    alpha[3] = -1.0f;
    for (const auto& coefficients : {std::vector<float>{}, alpha}) {
        const Eigen::Matrix3Xf v = m.shape_instance(coefficients);
        for (int i = 0; i < m.num_vertices(); ++i) {
            const int j = m.symmetry[static_cast<std::size_t>(i)];
            ASSERT_GE(j, 0);
            ASSERT_EQ(m.symmetry[static_cast<std::size_t>(j)], i);
            EXPECT_NEAR(v(0, i), -v(0, j), 1e-3f);
            EXPECT_NEAR(v(1, i), v(1, j), 1e-3f);
            EXPECT_NEAR(v(2, i), v(2, j), 1e-3f);
        }
    }
}

TEST_F(BuiltinModel, MirrorLandmarkPairsMirrorAcrossTheMidline) {
    const Eigen::Matrix3Xf l = mean_landmarks();
    const auto mirror = morph::ibug_mirror_pairs();
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        const int j = mirror[static_cast<std::size_t>(i)];
        EXPECT_NEAR(l(0, i), -l(0, j), 0.05f) << "iBUG " << i + 1;
        EXPECT_NEAR(l(1, i), l(1, j), 0.05f) << "iBUG " << i + 1;
        EXPECT_NEAR(l(2, i), l(2, j), 0.05f) << "iBUG " << i + 1;
    }
}

TEST_F(BuiltinModel, LandmarksSitOnTheFrontOfTheFaceInAnatomicalOrder) {
    const Eigen::Matrix3Xf l = mean_landmarks();
    const Eigen::Matrix3Xf v = model().shape_instance({});
    const float half_width = 0.5f * (v.row(0).maxCoeff() - v.row(0).minCoeff());
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        EXPECT_LT(std::abs(l(0, i)), half_width) << "iBUG " << i + 1;
        EXPECT_GT(l(2, i), i < morph::kNumJawLandmarks ? -10.0f : 40.0f) << "iBUG " << i + 1;  // interior points well in front
    }
    // Subject's right is the viewer's left (-x).
    for (int id : {1, 4, 8, 18, 22, 32, 37, 40, 49, 61}) EXPECT_LT(point(l, id).x(), -1.0f) << "iBUG " << id;
    for (int id : {9, 28, 31, 34, 52, 58, 63, 67}) EXPECT_NEAR(point(l, id).x(), 0.0f, 0.05f) << "iBUG " << id;
    // Top to bottom: brows, eyes, nose tip, subnasale, mouth, chin.
    EXPECT_GT(point(l, 20).y(), point(l, 38).y());
    EXPECT_GT(point(l, 38).y(), point(l, 42).y());
    EXPECT_GT(point(l, 37).y(), point(l, 31).y());
    EXPECT_GT(point(l, 31).y(), point(l, 34).y());
    EXPECT_GT(point(l, 34).y(), point(l, 52).y());
    EXPECT_GT(point(l, 52).y(), point(l, 63).y());
    EXPECT_GT(point(l, 67).y(), point(l, 58).y());
    EXPECT_GT(point(l, 58).y(), point(l, 9).y());
    // The nose tip is the most prominent landmark.
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) EXPECT_LE(l(2, i), point(l, 31).z() + 1e-3f) << "iBUG " << i + 1;
    // The jaw outline descends monotonically from point 1 to the chin.
    for (int id = 2; id <= 9; ++id) EXPECT_LT(point(l, id).y(), point(l, id - 1).y()) << "iBUG " << id;
}

// Mean anthropometry against Farkas' adult norms (male / female means, docs/builtin-model.md), with room for
// the landmark definitions (300-W points are not exactly the anthropometric points).
TEST_F(BuiltinModel, MeanFaceMatchesAnthropometricNorms) {
    const Eigen::Matrix3Xf l = mean_landmarks();
    EXPECT_NEAR(distance(l, 37, 46), 89.5, 4.0);   // biocular width ex-ex: 91 / 88
    // intercanthal width en-en: 33 / 32; 300-W's annotators put the inner corners (40, 43) about 2 mm
    // lateral to en, where the lids meet beside the caruncle (morph/builtin.cpp kAnnotatorShifts)
    EXPECT_NEAR(distance(l, 40, 43), 36.5, 3.0);
    EXPECT_NEAR(distance(l, 37, 40), 28.5, 3.5);   // eye fissure length: 31 / 30
    EXPECT_NEAR(distance(l, 49, 55), 52.0, 4.0);   // mouth width ch-ch: 54 / 50
    EXPECT_NEAR(point(l, 34).y() - point(l, 63).y(), 20.0, 4.0);  // upper lip height sn-sto: 22 / 20
    EXPECT_NEAR(point(l, 31).z() - point(l, 34).z(), 19.5, 4.0);  // nasal tip protrusion sn-prn: 20 / 19
    EXPECT_NEAR(distance(l, 1, 17), 133.0, 12.0);  // face width at the outline, close to zy-zy: 137 / 130
    const double nasion_to_chin = point(l, 28).y() + 6.0 - point(l, 9).y();  // 28 sits a little below nasion
    EXPECT_NEAR(nasion_to_chin, 116.5, 8.0);       // face height n-gn: 121 / 112
}

TEST_F(BuiltinModel, BasesAreOrthonormalWithDescendingVariances) {
    for (const morph::PcaModel* pca : {&model().shape, &*model().albedo}) {
        const Eigen::MatrixXf gram = pca->basis.transpose() * pca->basis;
        EXPECT_LT((gram - Eigen::MatrixXf::Identity(gram.rows(), gram.cols())).cwiseAbs().maxCoeff(), 1e-3f);
        for (int i = 1; i < pca->num_components(); ++i) EXPECT_LE(pca->eigenvalues[i], pca->eigenvalues[i - 1]);
        EXPECT_GT(pca->eigenvalues.minCoeff(), 0.0f);
    }
}

TEST_F(BuiltinModel, BlendshapesMoveTheFaceAsNamed) {
    for (const char* name : {"jaw_open", "smile", "brow_raise", "eye_close", "pucker"})
        ASSERT_GE(blendshape_index(name), 0) << name;
    const Eigen::Matrix3Xf neutral = mean_landmarks();
    const auto open = landmarks_with("jaw_open", 1.0f);
    EXPECT_LT(point(open, 9).y(), point(neutral, 9).y() - 15.0f);
    EXPECT_GT(distance(open, 63, 67), 8.0);
    EXPECT_LT(distance(neutral, 63, 67), 1.5);
    const auto smile = landmarks_with("smile", 1.0f);
    EXPECT_GT(point(smile, 49).y(), point(neutral, 49).y() + 2.0f);
    EXPECT_GT(distance(smile, 49, 55), distance(neutral, 49, 55) + 2.0);
    const auto raised = landmarks_with("brow_raise", 1.0f);
    for (int id = 18; id <= 27; ++id) EXPECT_GT(point(raised, id).y(), point(neutral, id).y() + 3.0f) << id;
    const auto closed = landmarks_with("eye_close", 1.0f);
    EXPECT_GT(distance(neutral, 38, 42), 7.0);
    EXPECT_LT(distance(closed, 38, 42), 1.5);
    EXPECT_LT(distance(closed, 45, 47), 1.5);
    const auto pucker = landmarks_with("pucker", 1.0f);
    EXPECT_LT(distance(pucker, 49, 55), distance(neutral, 49, 55) - 6.0);
    EXPECT_GT(point(pucker, 52).z(), point(neutral, 52).z() + 3.0f);
}

TEST_F(BuiltinModel, ColourModelHasDistinctRegionsAndASkinToneRange) {
    const auto& m = model();
    const Eigen::Matrix3Xf c = m.albedo_instance({});
    const auto colour = [&](int ibug) { return Eigen::Vector3f(c.col(m.landmarks[static_cast<std::size_t>(ibug - 1)].vertices[0])); };
    const auto luminance = [](const Eigen::Vector3f& rgb) { return 0.2126f * rgb.x() + 0.7152f * rgb.y() + 0.0722f * rgb.z(); };
    // Lips (lower lip centre, just inside the border) are redder than the cheek-side skin by the nose.
    const Eigen::Matrix3Xf v = m.shape_instance({});
    const Eigen::Vector3f lip_point = 0.5f * (m.landmarks[57].position(v) + m.landmarks[66].position(v));
    int lip = 0, cheek = m.landmarks[1].vertices[0];
    for (int i = 0; i < m.num_vertices(); ++i)
        if ((v.col(i) - lip_point).norm() < (v.col(lip) - lip_point).norm()) lip = i;
    cheek = m.landmarks[31].vertices[0];
    const Eigen::Vector3f lip_rgb = c.col(lip), skin_rgb = colour(29);
    EXPECT_GT(lip_rgb.x() / lip_rgb.y(), 1.15f * skin_rgb.x() / skin_rgb.y());
    (void)cheek;
    // Brows are darker than the forehead; eyes hold bright sclera and a dark pupil.
    EXPECT_LT(luminance(colour(20)), 0.7f * luminance(colour(29)));
    float brightest = 0, darkest = 1;
    for (int i = 0; i < m.num_vertices(); ++i) {
        const Eigen::Vector3f p = v.col(i);
        const Eigen::Vector3f eye = 0.5f * (m.landmarks[36].position(v) + m.landmarks[39].position(v));
        if ((p - eye).head<2>().norm() < 12.0f && p.z() > eye.z() - 10.0f) {
            brightest = std::max(brightest, luminance(c.col(i)));
            darkest = std::min(darkest, luminance(c.col(i)));
        }
    }
    EXPECT_GT(brightest, 1.3f * luminance(colour(29)));
    EXPECT_LT(darkest, 0.1f);
    // Skin tone spans light to dark along the colour model's prior.
    float lightest_skin = 1, darkest_skin = 0;
    for (int k = 0; k < m.num_albedo_components(); ++k)
        for (float s : {-2.0f, 2.0f}) {
            std::vector<float> beta(static_cast<std::size_t>(m.num_albedo_components()), 0.0f);
            beta[static_cast<std::size_t>(k)] = s;
            const float y = luminance(Eigen::Vector3f(m.albedo_instance(beta).col(m.landmarks[28].vertices[0])));
            lightest_skin = std::min(lightest_skin, y);
            darkest_skin = std::max(darkest_skin, y);
        }
    EXPECT_GT(darkest_skin / std::max(lightest_skin, 1e-4f), 2.5f);
}

TEST_F(BuiltinModel, RegionLabelsFollowTheFeaturesAndMirror) {
    const auto& m = model();
    const auto& labels = m.vertex_labels;
    ASSERT_EQ(static_cast<int>(labels.size()), m.num_vertices());
    std::set<int> present(labels.begin(), labels.end());
    // Every face region; clothing is synth's head parts', never a model's.
    for (int r = 1; r < morph::kNumRegions; ++r) {
        if (static_cast<morph::Region>(r) != morph::Region::kClothing) {
            EXPECT_TRUE(present.count(r)) << morph::region_name(static_cast<morph::Region>(r));
        }
    }
    EXPECT_FALSE(present.count(static_cast<int>(morph::Region::kClothing)));
    EXPECT_FALSE(present.count(0));  // no vertex is background
    for (int v = 0; v < m.num_vertices(); ++v)
        ASSERT_EQ(labels[static_cast<std::size_t>(v)], labels[static_cast<std::size_t>(m.symmetry[static_cast<std::size_t>(v)])]) << v;
    // The region under each landmark's dominant vertex (1-based iBUG ids).
    const auto label_at = [&](int id) {
        const morph::SurfacePoint& p = m.landmarks[static_cast<std::size_t>(id - 1)];
        int best = 0;
        for (int k = 1; k < 3; ++k)
            if (p.weights[static_cast<std::size_t>(k)] > p.weights[static_cast<std::size_t>(best)]) best = k;
        return static_cast<morph::Region>(labels[static_cast<std::size_t>(p.vertices[static_cast<std::size_t>(best)])]);
    };
    for (int id : {20, 25}) EXPECT_EQ(label_at(id), morph::Region::kBrows) << id;
    for (int id : {30, 31}) EXPECT_EQ(label_at(id), morph::Region::kNose) << id;
    for (int id : {38, 39, 44, 45}) EXPECT_EQ(label_at(id), morph::Region::kEyes) << id;
    // Lip landmarks lie on the vermilion border: one of their vertices is lips.
    for (int id = 49; id <= 60; ++id) {
        const morph::SurfacePoint& p = m.landmarks[static_cast<std::size_t>(id - 1)];
        bool lips = false;
        for (int k = 0; k < 3; ++k)
            lips = lips || (p.weights[static_cast<std::size_t>(k)] > 0 &&
                            labels[static_cast<std::size_t>(p.vertices[static_cast<std::size_t>(k)])] == static_cast<std::uint8_t>(morph::Region::kLips));
        EXPECT_TRUE(lips) << id;
    }
    for (int id : {5, 9, 13}) EXPECT_EQ(label_at(id), morph::Region::kSkin) << id;
    // Hair on the crown, ears at the sides behind the jaw, neck under the chin.
    EXPECT_EQ(static_cast<morph::Region>(labels[0]), morph::Region::kHair);
    EXPECT_EQ(static_cast<morph::Region>(labels[static_cast<std::size_t>(m.num_vertices() - 1 - morph::kBuiltinColumns / 2)]), morph::Region::kNeck);
}

TEST_F(BuiltinModel, ContourChainsRunDownTheOutlineAndMirror) {
    const auto& m = model();
    ASSERT_EQ(m.contour.right.size(), 17u);
    ASSERT_EQ(m.contour.left.size(), 17u);
    const Eigen::Matrix3Xf v = m.shape_instance({});
    const Eigen::Matrix3Xf l = mean_landmarks();
    std::set<int> unique(m.contour.right.begin(), m.contour.right.end());
    EXPECT_EQ(unique.size(), 17u);
    for (std::size_t i = 0; i < 17; ++i) {
        const int r = m.contour.right[i], left = m.contour.left[i];
        EXPECT_LT(v(0, r), 0.0f);
        EXPECT_EQ(m.symmetry[static_cast<std::size_t>(r)], left);
        if (i > 0) {
            EXPECT_LT(v(1, r), v(1, m.contour.right[i - 1]));
        }
    }
    // From eyebrow height down toward the chin, chin excluded.
    EXPECT_GT(v(1, m.contour.right.front()), point(l, 37).y());
    EXPECT_GT(v(1, m.contour.right.back()), point(l, 9).y());
}

TEST_F(BuiltinModel, RandomIdentitiesStayFaceShaped) {
    const auto& m = model();
    for (float s : {-2.0f, 2.0f})
        for (int k = 0; k < 6; ++k) {
            std::vector<float> alpha(static_cast<std::size_t>(m.num_shape_components()), 0.0f);
            alpha[static_cast<std::size_t>(k)] = s;
            const Eigen::Matrix3Xf l = m.landmark_positions(m.shape_instance(alpha));
            EXPECT_GT(point(l, 38).y(), point(l, 31).y()) << k;
            EXPECT_GT(point(l, 31).y(), point(l, 52).y()) << k;
            EXPECT_GT(point(l, 58).y(), point(l, 9).y()) << k;
            EXPECT_GT(distance(l, 37, 46), 70.0) << k;
            EXPECT_LT(distance(l, 37, 46), 110.0) << k;
        }
}

}  // namespace
}  // namespace facesynth
