// `facesynth model ...` end to end: the real executable, its output files and exit codes
// (0 success, 1 failure with a one-line message, 2 usage error).
#include "morph/mesh_io.h"
#include "morph/model_io.h"

#include "common/test_data.h"
#include "common/toy_model.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

using namespace facesynth;

namespace {

std::string cli() { return testkit::cli_path().string(); }

int run(const std::string& arguments, std::string* output = nullptr) {
    return testkit::run_command(cli() + " " + arguments, output);
}

using facesynth::testkit::read_json;

std::size_t count_lines(const std::string& text) { return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')); }

// A small model file for commands that do not need a real one.
std::filesystem::path toy_model_file(const std::filesystem::path& dir) {
    testkit::ToyModelOptions o;
    o.shape_components = 4;
    o.latitude_steps = 12;
    o.longitude_steps = 16;
    const auto path = dir / "toy.fsm";
    morph::write_model(testkit::make_toy_model(o), path);
    return path;
}

}  // namespace

TEST(CmdModel, InfoJsonOnTheSurreyFolder) {
    FACESYNTH_REQUIRE_SHARED_DATA(sfm, "sfm");
    const auto dir = testkit::fresh_temp_dir("cmd_model_info_sfm");
    std::string output;
    ASSERT_EQ(run("model info --model " + sfm.string() + " --json " + (dir / "info.json").string(), &output), 0) << output;
    EXPECT_NE(output.find("vertices:             3448"), std::string::npos) << output;
    const auto j = read_json(dir / "info.json");
    EXPECT_EQ(j["vertices"], 3448);
    EXPECT_EQ(j["triangles"], 6736);
    EXPECT_EQ(j["shape_components"], 63);
    EXPECT_EQ(j["expression_components"], 6);
    EXPECT_EQ(j["expression_kind"], "blendshapes");
    EXPECT_EQ(j["albedo_components"], 0);
    EXPECT_EQ(j["landmarks"], 68);
    EXPECT_EQ(j["contour_right"], 17);
    EXPECT_EQ(j["symmetric_vertices"], 845);
    EXPECT_EQ(j["units"], "mm");
    EXPECT_LT(j["bbox_min_x"].get<double>(), -50.0);
    EXPECT_GT(j["bbox_max_x"].get<double>(), 50.0);
    EXPECT_EQ(j["checksum"].get<std::string>().size(), 16u);
    // The bare model file: same geometry, no side files.
    ASSERT_EQ(run("model info --model " + (sfm / "sfm_shape_3448.bin").string() + " --json " + (dir / "bin.json").string(), &output), 0)
        << output;
    const auto b = read_json(dir / "bin.json");
    EXPECT_EQ(b["vertices"], 3448);
    EXPECT_EQ(b["shape_components"], 63);
    EXPECT_EQ(b["landmarks"], 0);
}

TEST(CmdModel, ConvertExportAndBuild) {
    const auto dir = testkit::fresh_temp_dir("cmd_model_convert");
    const auto model = toy_model_file(dir);
    std::string output;
    ASSERT_EQ(run("model convert --model " + model.string() + " --out " + (dir / "copy.fsm").string(), &output), 0) << output;
    EXPECT_EQ(morph::read_model(dir / "copy.fsm").checksum(), morph::read_model(model).checksum());

    // Export a few instances, read them back, and build a model from them.
    const auto meshes = dir / "meshes";
    std::filesystem::create_directories(meshes);
    ASSERT_EQ(run("model export --model " + model.string() + " --alpha 1,-0.5 --out " + (meshes / "a.obj").string(), &output), 0) << output;
    ASSERT_EQ(run("model export --model " + model.string() + " --random --seed 3 --out " + (meshes / "b.glb").string(), &output), 0) << output;
    ASSERT_EQ(run("model export --model " + model.string() + " --random --seed 4 --out " + (meshes / "c.glb").string(), &output), 0) << output;
    const morph::Mesh a = morph::read_mesh(meshes / "a.obj");
    const morph::Mesh b = morph::read_mesh(meshes / "b.glb");
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_GT((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.1f);
    // --random is reproducible from the seed.
    ASSERT_EQ(run("model export --model " + model.string() + " --random --seed 3 --out " + (dir / "b_again.glb").string(), &output), 0);
    EXPECT_EQ(morph::read_mesh(dir / "b_again.glb").vertices, b.vertices);

    ASSERT_EQ(run("model build --quiet --meshes " + meshes.string() + " --like " + model.string() + " --out " + (dir / "built.fsm").string(), &output), 0)
        << output;
    const morph::MorphableModel built = morph::read_model(dir / "built.fsm");
    EXPECT_EQ(built.num_vertices(), a.num_vertices());
    EXPECT_EQ(built.num_shape_components(), 2);  // 3 meshes -> at most 2 components
    EXPECT_EQ(built.landmarks.size(), 68u);
    EXPECT_EQ(built.num_albedo_components(), 2);  // the random exports differ in albedo too
}

TEST(CmdModel, ExitCodes) {
    const auto dir = testkit::fresh_temp_dir("cmd_model_exit");
    const auto model = toy_model_file(dir);
    std::string output;
    // Usage errors: exit 2.
    EXPECT_EQ(run("model", &output), 2) << output;
    EXPECT_EQ(run("model info --no-such-option", &output), 2) << output;
    EXPECT_EQ(run("model export --model " + model.string(), &output), 2) << output;  // --out missing
    EXPECT_EQ(run("model export --model " + model.string() + " --out x.ply", &output), 2) << output;
    EXPECT_EQ(run("model export --model " + model.string() + " --alpha 1,zz --out " + (dir / "x.obj").string(), &output), 2) << output;
    EXPECT_EQ(run("model convert --model " + model.string() + " --out x.bin", &output), 2) << output;
    // Failures: exit 1 with one line naming the file.
    EXPECT_EQ(run("model info --model " + (dir / "missing.fsm").string(), &output), 1);
    EXPECT_EQ(count_lines(output), 1u) << output;
    EXPECT_NE(output.find("missing.fsm"), std::string::npos) << output;
    std::ofstream(dir / "broken.fsm") << "garbage";
    EXPECT_EQ(run("model info --model " + (dir / "broken.fsm").string(), &output), 1);
    EXPECT_EQ(count_lines(output), 1u) << output;
    EXPECT_NE(output.find("broken.fsm"), std::string::npos) << output;
    EXPECT_EQ(run("model build --meshes " + dir.string() + " --out " + (dir / "none.fsm").string(), &output), 1);
    EXPECT_EQ(count_lines(output), 1u) << output;
    EXPECT_EQ(run("model export --model " + model.string() + " --alpha 1,1,1,1,1,1,1 --out " + (dir / "x.obj").string(), &output), 1);
    EXPECT_EQ(count_lines(output), 1u) << output;
    EXPECT_FALSE(std::filesystem::exists(dir / "x.obj"));
    // --help works on every command.
    for (const char* command : {"model", "model info", "model export", "model convert", "model build"})
        EXPECT_EQ(run(std::string(command) + " --help", &output), 0) << command;
}

// The figure docs/builtin-model.md gives for the built-in model's colour draws (synth's defaults:
// seed 1, truncation 2), and that albedo.reject_implausible leaves none of them implausible.
TEST(CmdModel, AlbedoCheckMeasuresTheBuiltinModelsImplausibleColourDraws) {
    const auto dir = testkit::fresh_temp_dir("cmd_model_albedo_check");
    std::string output;
    ASSERT_EQ(run("model albedo-check --count 2000 --seed 1 --quiet --json " + (dir / "check.json").string(), &output), 0) << output;
    EXPECT_NE(output.find("implausible:        121 (6.05 %)"), std::string::npos) << output;
    const auto j = read_json(dir / "check.json");
    EXPECT_EQ(j["count"], 2000);
    EXPECT_EQ(j["implausible"], 121);
    EXPECT_EQ(j["too_red"], 116);
    EXPECT_EQ(j["too_dark"], 22);
    EXPECT_EQ(j["too_light"], 0);
    EXPECT_EQ(j["wrong_hue"], 5);
    EXPECT_EQ(j["clamped"], 99);
    EXPECT_TRUE(j["mean_plausible"].get<bool>());
    EXPECT_EQ(j["redrawn"], 121);
    EXPECT_EQ(j["shrunk"], 0);
    EXPECT_EQ(j["implausible_after"], 0);
    EXPECT_EQ(j["implausible_indices"].get<std::string>().rfind("10,29,48,", 0), 0u);  // 29 and 48: the red and the black face of the sheet
}

TEST(CmdModel, AlbedoCheckFindsABrokenColourBasisAndNeedsAColourModel) {
    const auto dir = testkit::fresh_temp_dir("cmd_model_albedo_check_broken");
    testkit::ToyModelOptions o;
    o.shape_components = 4;
    morph::MorphableModel broken = testkit::make_toy_model(o);
    // Each σ moves green by 0.5: above +0.44σ the skin is too red, below -0.4σ greener than red.
    testkit::set_uniform_colour_model(broken, {0.6f, 0.4f, 0.3f}, {0.0f, -0.5f, 0.0f});
    morph::write_model(broken, dir / "broken.fsm");
    std::string output;
    ASSERT_EQ(run("model albedo-check --model " + (dir / "broken.fsm").string() + " --count 300 -q --json " + (dir / "broken.json").string(), &output), 0)
        << output;
    const auto j = read_json(dir / "broken.json");
    EXPECT_GT(j["implausible_share"].get<double>(), 0.5);
    EXPECT_GT(j["too_red"].get<int>(), 60);
    EXPECT_GT(j["wrong_hue"].get<int>(), 60);
    EXPECT_EQ(j["implausible_after"], 0);

    morph::MorphableModel colourless = testkit::make_toy_model(o);
    colourless.albedo.reset();
    morph::write_model(colourless, dir / "colourless.fsm");
    EXPECT_EQ(run("model albedo-check --model " + (dir / "colourless.fsm").string() + " -q", &output), 1) << output;
    EXPECT_NE(output.find("no colour model"), std::string::npos) << output;
}
