// eos file readers: the Surrey model as shipped, synthetic files of every model version, and the
// bad-file matrix (each must throw core::Error naming the file, never crash).
#include "core/atomic_file.h"
#include "core/byte_io.h"
#include "morph/eos_io.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"

#include "common/model_files.h"
#include "common/test_data.h"
#include "common/toy_model.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace facesynth;
using facesynth::testkit::write_bytes;

namespace {

// Expects core::Error whose message names `path`.
void expect_file_error(const std::function<void()>& call, const std::filesystem::path& path) {
    try {
        call();
        ADD_FAILURE() << "no error for " << path;
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << e.what();
    }
}

testkit::ToyModelOptions small_toy() {
    testkit::ToyModelOptions o;
    o.shape_components = 4;
    o.latitude_steps = 12;
    o.longitude_steps = 16;
    return o;
}

}  // namespace

// --- The Surrey model as shipped --------------------------------------------------------------------

TEST(EosIo, SurreyModelCountsAndKnownValues) {
    FACESYNTH_REQUIRE_SHARED_DATA(path, "sfm/sfm_shape_3448.bin");
    const morph::EosModelFile file = morph::read_eos_model(path);
    const morph::MorphableModel& m = file.model;
    EXPECT_EQ(file.version, 1);
    EXPECT_EQ(m.num_vertices(), 3448);
    EXPECT_EQ(m.num_shape_components(), 63);
    EXPECT_EQ(m.triangles.size(), 6736u);
    EXPECT_EQ(m.uv.cols(), 3448);
    EXPECT_FALSE(m.albedo.has_value());
    EXPECT_FALSE(m.expression.has_value());
    EXPECT_NEAR(m.shape.eigenvalues[0], 56502.4f, 0.1f);
    EXPECT_NEAR(m.shape.eigenvalues[1], 29755.4f, 0.1f);
    EXPECT_NEAR(m.shape.eigenvalues[2], 9637.5f, 0.1f);
    EXPECT_NEAR(m.shape.eigenvalues[62], 45.58f, 0.01f);
    EXPECT_GE(m.uv.minCoeff(), 0.0f);
    EXPECT_LE(m.uv.maxCoeff(), 1.0f);
    const Eigen::MatrixXf gram = m.shape.basis.transpose() * m.shape.basis;
    EXPECT_LT((gram - Eigen::MatrixXf::Identity(63, 63)).cwiseAbs().maxCoeff(), 1e-3f);
    // The nose tip (iBUG 31 -> vertex 114) is within 0.5 mm of the most protruding point of the
    // mean (the maximum itself is vertex 3420, 1.4 mm above it).
    const Eigen::Matrix3Xf mean = m.shape_instance({});
    EXPECT_NEAR(mean(2, 114), mean.row(2).maxCoeff(), 0.5f);
    EXPECT_NEAR(mean(0, 114), 0.0f, 1.0f);  // on the midline
}

TEST(EosIo, SurreyBlendshapes) {
    FACESYNTH_REQUIRE_SHARED_DATA(path, "sfm/expression_blendshapes_3448.bin");
    const auto shapes = morph::read_eos_blendshapes(path, 3 * 3448);
    ASSERT_EQ(shapes.size(), 6u);
    const char* names[] = {"anger", "disgust", "fear", "happiness", "sadness", "surprise"};
    for (std::size_t i = 0; i < 6; ++i) {
        EXPECT_EQ(shapes[i].name, names[i]);
        EXPECT_GT(shapes[i].offsets.cwiseAbs().maxCoeff(), 1.0f) << names[i];  // mm-sized deformations
    }
    EXPECT_THROW((void)morph::read_eos_blendshapes(path, 3 * 100), core::Error);
}

TEST(EosIo, SurreySideFiles) {
    FACESYNTH_REQUIRE_SHARED_DATA(dir, "sfm");
    const morph::LandmarkMapping mapping = morph::read_landmark_mapping(dir / "ibug_to_sfm.txt");
    EXPECT_EQ(mapping.size(), 50u);
    EXPECT_EQ(mapping.at(31), 114);
    EXPECT_EQ(mapping.at(9), 33);
    EXPECT_FALSE(mapping.contains(1));
    EXPECT_FALSE(mapping.contains(61));
    const morph::ContourChains chains = morph::read_model_contours(dir / "sfm_model_contours.json");
    ASSERT_EQ(chains.right.size(), 17u);
    ASSERT_EQ(chains.left.size(), 17u);
    EXPECT_EQ(chains.right.front(), 380);
    EXPECT_EQ(chains.left.back(), 465);
    const std::vector<int> symmetry = morph::read_symmetry(dir / "sfm_reference_symmetry.txt", 3448);
    ASSERT_EQ(symmetry.size(), 3448u);
    EXPECT_EQ(symmetry[0], 444);  // line 1 says 445, 1-based
    EXPECT_EQ(symmetry[844], 435);
    EXPECT_EQ(symmetry[845], -1);
}

TEST(EosIo, SurreyFolderLoadsEverythingWith68Landmarks) {
    FACESYNTH_REQUIRE_SHARED_DATA(dir, "sfm");
    const morph::MorphableModel m = morph::load_model(dir.string());
    ASSERT_EQ(m.landmarks.size(), 68u);
    EXPECT_EQ(m.landmarks[30].vertices[0], 114);  // iBUG 31, nose tip
    EXPECT_EQ(m.num_expression_components(), 6);
    EXPECT_EQ(m.contour.right.size(), 17u);
    EXPECT_EQ(m.symmetry.size(), 3448u);
    const Eigen::Matrix3Xf lm = m.landmark_positions(m.shape_instance({}));
    // Completed jaw points mirror each other and descend from eye level to the chin.
    const auto mirror = morph::ibug_mirror_pairs();
    for (int i = 0; i < 17; ++i) {
        const int j = mirror[static_cast<std::size_t>(i)];
        EXPECT_NEAR(lm(0, i), -lm(0, j), 3.0f) << "jaw point " << i + 1;
        EXPECT_NEAR(lm(1, i), lm(1, j), 3.0f) << "jaw point " << i + 1;
    }
    for (int i = 0; i < 8; ++i) EXPECT_GT(lm(1, i), lm(1, i + 1)) << "jaw point " << i + 1 << " not above the next";
    // Point 1 sits a little above the eye line (as on near-frontal 300-W faces), below the brow.
    EXPECT_GT(lm(1, 0), lm(1, morph::kRightEyeOuterCorner));
    EXPECT_LT(lm(1, 0), lm(1, 17));
    // Inner mouth corners lie between the outer corners and the inner lip points, at lip height.
    EXPECT_GT(lm(0, 60), lm(0, 48));
    EXPECT_LT(lm(0, 60), lm(0, 61));
    EXPECT_LT(lm(0, 64), lm(0, 54));
    EXPECT_GT(lm(0, 64), lm(0, 63));
    EXPECT_NEAR(lm(1, 60), lm(1, 48), 3.0f);
}

TEST(EosIo, CompletionDataMatchesTheSurreyMesh) {
    const morph::LandmarkCompletion& c = morph::sfm_landmark_completion();
    EXPECT_EQ(c.model_vertices, 3448);
    EXPECT_EQ(c.model_triangles, 6736);
    EXPECT_EQ(c.mapping.size(), 18u);
    for (int id : {1, 2, 3, 4, 5, 6, 7, 8, 10, 11, 12, 13, 14, 15, 16, 17, 61, 65}) EXPECT_TRUE(c.mapping.contains(id)) << id;
}

// --- Synthetic files of every version ------------------------------------------------------------

TEST(EosIo, ReadsVersionsOneToFour) {
    const auto dir = testkit::fresh_temp_dir("eos_versions");
    morph::MorphableModel toy = testkit::make_toy_model(small_toy());
    for (std::uint32_t version = 1; version <= 4; ++version) {
        const auto path = dir / ("v" + std::to_string(version) + ".bin");
        write_bytes(path, testkit::eos_model_bytes(toy, version));
        const morph::EosModelFile file = morph::read_eos_model(path);
        EXPECT_EQ(file.version, static_cast<int>(version));
        EXPECT_EQ(file.model.shape.mean, toy.shape.mean);
        EXPECT_EQ(file.model.shape.basis, toy.shape.basis);
        EXPECT_EQ(file.model.triangles, toy.triangles);
        EXPECT_TRUE(file.model.uv.isApprox(toy.uv));
        ASSERT_TRUE(file.model.albedo.has_value());
        EXPECT_EQ(file.model.albedo->mean, toy.albedo->mean);
        EXPECT_EQ(file.model.expression.has_value(), version >= 2);
        if (version >= 2) {
            EXPECT_EQ(file.model.num_expression_components(), toy.num_expression_components());
        }
        EXPECT_EQ(file.landmarks.size(), version >= 3 ? 68u : 0u);
        // A lone model file with a complete iBUG map gets its 68 landmarks.
        EXPECT_EQ(morph::load_model(path.string()).landmarks.size(), version >= 3 ? 68u : 0u);
    }
    // The PCA expression alternative of the variant.
    toy.expression = toy.shape;
    const auto path = dir / "pca_expression.bin";
    write_bytes(path, testkit::eos_model_bytes(toy, 2));
    const morph::EosModelFile file = morph::read_eos_model(path);
    ASSERT_TRUE(std::holds_alternative<morph::PcaModel>(*file.model.expression));
    EXPECT_EQ(std::get<morph::PcaModel>(*file.model.expression).basis, toy.shape.basis);
}

// --- Bad files -----------------------------------------------------------------------------------

TEST(EosIo, BadModelFilesFailWithTheFileName) {
    const auto dir = testkit::fresh_temp_dir("eos_bad");
    const morph::MorphableModel toy = testkit::make_toy_model(small_toy());
    const std::string good = testkit::eos_model_bytes(toy, 3);
    const auto path = dir / "bad_model.bin";
    const auto expect_bad = [&](const std::string& bytes, const char* what) {
        SCOPED_TRACE(what);
        write_bytes(path, bytes);
        expect_file_error([&] { (void)morph::read_eos_model(path); }, path);
    };
    expect_bad("", "empty");
    for (std::size_t cut : {std::size_t{2}, std::size_t{6}, std::size_t{13}, good.size() / 3, good.size() / 2, good.size() - 1})
        expect_bad(good.substr(0, cut), "truncated");
    for (std::uint32_t version : {0u, 5u, 0x01000000u}) {
        std::string bytes = good;
        std::memcpy(bytes.data(), &version, 4);
        expect_bad(bytes, "wrong version");
    }
    {
        std::string bytes = good;
        const float nan = std::numeric_limits<float>::quiet_NaN();
        std::memcpy(bytes.data() + 4 + 8 + 4 * 5, &nan, 4);  // a value of the shape mean
        expect_bad(bytes, "NaN");
    }
    for (std::int32_t rows : {std::int32_t{-3}, std::numeric_limits<std::int32_t>::max()}) {
        std::string bytes = good;
        std::memcpy(bytes.data() + 4, &rows, 4);
        expect_bad(bytes, "huge or negative dimension");
    }
    {
        std::string bytes = good;
        const std::int32_t huge = 1 << 30;
        std::memcpy(bytes.data() + 4 + 4, &huge, 4);  // mean cols
        expect_bad(bytes, "huge column count");
    }
    expect_bad(good + "xx", "trailing bytes");
    {
        // A triangle list count far beyond the file (the count follows the shape model's three matrices).
        std::string bytes = good;
        const std::size_t triangle_count_offset = 4 + 3 * 8 + sizeof(float) * static_cast<std::size_t>(
            toy.shape.mean.size() + toy.shape.basis.size() + toy.shape.eigenvalues.size());
        const std::uint64_t huge_count = std::uint64_t{1} << 60;
        std::memcpy(bytes.data() + triangle_count_offset, &huge_count, 8);
        expect_bad(bytes, "huge triangle count");
    }
    expect_file_error([&] { (void)morph::read_eos_model(dir / "missing.bin"); }, dir / "missing.bin");
}

TEST(EosIo, BadBlendshapeFiles) {
    const auto dir = testkit::fresh_temp_dir("eos_bad_blendshapes");
    const std::string good =
        testkit::eos_blendshape_bytes({{"smile", Eigen::VectorXf::Ones(30)}, {"frown", Eigen::VectorXf::Ones(30)}});
    const auto path = dir / "bad_blendshapes.bin";
    write_bytes(path, good);
    EXPECT_EQ(morph::read_eos_blendshapes(path, 30).size(), 2u);
    for (const std::string& bytes : {std::string(), good.substr(0, 7), good.substr(0, 20),
                                     good.substr(0, good.size() - 4), good + "z"}) {
        write_bytes(path, bytes);
        expect_file_error([&] { (void)morph::read_eos_blendshapes(path); }, path);
    }
    std::string huge = good;
    const std::uint64_t count = std::uint64_t{1} << 62;
    std::memcpy(huge.data(), &count, 8);
    write_bytes(path, huge);
    expect_file_error([&] { (void)morph::read_eos_blendshapes(path); }, path);
    std::string nan = good;
    const float value = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(nan.data() + 8 + 8 + 5 + 8 + 4, &value, 4);
    write_bytes(path, nan);
    expect_file_error([&] { (void)morph::read_eos_blendshapes(path); }, path);
}

TEST(EosIo, BadSideFiles) {
    const auto dir = testkit::fresh_temp_dir("eos_bad_side");
    const auto mapping = dir / "ibug_to_bad.txt";
    for (const std::string& text : {std::string(), std::string("[landmark_mappings]\n31 = \n"),
                                    std::string("[other]\n1 = 2\n"), std::string("[landmark_mappings]\nnose = 3\n"),
                                    std::string("[landmark_mappings]\n99 = 3\n"), std::string("[landmark_mappings]\n9 = \"x\"\n")}) {
        write_bytes(mapping, text);
        expect_file_error([&] { (void)morph::read_landmark_mapping(mapping); }, mapping);
    }
    const auto contours = dir / "bad_contours.json";
    for (const std::string& text : {std::string(), std::string("{"), std::string("{\"model_contour\": {}}"),
                                    std::string("{\"model_contour\": {\"right_contour\": [1, -2], \"left_contour\": []}}")}) {
        write_bytes(contours, text);
        expect_file_error([&] { (void)morph::read_model_contours(contours); }, contours);
    }
    const auto symmetry = dir / "bad_symmetry.txt";
    for (const std::string& text : {std::string(), std::string("2\nx\n"), std::string("0\n"), std::string("1\n2\n3\n4\n")}) {
        write_bytes(symmetry, text);
        expect_file_error([&] { (void)morph::read_symmetry(symmetry, 3); }, symmetry);
    }
    EXPECT_THROW((void)morph::parse_landmark_completion("model_vertices = 10\nmodel_triangles = 1\n[landmark_mappings]\n1 = 10\n", "c.toml"), core::Error);
    // Fuzzer finding (fuzz_landmark_mapping): an empty completion table, or one without a model
    // size, escaped as toml11's std::out_of_range instead of an error naming the file.
    for (const std::string text : {"", "model_vertices = 10\n[landmark_mappings]\n1 = 3\n"}) {
        try {
            (void)morph::parse_landmark_completion(text, "c.toml");
            ADD_FAILURE() << "accepted '" << text << "'";
        } catch (const core::Error& e) {
            EXPECT_NE(std::string(e.what()).find("c.toml: missing key"), std::string::npos) << e.what();
        }
    }
}

// --- Kept fuzzer finding -----------------------------------------------------------------------------

TEST(EosIo, KeptTomlFuzzFindingIsRefusedByTheMappingReaderNamingTheFileAndLine) {
    // fuzz_synth_config: toml11 3.7 read past its buffer (heap-buffer-overflow in
    // location::reset) on a literal string holding invalid UTF-8. core/toml_file.h refuses the
    // bytes first.
    const std::filesystem::path kept =
        testkit::test_files_dir() / "fuzz_regressions" / "synth_config-toml11-heap-overflow-3ea07958.toml";
    ASSERT_TRUE(std::filesystem::exists(kept)) << kept;
    const std::string message = testkit::error_message_of([&] { (void)morph::read_landmark_mapping(kept); });
    EXPECT_NE(message.find(kept.filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find("line 2, byte 9: not valid UTF-8"), std::string::npos) << message;
    const std::string text = core::read_file(kept);
    const std::string completion = testkit::error_message_of([&] { (void)morph::parse_landmark_completion(text, "kept.toml"); });
    EXPECT_NE(completion.find("kept.toml: line 2"), std::string::npos) << completion;
}
