// build_model: meshes in correspondence -> PCA model (the code behind `facesynth model build`).
#include "core/error.h"
#include "morph/model_build.h"

#include "common/toy_model.h"

#include <gtest/gtest.h>

using namespace facesynth;

namespace {

std::vector<morph::Mesh> toy_meshes(int count) {
    testkit::ToyModelOptions o;
    o.shape_components = 4;
    o.latitude_steps = 10;
    o.longitude_steps = 12;
    const morph::MorphableModel m = testkit::make_toy_model(o);
    std::vector<morph::Mesh> meshes;
    for (int i = 0; i < count; ++i) {
        const std::vector<float> alpha = {0.5f * static_cast<float>(i), -0.3f * static_cast<float>(i * i % 3), 1.0f};
        meshes.push_back(m.instance(alpha));
    }
    return meshes;
}

std::vector<std::string> names(std::size_t n) {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < n; ++i) out.push_back("mesh" + std::to_string(i) + ".obj");
    return out;
}

}  // namespace

TEST(ModelBuild, ReproducesTheMeshesFromTheirCoefficients) {
    const auto meshes = toy_meshes(4);
    const morph::ModelBuildResult built = morph::build_model(meshes, names(4));
    EXPECT_DOUBLE_EQ(built.length_scale, 1.0);
    EXPECT_EQ(built.model.num_shape_components(), 2);  // the toy draws vary along 2 directions only
    EXPECT_EQ(built.model.triangles, meshes[0].triangles);
    EXPECT_EQ(built.model.uv, meshes[0].uv);
    ASSERT_TRUE(built.model.albedo.has_value());
    EXPECT_EQ(built.model.num_albedo_components(), 0);  // same mean colour in every mesh
    // Every input mesh lies in the model's span.
    const morph::PcaModel& shape = built.model.shape;
    for (const morph::Mesh& mesh : meshes) {
        const Eigen::VectorXf x = Eigen::Map<const Eigen::VectorXf>(mesh.vertices.data(), mesh.vertices.size());
        const Eigen::VectorXf residual = (x - shape.mean) - shape.basis * (shape.basis.transpose() * (x - shape.mean));
        EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-2f);
    }
}

TEST(ModelBuild, MetresAreConvertedToMillimetres) {
    auto meshes = toy_meshes(3);
    for (auto& m : meshes) m.vertices *= 0.001f;
    const morph::ModelBuildResult built = morph::build_model(meshes, names(3));
    EXPECT_DOUBLE_EQ(built.length_scale, 1000.0);
    EXPECT_NEAR(built.model.shape.mean.cwiseAbs().maxCoeff(), toy_meshes(1)[0].vertices.cwiseAbs().maxCoeff(), 1.0f);
}

TEST(ModelBuild, RejectsTooFewOrMismatchedMeshes) {
    auto meshes = toy_meshes(3);
    EXPECT_THROW((void)morph::build_model({meshes[0]}, names(1)), core::Error);
    auto swapped = meshes;
    std::swap(swapped[2].triangles[0][0], swapped[2].triangles[0][1]);
    try {
        (void)morph::build_model(swapped, names(3));
        ADD_FAILURE() << "no error for mismatched triangles";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("mesh2.obj"), std::string::npos) << e.what();
    }
    auto fewer = meshes;
    fewer[1].vertices.conservativeResize(3, fewer[1].vertices.cols() - 1);
    EXPECT_THROW((void)morph::build_model(fewer, names(3)), core::Error);
}
