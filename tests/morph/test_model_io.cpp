// The project's .fsm model format and load_model's dispatch.
#include "core/error.h"
#include "morph/model_io.h"
#include "morph/regions.h"

#include "common/model_files.h"
#include "common/test_data.h"
#include "common/toy_model.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace facesynth;
using facesynth::testkit::write_bytes;

namespace {

std::string read_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}


// Recomputes the trailing FNV-1a so that a deliberately edited file passes the integrity check
// and reaches the field checks.
std::string with_fixed_trailer(std::string bytes) {
    std::uint64_t hash = 14695981039346656037ull;
    for (std::size_t i = 0; i + 8 < bytes.size(); ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * 1099511628211ull;
    std::memcpy(bytes.data() + bytes.size() - 8, &hash, 8);
    return bytes;
}

void expect_model_error_naming(const std::function<void()>& call, const std::filesystem::path& path, const char* what) {
    try {
        call();
        ADD_FAILURE() << "no error: " << what;
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << what << ": " << e.what();
    }
}

testkit::ToyModelOptions small_io_toy() {
    testkit::ToyModelOptions o;
    o.shape_components = 5;
    o.latitude_steps = 12;
    o.longitude_steps = 16;
    return o;
}

void expect_same_model(const morph::MorphableModel& a, const morph::MorphableModel& b) {
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.shape.mean, b.shape.mean);
    EXPECT_EQ(a.shape.basis, b.shape.basis);
    EXPECT_EQ(a.shape.eigenvalues, b.shape.eigenvalues);
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.uv, b.uv);
    EXPECT_EQ(a.albedo.has_value(), b.albedo.has_value());
    if (a.albedo && b.albedo) {
        EXPECT_EQ(a.albedo->basis, b.albedo->basis);
    }
    EXPECT_EQ(a.num_expression_components(), b.num_expression_components());
    ASSERT_EQ(a.landmarks.size(), b.landmarks.size());
    for (std::size_t i = 0; i < a.landmarks.size(); ++i) {
        EXPECT_EQ(a.landmarks[i].vertices, b.landmarks[i].vertices);
        EXPECT_EQ(a.landmarks[i].weights, b.landmarks[i].weights);
    }
    EXPECT_EQ(a.contour.right, b.contour.right);
    EXPECT_EQ(a.contour.left, b.contour.left);
    EXPECT_EQ(a.symmetry, b.symmetry);
    EXPECT_EQ(a.vertex_labels, b.vertex_labels);
    EXPECT_EQ(a.checksum(), b.checksum());  // covers every field, blendshape names included
}

}  // namespace

TEST(ModelIo, FsmRoundTripsEveryField) {
    const auto dir = testkit::fresh_temp_dir("fsm_round_trip");
    morph::MorphableModel toy = testkit::make_toy_model(small_io_toy());
    toy.name = "toy with blendshapes";
    toy.landmarks[5] = morph::SurfacePoint{{1, 2, 3}, {0.2f, 0.3f, 0.5f}};  // a barycentric landmark
    toy.vertex_labels.resize(static_cast<std::size_t>(toy.num_vertices()));
    for (std::size_t i = 0; i < toy.vertex_labels.size(); ++i) toy.vertex_labels[i] = static_cast<std::uint8_t>(i % morph::kNumRegions);
    morph::write_model(toy, dir / "toy.fsm");
    expect_same_model(morph::read_model(dir / "toy.fsm"), toy);

    // The PCA expression alternative, and a model without any optional part.
    toy.expression = toy.shape;
    morph::write_model(toy, dir / "pca.fsm");
    const morph::MorphableModel pca = morph::read_model(dir / "pca.fsm");
    ASSERT_TRUE(std::holds_alternative<morph::PcaModel>(*pca.expression));
    expect_same_model(pca, toy);

    morph::MorphableModel bare;
    bare.name = "bare";
    bare.shape = toy.shape;
    bare.triangles = toy.triangles;
    morph::write_model(bare, dir / "bare.fsm");
    const morph::MorphableModel back = morph::read_model(dir / "bare.fsm");
    expect_same_model(back, bare);
    EXPECT_FALSE(back.expression.has_value());
    EXPECT_FALSE(back.albedo.has_value());
    EXPECT_TRUE(back.vertex_labels.empty());
}

TEST(ModelIo, LoadModelDispatchesByExtensionAndContent) {
    const auto dir = testkit::fresh_temp_dir("fsm_dispatch");
    const morph::MorphableModel toy = testkit::make_toy_model(small_io_toy());
    morph::write_model(toy, dir / "toy.fsm");
    EXPECT_EQ(morph::load_model((dir / "toy.fsm").string()).checksum(), toy.checksum());
    std::filesystem::copy_file(dir / "toy.fsm", dir / "toy.model");  // sniffed by its magic bytes
    EXPECT_EQ(morph::load_model((dir / "toy.model").string()).checksum(), toy.checksum());
    // A folder holding one .fsm loads it.
    const auto folder = dir / "folder";
    std::filesystem::create_directories(folder);
    std::filesystem::copy_file(dir / "toy.fsm", folder / "toy.fsm");
    EXPECT_EQ(morph::load_model(folder.string()).checksum(), toy.checksum());
    std::filesystem::copy_file(dir / "toy.fsm", folder / "second.fsm");
    expect_model_error_naming([&] { (void)morph::load_model(folder.string()); }, folder, "two models in a folder");

    expect_model_error_naming([&] { (void)morph::load_model((dir / "nothing.fsm").string()); }, dir / "nothing.fsm", "missing");
    write_bytes(dir / "notes.txt", "hello");
    expect_model_error_naming([&] { (void)morph::load_model((dir / "notes.txt").string()); }, dir / "notes.txt", "unknown format");
    const auto empty = dir / "empty_folder";
    std::filesystem::create_directories(empty);
    expect_model_error_naming([&] { (void)morph::load_model(empty.string()); }, empty, "folder without a model");
}

TEST(ModelIo, BuiltinLoadsThroughTheSameEntryPoint) {
    const morph::MorphableModel builtin = morph::load_model("builtin");
    EXPECT_GT(builtin.num_vertices(), 0);
    EXPECT_NO_THROW(builtin.validate("builtin"));
}

TEST(ModelIo, BadFsmFilesFailWithTheFileName) {
    const auto dir = testkit::fresh_temp_dir("fsm_bad");
    const morph::MorphableModel toy = testkit::make_toy_model(small_io_toy());
    morph::write_model(toy, dir / "good.fsm");
    const std::string good = read_bytes(dir / "good.fsm");
    const auto path = dir / "bad.fsm";
    const auto expect_bad = [&](const std::string& bytes, const char* what) {
        write_bytes(path, bytes);
        expect_model_error_naming([&] { (void)morph::read_model(path); }, path, what);
    };
    expect_bad("", "empty");
    expect_bad("FSMODEL", "short");
    for (std::size_t cut : {std::size_t{8}, std::size_t{20}, std::size_t{40}, good.size() / 2, good.size() - 1})
        expect_bad(good.substr(0, cut), "truncated");
    {
        std::string bytes = good;
        bytes[1] = 'X';
        expect_bad(bytes, "wrong magic");
    }
    {
        std::string bytes = good;
        const std::uint32_t version = 7;
        std::memcpy(bytes.data() + 8, &version, 4);
        expect_bad(bytes, "wrong version");
    }
    {
        std::string bytes = good;
        bytes[good.size() / 2] ^= 0x5a;
        expect_bad(bytes, "flipped byte");
    }
    expect_bad(good + "x", "trailing byte");
    // Section layout from docs/model-format.md: header 32 bytes, then NAME (tag, size, payload),
    // then SHAP (tag, size, uint32 vertices, uint32 components, mean ...).
    const std::size_t shape_section = 32 + 4 + 8 + toy.name.size();
    const std::size_t shape_payload = shape_section + 12;
    {
        std::string bytes = good;
        const float nan = std::numeric_limits<float>::quiet_NaN();
        std::memcpy(bytes.data() + shape_payload + 8 + 4 * 7, &nan, 4);
        expect_bad(with_fixed_trailer(bytes), "NaN in the mean");
    }
    for (std::uint32_t vertices : {0x7fffffffu, 0xffffffffu}) {
        std::string bytes = good;
        std::memcpy(bytes.data() + shape_payload, &vertices, 4);
        expect_bad(with_fixed_trailer(bytes), "huge vertex count");
    }
    {
        std::string bytes = good;
        const std::uint32_t components = 0xfffffff0u;
        std::memcpy(bytes.data() + shape_payload + 4, &components, 4);
        expect_bad(with_fixed_trailer(bytes), "huge component count");
    }
    {
        std::string bytes = good;
        const std::uint64_t size = std::uint64_t{1} << 62;
        std::memcpy(bytes.data() + shape_section + 4, &size, 8);
        expect_bad(with_fixed_trailer(bytes), "huge section size");
    }
    {
        std::string bytes = good;
        const std::uint32_t sections = 1000;
        std::memcpy(bytes.data() + 12, &sections, 4);
        expect_bad(with_fixed_trailer(bytes), "wrong section count");
    }
    {
        // A stored checksum that does not match the content.
        std::string bytes = good;
        bytes[16] = bytes[16] == '0' ? '1' : '0';
        expect_bad(with_fixed_trailer(bytes), "model checksum mismatch");
    }
}

TEST(ModelIo, WriteRefusesAnInvalidModelAndLeavesNoFile) {
    const auto dir = testkit::fresh_temp_dir("fsm_invalid");
    morph::MorphableModel toy = testkit::make_toy_model(small_io_toy());
    toy.triangles[0][0] = -4;
    EXPECT_THROW(morph::write_model(toy, dir / "broken.fsm"), core::Error);
    EXPECT_FALSE(std::filesystem::exists(dir / "broken.fsm"));
    EXPECT_THROW(morph::write_model(testkit::make_toy_model(small_io_toy()), dir / "no" / "such" / "dir.fsm"), core::Error);
}
