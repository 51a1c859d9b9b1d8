// Mesh export (OBJ, glTF binary) and import, with the .glb structure checked by loading it back
// with tinygltf.
#include "core/error.h"
#include "morph/mesh_io.h"

#include "common/test_data.h"
#include "common/toy_model.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <fstream>

using namespace facesynth;

namespace {

// A 2 x 2 RGB PNG.
constexpr std::uint8_t kTinyPng[] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00, 0x00,
    0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x02, 0x00, 0x00, 0x00, 0xfd, 0xd4, 0x9a, 0x73, 0x00, 0x00, 0x00, 0x10, 0x49,
    0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x38, 0x31, 0xad, 0x02, 0x88, 0x18, 0x20, 0x14, 0x00, 0x34, 0xb6, 0x07, 0x59,
    0x33, 0x47, 0x6a, 0x96, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

morph::Mesh toy_mesh() {
    testkit::ToyModelOptions o;
    o.shape_components = 3;
    o.latitude_steps = 10;
    o.longitude_steps = 14;
    const morph::MorphableModel m = testkit::make_toy_model(o);
    const std::vector<float> alpha = {1.0f, -0.5f, 0.25f};
    return m.instance(alpha);
}

void expect_mesh_error_naming(const std::function<void()>& call, const std::filesystem::path& path, const char* what) {
    try {
        call();
        ADD_FAILURE() << "no error: " << what;
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << what << ": " << e.what();
    }
}

}  // namespace

TEST(MeshIo, GlbStructureIsValid) {
    const auto dir = testkit::fresh_temp_dir("mesh_glb");
    const morph::Mesh mesh = toy_mesh();
    morph::write_glb(mesh, dir / "face.glb", kTinyPng);

    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, (dir / "face.glb").string())) << err;
    EXPECT_EQ(model.asset.version, "2.0");
    ASSERT_EQ(model.meshes.size(), 1u);
    ASSERT_EQ(model.meshes[0].primitives.size(), 1u);
    const auto& primitive = model.meshes[0].primitives[0];
    EXPECT_EQ(primitive.mode, TINYGLTF_MODE_TRIANGLES);
    for (const char* attribute : {"POSITION", "NORMAL", "TEXCOORD_0", "COLOR_0"}) {
        ASSERT_TRUE(primitive.attributes.contains(attribute)) << attribute;
        const auto& accessor = model.accessors[static_cast<std::size_t>(primitive.attributes.at(attribute))];
        EXPECT_EQ(accessor.count, static_cast<std::size_t>(mesh.num_vertices())) << attribute;
        EXPECT_EQ(accessor.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT) << attribute;
    }
    const auto& position = model.accessors[static_cast<std::size_t>(primitive.attributes.at("POSITION"))];
    ASSERT_EQ(position.minValues.size(), 3u);
    ASSERT_EQ(position.maxValues.size(), 3u);
    for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(static_cast<float>(position.minValues[static_cast<std::size_t>(c)]), mesh.vertices.row(c).minCoeff());
        EXPECT_FLOAT_EQ(static_cast<float>(position.maxValues[static_cast<std::size_t>(c)]), mesh.vertices.row(c).maxCoeff());
    }
    const auto& indices = model.accessors[static_cast<std::size_t>(primitive.indices)];
    EXPECT_EQ(indices.count, 3 * mesh.triangles.size());
    EXPECT_EQ(indices.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    // Every accessor lies inside its view and every view inside the one buffer.
    ASSERT_EQ(model.buffers.size(), 1u);
    for (const auto& accessor : model.accessors) {
        const auto& view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
        const std::size_t element = static_cast<std::size_t>(
            tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(accessor.componentType)) *
            tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type)));
        EXPECT_LE(accessor.byteOffset + accessor.count * element, view.byteLength);
    }
    for (const auto& view : model.bufferViews) {
        EXPECT_LE(view.byteOffset + view.byteLength, model.buffers[0].data.size());
        EXPECT_EQ(view.byteOffset % 4, 0u);
    }
    // The texture: one PNG image in the buffer, decoded by tinygltf, used as base colour.
    ASSERT_EQ(model.images.size(), 1u);
    EXPECT_EQ(model.images[0].mimeType, "image/png");
    EXPECT_EQ(model.images[0].width, 2);
    ASSERT_EQ(model.materials.size(), 1u);
    EXPECT_EQ(model.materials[0].pbrMetallicRoughness.baseColorTexture.index, 0);
}

TEST(MeshIo, GlbAndObjRoundTrip) {
    const auto dir = testkit::fresh_temp_dir("mesh_round_trip");
    const morph::Mesh mesh = toy_mesh();
    for (const char* name : {"face.glb", "face.obj"}) {
        SCOPED_TRACE(name);
        std::string_view(name).ends_with(".glb") ? morph::write_glb(mesh, dir / name) : morph::write_obj(mesh, dir / name);
        const morph::Mesh back = morph::read_mesh(dir / name);
        EXPECT_EQ(back.triangles, mesh.triangles);
        ASSERT_EQ(back.vertices.cols(), mesh.vertices.cols());
        EXPECT_LT((back.vertices - mesh.vertices).cwiseAbs().maxCoeff(), 1e-3f);
        ASSERT_EQ(back.uv.cols(), mesh.uv.cols());
        EXPECT_LT((back.uv - mesh.uv).cwiseAbs().maxCoeff(), 1e-5f);
        ASSERT_EQ(back.colours.cols(), mesh.colours.cols());
        EXPECT_LT((back.colours - mesh.colours).cwiseAbs().maxCoeff(), 1e-5f);
    }
}

TEST(MeshIo, ObjWithPolygonsAndNegativeIndices) {
    const auto dir = testkit::fresh_temp_dir("mesh_obj_polygons");
    std::ofstream(dir / "quad.obj") << "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n";
    const morph::Mesh quad = morph::read_mesh(dir / "quad.obj");
    ASSERT_EQ(quad.triangles.size(), 2u);
    EXPECT_EQ(quad.triangles[1], (morph::Triangle{0, 2, 3}));
    EXPECT_EQ(quad.colours.cols(), 0);
    EXPECT_EQ(quad.uv.cols(), 0);
}

TEST(MeshIo, BadMeshFiles) {
    const auto dir = testkit::fresh_temp_dir("mesh_bad");
    const auto check = [&](const char* name, const std::string& text, const char* what) {
        std::ofstream(dir / name, std::ios::binary) << text;
        expect_mesh_error_naming([&] { (void)morph::read_mesh(dir / name); }, dir / name, what);
    };
    check("empty.obj", "", "empty obj");
    check("range.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", "index out of range");
    check("nan.obj", "v 0 nan 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "NaN vertex");
    check("short.obj", "v 0 0\n", "short vertex");
    check("empty.glb", "", "empty glb");
    check("junk.glb", "glTF\x02\0\0\0garbage", "junk glb");
    check("junk.gltf", "{\"asset\": {\"version\": \"2.0\"}}", "gltf without meshes");
    check("mesh.ply", "ply\n", "unknown extension");
    // A truncated .glb.
    morph::write_glb(toy_mesh(), dir / "whole.glb");
    std::string bytes;
    {
        std::ifstream in(dir / "whole.glb", std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    check("cut.glb", bytes.substr(0, bytes.size() / 2), "truncated glb");
    // Writing: a texture without uv, and an unwritable folder.
    morph::Mesh no_uv = toy_mesh();
    no_uv.uv.resize(2, 0);
    expect_mesh_error_naming([&] { morph::write_glb(no_uv, dir / "tex.glb", kTinyPng); }, dir / "tex.glb", "texture without uv");
    EXPECT_THROW(morph::write_obj(toy_mesh(), dir / "missing" / "x.obj"), core::Error);
    EXPECT_FALSE(std::filesystem::exists(dir / "tex.glb"));
}
