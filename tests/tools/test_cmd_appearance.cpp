// `facesynth textures`, `backgrounds`, synth with albedo.texture_bank and `eval realism` end to end on
// renders standing in for photographs, with the bad inputs each must refuse.
#include "common/test_data.h"
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::read_json;
using facesynth::testkit::run_command;

std::string appearance_cli() { return cli_path().string(); }

std::string read_file_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// Near-frontal renders as "photographs": IMAGE.png with IMAGE.pts beside it.
std::string make_photo_folder_arguments(int count) {
    return "-n " + std::to_string(count) +
           " --seed 3 --set pose.yaw.min=-20 --set pose.yaw.max=20 --set pose.pitch.min=-5 --set pose.pitch.max=5"
           " --set camera.face_scale_min=0.3 --set camera.face_scale_max=0.35";
}
fs::path make_photo_folder(const fs::path& dir, int count) { return facesynth::testkit::photo_folder_from_renders(dir, make_photo_folder_arguments(count)); }

// Each test in its own folder: ctest runs them as separate processes, in parallel.
class CmdAppearance : public ::testing::Test {
protected:
    void SetUp() override {
        const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
        dir = fresh_temp_dir("cmd_appearance_" + name);
        photos = make_photo_folder(dir, 6);
    }
    fs::path dir, photos;
};

TEST_F(CmdAppearance, TexturesBuildABankThatSynthDrawsFromDeterministically) {
    const fs::path with_bad = dir / "photos_with_bad";
    fs::create_directories(with_bad);
    for (const auto& entry : fs::directory_iterator(photos)) fs::copy_file(entry.path(), with_bad / entry.path().filename());
    std::ofstream(with_bad / "broken.png") << "not an image";
    std::string out;
    const fs::path bank = dir / "bank";
    const fs::path summary = dir / "textures.json";
    ASSERT_EQ(run_command(appearance_cli() + " textures --photos " + with_bad.string() + " --out " + bank.string() + " --size 128 -q --json " + summary.string(), &out),
              0)
        << out;
    const auto j = read_json(summary);
    EXPECT_EQ(j["photos"], 7);
    EXPECT_EQ(j["rejected_unreadable"], 1);  // broken.png: reported, the others still processed
    EXPECT_GE(j["textures"].get<int>(), 4);
    for (const char* key : {"rejected_pose", "rejected_coverage", "rejected_occlusion", "rejected_fit", "with_pts", "detected"})
        EXPECT_TRUE(j.contains(key)) << key;
    const auto manifest = read_json(bank / "bank.json");
    EXPECT_EQ(manifest["model"], "builtin");
    EXPECT_EQ(manifest["size"], 128);
    bool broken_listed = false;
    for (const auto& r : manifest["rejected"]) broken_listed |= r["source"].get<std::string>().find("broken.png") != std::string::npos;
    EXPECT_TRUE(broken_listed);

    // Sample i is the same with one worker or two, and with the bank it records its texture and gain.
    const std::string synth = appearance_cli() + " synth -n 4 --seed 9 --size 96 -q --set albedo.texture_bank=" + bank.string() +
                              " --set albedo.texture_tone_jitter=0.1";
    ASSERT_EQ(run_command(synth + " --threads 1 -o " + (dir / "s1").string(), &out), 0) << out;
    ASSERT_EQ(run_command(synth + " --threads 2 -o " + (dir / "s2").string(), &out), 0) << out;
    for (int i = 0; i < 4; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        EXPECT_EQ(read_file_bytes(dir / "s1" / "images" / (key + ".png")), read_file_bytes(dir / "s2" / "images" / (key + ".png"))) << key;
        const auto meta = read_json(dir / "s1" / "meta" / (key + ".json"));
        EXPECT_EQ(meta["texture"].get<std::string>().rfind("textures/", 0), 0u);
        EXPECT_NE(meta["texture_gain"], nlohmann::json::array({1.0, 1.0, 1.0}));
    }
    // A bank made for another model is refused, naming the bank.
    auto other = manifest;
    other["model_checksum"] = "0000000000000000";
    const fs::path other_bank = dir / "other_bank";
    fs::copy(bank, other_bank, fs::copy_options::recursive);
    std::ofstream(other_bank / "bank.json") << other.dump();
    EXPECT_EQ(run_command(appearance_cli() + " synth -n 1 -q -o " + (dir / "s3").string() + " --set albedo.texture_bank=" + other_bank.string(), &out), 1);
    EXPECT_NE(out.find("made for model"), std::string::npos) << out;
    EXPECT_NE(out.find("bank.json"), std::string::npos) << out;
    // texture_folder and texture_bank together: a config error naming the key.
    EXPECT_EQ(run_command(appearance_cli() + " synth -n 1 -q -o " + (dir / "s4").string() + " --set albedo.texture_bank=" + bank.string() +
                              " --set albedo.texture_folder=" + photos.string(),
                          &out),
              1);
    EXPECT_NE(out.find("albedo.texture_bank"), std::string::npos) << out;
}

// --fit-lambda: the identity prior of the fits; a weaker one lets the shapes stray further from the mean.
TEST_F(CmdAppearance, TexturesFitLambdaSetsHowFarTheShapesFollowThePoints) {
    std::string out;
    const auto shape_norms = [&](const std::string& name, const std::string& option) {
        const fs::path bank = dir / name;
        EXPECT_EQ(run_command(appearance_cli() + " textures -q --size 64 --photos " + photos.string() + " --out " + bank.string() + option, &out), 0) << out;
        const auto manifest = read_json(bank / "bank.json");
        std::map<std::string, double> norms;
        for (const auto& t : manifest["textures"]) {
            double sum = 0;
            for (const auto& a : t["shape"]) sum += a.get<double>() * a.get<double>();
            norms[t["source"].get<std::string>()] = std::sqrt(sum);
        }
        return std::pair{manifest["settings"]["fit_lambda"].get<double>(), norms};
    };
    const auto [lambda_default, strong] = shape_norms("bank_default", "");
    const auto [lambda_weak, weak] = shape_norms("bank_weak", " --fit-lambda 1");
    EXPECT_EQ(lambda_default, 30);
    EXPECT_EQ(lambda_weak, 1);
    int compared = 0;
    for (const auto& [source, norm] : strong)
        if (weak.count(source)) {
            EXPECT_GT(weak.at(source), norm) << source;
            ++compared;
        }
    EXPECT_GE(compared, 4);
    EXPECT_EQ(run_command(appearance_cli() + " textures -q --fit-lambda -1 --photos " + photos.string() + " --out " + (dir / "bank_bad").string(), &out), 2);
    EXPECT_FALSE(fs::exists(dir / "bank_bad"));
}

// pose.source = texture end to end: the angles `textures` fits to a photograph are in synth's
// convention, so a render drawn at its texture's pose (spread ~0) turns and tilts as the photograph does.
TEST_F(CmdAppearance, TexturePoseRendersFaceTheWayTheirPhotographDoes) {
    std::string out;
    const fs::path turned = dir / "turned";
    const fs::path photos_turned = facesynth::testkit::photo_folder_from_renders(
        turned, "-n 6 --seed 5 --set pose.yaw.min=-35 --set pose.yaw.max=35 --set pose.roll.min=-12 --set pose.roll.max=12"
                " --set pose.pitch.min=-5 --set pose.pitch.max=5 --set camera.face_scale_min=0.3 --set camera.face_scale_max=0.35");
    const fs::path bank = dir / "bank_turned";
    ASSERT_EQ(run_command(appearance_cli() + " textures -q --size 64 --photos " + photos_turned.string() + " --out " + bank.string(), &out), 0) << out;
    ASSERT_EQ(run_command(appearance_cli() + " synth -n 12 --seed 2 --size 96 -q -o " + (dir / "at_pose").string() + " --set albedo.texture_bank=" +
                              bank.string() +
                              " --set pose.source=texture --set pose.yaw.distribution=normal --set pose.yaw.stddev=0.1"
                              " --set pose.pitch.distribution=normal --set pose.pitch.stddev=0.1 --set pose.roll.distribution=normal"
                              " --set pose.roll.stddev=0.1",
                          &out),
              0)
        << out;
    std::map<std::string, std::string> photo_of_texture;  // bank file -> photograph's stem
    const auto manifest = read_json(bank / "bank.json");
    for (const auto& t : manifest["textures"])
        photo_of_texture[t["file"].get<std::string>()] = fs::path(t["source"].get<std::string>()).stem().string();
    bool saw_left = false, saw_right = false;
    for (int i = 0; i < 12; ++i) {
        std::ostringstream key;
        key << 's' << std::setw(8) << std::setfill('0') << i;
        const auto render = read_json(dir / "at_pose" / "meta" / (key.str() + ".json"));
        const std::string stem = photo_of_texture.at(render["texture"].get<std::string>());
        const auto photo = read_json(turned / "renders" / "meta" / (stem + ".json"));
        // The fit recovers the photograph's pose to within a few degrees; a flipped sign would be off by twice the angle.
        EXPECT_NEAR(render["yaw"].get<double>(), photo["yaw"].get<double>(), 5) << "sample " << i << ", photograph " << stem;
        EXPECT_NEAR(render["roll"].get<double>(), photo["roll"].get<double>(), 4) << "sample " << i << ", photograph " << stem;
        saw_left |= photo["yaw"].get<double>() < -10;
        saw_right |= photo["yaw"].get<double>() > 10;
    }
    EXPECT_TRUE(saw_left && saw_right);  // both signs tested
}

TEST_F(CmdAppearance, TexturesRefuseEmptyFoldersAndLeaveNoPartialBank) {
    std::string out;
    fs::create_directories(dir / "empty");
    EXPECT_EQ(run_command(appearance_cli() + " textures --photos " + (dir / "empty").string() + " --out " + (dir / "bank_empty").string(), &out), 1);
    EXPECT_NE(out.find("no images"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "bank_empty"));
    // Every photograph rejected: no bank either.
    EXPECT_EQ(run_command(appearance_cli() + " textures -q --max-yaw 0.001 --photos " + photos.string() + " --out " + (dir / "bank_none").string(), &out), 1);
    EXPECT_NE(out.find("no usable texture"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "bank_none"));
    for (const auto& entry : fs::directory_iterator(dir))
        EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
    EXPECT_EQ(run_command(appearance_cli() + " textures --photos " + photos.string(), &out), 2);  // --out missing: usage error
}

TEST_F(CmdAppearance, BackgroundsCutTheFaceAwayAndNeverOverwrite) {
    std::string out;
    const fs::path backgrounds = dir / "backgrounds";
    const fs::path summary = dir / "backgrounds.json";
    ASSERT_EQ(run_command(appearance_cli() + " backgrounds -q --min-side 24 --photos " + photos.string() + " --out " + backgrounds.string() + " --json " +
                              summary.string(),
                          &out),
              0)
        << out;
    const auto j = read_json(summary);
    EXPECT_GT(j["backgrounds"].get<int>(), 0);
    int files = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(backgrounds)) ++files;
    EXPECT_EQ(files, j["backgrounds"].get<int>());
    EXPECT_EQ(run_command(appearance_cli() + " backgrounds -q --photos " + photos.string() + " --out " + backgrounds.string(), &out), 1);
    EXPECT_NE(out.find("exists already"), std::string::npos) << out;
    // The backgrounds work as synth's image backgrounds.
    EXPECT_EQ(run_command(appearance_cli() + " synth -n 2 --size 64 -q -o " + (dir / "s_bg").string() + " --set background.type=images --set background.folder=" +
                              backgrounds.string(),
                          &out),
              0)
        << out;
}

TEST_F(CmdAppearance, RealismComparesRendersWithPhotographs) {
    std::string out;
    const fs::path summary = dir / "realism.json";
    ASSERT_EQ(run_command(appearance_cli() + " eval realism -q --data " + (dir / "renders").string() + " --photos " + photos.string() + " --json " +
                              summary.string(),
                          &out),
              0)
        << out;
    const auto j = read_json(summary);
    EXPECT_EQ(j["renders_faces"], 6);
    EXPECT_GE(j["photos_faces"].get<int>(), 5);  // the same renders; their yaw fitted from the labels
    for (const char* key : {"nme_ratio", "renders_nme_mean", "renders_failure_rate_008", "photos_nme_median", "renders_bias_x_01", "photos_bias_y_68"})
        EXPECT_TRUE(j.contains(key)) << key;
    if (j["renders_detected"].get<int>() > 0 && j["photos_detected"].get<int>() > 0) {
        EXPECT_GT(j["nme_ratio"].get<double>(), 0.0);
    }
    // The face's grey level: a rendered face is neither black nor white, and the same images measure the same.
    EXPECT_GT(j["renders_face_grey_mean"].get<double>(), 0.1);
    EXPECT_LT(j["renders_face_grey_mean"].get<double>(), 0.9);
    EXPECT_GT(j["renders_face_grey_stddev"].get<double>(), 0.0);
    // The skin under the chin against the face's: some grey, not the face's twice over.
    for (const char* key : {"renders_under_chin_shade", "renders_neck_shade"}) {
        EXPECT_GT(j[key].get<double>(), 0.05) << key;
        EXPECT_LT(j[key].get<double>(), 2.0) << key;
    }
    EXPECT_GT(j["renders_face_detail"].get<double>(), 0.0);  // a rendered face has edges
    if (j["photos_faces"] == j["renders_faces"]) {
        EXPECT_DOUBLE_EQ(j["photos_face_grey_mean"].get<double>(), j["renders_face_grey_mean"].get<double>());
        EXPECT_DOUBLE_EQ(j["photos_face_detail"].get<double>(), j["renders_face_detail"].get<double>());
        EXPECT_DOUBLE_EQ(j["photos_under_chin_shade"].get<double>(), j["renders_under_chin_shade"].get<double>());
    }
    EXPECT_FALSE(j["match_face_size"].get<bool>());
    EXPECT_DOUBLE_EQ(j["photos_scale_median"].get<double>(), 1.0);

    // The same faces rendered at twice the size: twice the face, and with --match-face-size scaled back
    // to the renders' face size, read as the renders are.
    const fs::path big = facesynth::testkit::photo_folder_from_renders(dir / "big", make_photo_folder_arguments(6) + " --size 512");
    const fs::path matched = dir / "realism_matched.json";
    ASSERT_EQ(run_command(appearance_cli() + " eval realism -q --match-face-size --data " + (dir / "renders").string() + " --photos " + big.string() +
                              " --json " + matched.string(),
                          &out),
              0)
        << out;
    const auto m = read_json(matched);
    EXPECT_TRUE(m["match_face_size"].get<bool>());
    EXPECT_NEAR(m["photos_iod_px_median"].get<double>(), 2 * m["renders_iod_px_median"].get<double>(), 0.02 * m["photos_iod_px_median"].get<double>());
    EXPECT_NEAR(m["photos_scale_median"].get<double>(), 0.5, 0.01);
    EXPECT_DOUBLE_EQ(m["renders_iod_px_median"].get<double>(), j["renders_iod_px_median"].get<double>());
    if (m["photos_detected"] == m["renders_detected"] && m["renders_detected"].get<int>() > 0) {
        EXPECT_NEAR(m["photos_nme_mean"].get<double>(), m["renders_nme_mean"].get<double>(), 0.01);
    }
    EXPECT_EQ(run_command(appearance_cli() + " eval realism -q --data " + (dir / "renders").string() + " --max-yaw nan", &out), 2);
    EXPECT_EQ(run_command(appearance_cli() + " eval realism -q --data " + photos.string(), &out), 1);  // no meta: no yaw
    EXPECT_NE(out.find("no render with"), std::string::npos) << out;
}

TEST_F(CmdAppearance, Sim2realRecipeTrainsARegressorOnRendersAlone) {
    std::string out;
    const fs::path model = dir / "sim2real.sdm";
    const std::string script = (facesynth::testkit::source_dir() / "tools" / "sim2real.sh").string();
    const std::string env = "FACESYNTH=" + appearance_cli() + " ";
    ASSERT_EQ(run_command(env + "bash " + script + " --photos " + photos.string() + " --out " + model.string() + " --count 60 --threads 2 --min-side 24", &out), 0)
        << out;
    // The default two seeds: a render set and a model each, joined into one ensemble file (row 91).
    EXPECT_EQ(facesynth::core::read_file(model).substr(0, 8), "FSYNSDME");
    for (const char* seed : {"seed-101", "seed-202"}) EXPECT_TRUE(fs::exists(dir / "sim2real-work" / seed / "model.sdm")) << seed;
    const auto train = read_json(dir / "sim2real-work" / "seed-101" / "train.json");
    EXPECT_EQ(train["stages"], 6);  // the recipe's six stages (docs/results.md row 41)
    EXPECT_EQ(train["hog_cells"], 3);
    EXPECT_EQ(train["augment"], 4);
    EXPECT_EQ(train["realign_stages"], 4);  // the realigned cascade that realign:MODEL runs (row 85)
    const auto meta = read_json(dir / "sim2real-work" / "seed-101" / "train" / "meta" / "s00000000.json");
    EXPECT_EQ(meta["texture"].get<std::string>().rfind("textures/", 0), 0u);  // rendered with the bank
    EXPECT_EQ(meta["background"]["type"], "wallpapers");                       // the default backgrounds
    EXPECT_TRUE(meta["head_parts"].is_object());                                // on a whole head (row 55)
    EXPECT_TRUE(read_json(dir / "sim2real-work" / "bank" / "bank.json")["settings"]["align_features"].get<bool>());
    EXPECT_TRUE(read_json(dir / "sim2real-work" / "bank" / "bank.json")["settings"]["drop_occluders"].get<bool>());
    EXPECT_EQ(read_json(dir / "sim2real-work" / "bank" / "bank.json")["settings"]["fit_lambda"], 3.0);  // row 74
    // The photograph's own light (rows 68-69): kept in the texture, and no synthetic light on the face;
    // the head parts lit with shadows (row 73).
    EXPECT_FALSE(read_json(dir / "sim2real-work" / "bank" / "bank.json")["settings"]["remove_shading"].get<bool>());
    const auto config = read_json(dir / "sim2real-work" / "seed-101" / "train" / "dataset.json")["config"];
    EXPECT_EQ(config["head"]["ambient_occlusion"], 1.0);
    EXPECT_EQ(config["lighting"]["face_light"], "even");
    EXPECT_EQ(config["lighting"]["shadow_probability"], 1.0);
    EXPECT_EQ(config["lighting"]["directional_min"], 1);
    EXPECT_TRUE(meta["lighting"]["lights"].empty());  // the face's light
    EXPECT_FALSE(meta["lighting"]["head_parts"]["lights"].empty());
    EXPECT_EQ(config["pose"]["source"], "texture");  // turned as the texture's photograph (row 69)
    EXPECT_EQ(config["lighting"]["face_luminance_mean"], 0.49);  // exposed for the face (row 71)
    EXPECT_EQ(config["albedo"]["texture_mix_probability"], 0.5);
    // One seed, the photographs' own backgrounds, paths relative to the folder the script is started
    // from (not the checkout it works in): a plain model file.
    fs::remove(model);
    ASSERT_EQ(run_command("cd " + dir.string() + " && " + env + "bash " + script + " --photos " + fs::relative(photos, dir).string() +
                              " --out sim2real.sdm --count 20 --min-side 24 --backgrounds photos --augment 2 --seeds 7", &out), 0)
        << out;
    EXPECT_EQ(facesynth::core::read_file(model).substr(0, 8), std::string("FSYNSDM\0", 8));
    EXPECT_EQ(read_json(dir / "sim2real-work" / "seed-7" / "train.json")["augment"], 2);
    EXPECT_EQ(read_json(dir / "sim2real-work" / "seed-7" / "train" / "meta" / "s00000000.json")["background"]["type"], "images");
    EXPECT_TRUE(fs::exists(dir / "sim2real-work" / "backgrounds"));
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + photos.string() + " --out " + model.string() + " --backgrounds walls", &out), 2);
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + photos.string() + " --out " + model.string() + " --augment 0", &out), 2);
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + photos.string() + " --out " + model.string() + " --seeds 3,3", &out), 2);
    EXPECT_EQ(run_command("bash " + script + " --out " + model.string(), &out), 2);
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + (dir / "missing").string() + " --out " + model.string(), &out), 1);
}

// tools/joined.sh: the renders (sim2real.sh --renders-only), the profiled views and three members trained
// on different data from one photo folder, joined into one ensemble file.
TEST_F(CmdAppearance, JoinedRecipeTrainsThreeMembersOnDifferentDataAndJoinsThem) {
    const fs::path twelve = make_photo_folder(dir / "twelve", 12);  // enough for a validation face at share 0.1
    std::string out;
    const fs::path model = dir / "joined.sdm";
    const fs::path work = dir / "joined-work";
    const std::string script = (facesynth::testkit::source_dir() / "tools" / "joined.sh").string();
    const std::string env = "FACESYNTH=" + appearance_cli() + " ";
    ASSERT_EQ(run_command(env + "bash " + script + " --photos " + twelve.string() + " --out " + model.string() + " --count 20 --threads 2 --hog-cells 2", &out), 0)
        << out;
    EXPECT_EQ(facesynth::core::read_file(model).substr(0, 8), "FSYNSDME");
    const auto photographs = read_json(work / "photographs.json");
    const auto mix = read_json(work / "mix.json");
    const auto mix_profiled = read_json(work / "mix_profiled.json");
    EXPECT_EQ(photographs["augment"], 10);
    EXPECT_EQ(photographs["image_copies"], 3);  // each photograph also as three moved and degraded copies
    EXPECT_EQ(mix["image_copies"], 0);
    EXPECT_EQ(mix["augment"], 4);
    for (const auto* j : {&photographs, &mix, &mix_profiled}) {
        EXPECT_EQ((*j)["hog_cells"], 2);
        EXPECT_EQ((*j)["stages"], 6);
        EXPECT_EQ((*j)["realign_stages"], 4);
    }
    const int photos = photographs["faces"].get<int>();
    EXPECT_EQ(photos, 12);
    EXPECT_EQ(mix["faces"].get<int>(), 20 + 5 * photos);  // the renders and the photographs five times
    const auto views = std::distance(fs::directory_iterator(work / "profiled" / "images"), fs::directory_iterator{});
    EXPECT_GT(views, 8 * photos / 2);  // 8 views per photograph, a few may fail
    EXPECT_EQ(mix_profiled["faces"].get<int>(), mix["faces"].get<int>() + views);
    EXPECT_EQ(read_json(work / "profiled" / "profile.json")["views_per_photo"], 8);
    EXPECT_EQ(read_json(work / "sim2real" / "seed-101" / "train" / "dataset.json")["count"], 20);
    EXPECT_FALSE(fs::exists(work / "sim2real" / "seed-101" / "model.sdm"));  // --renders-only trains nothing

    EXPECT_EQ(run_command("bash " + script + " --out " + model.string(), &out), 2);
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + twelve.string() + " --out " + model.string() + " --hog-cells 9", &out), 2);
    EXPECT_EQ(run_command(env + "bash " + script + " --photos " + (dir / "missing").string() + " --out " + model.string(), &out), 1);
    const std::string sim2real = (facesynth::testkit::source_dir() / "tools" / "sim2real.sh").string();
    EXPECT_EQ(run_command(env + "bash " + sim2real + " --photos " + twelve.string() + " --renders-only --work " + work.string() + " --out x.sdm", &out), 2);
}

TEST_F(CmdAppearance, ConventionsWriteOffsetsThatTrainReadsAndBadOffsetFilesAreNamed) {
    std::string out;
    const fs::path conventions = dir / "conventions.json";
    ASSERT_EQ(run_command(appearance_cli() + " eval conventions -q --photos " + photos.string() + " --json " + conventions.string(), &out), 0) << out;
    const auto j = read_json(conventions);
    EXPECT_EQ(j["faces"], 6);
    for (const char* key : {"mean_x_01", "mean_y_68", "sd_x_18", "skipped_pose", "failed", "depth_measured", "sin_yaw_sd", "depth_34"})
        EXPECT_TRUE(j.contains(key)) << key;
    // Depth is a number per landmark where the yaws spread enough, null otherwise (keys stay the same).
    EXPECT_EQ(j["depth_34"].is_number(), j["depth_measured"].get<bool>());
    EXPECT_EQ(j["depth_measured"].get<bool>(), j["sin_yaw_sd"].get<double>() >= 0.05);
    // The renders' own labels: the model's definitions, so small offsets (the fit's own error).
    EXPECT_LT(std::abs(j["mean_y_18"].get<double>()), 0.05);
    EXPECT_EQ(j["lambda"], 30);
    // A weaker identity prior lets the fits follow the labels closer.
    const fs::path loose = dir / "conventions_loose.json";
    ASSERT_EQ(run_command(appearance_cli() + " eval conventions -q --lambda 0.1 --photos " + photos.string() + " --json " + loose.string(), &out), 0) << out;
    const auto spread = [](const nlohmann::json& study) {
        double sum = 0;
        for (const auto& [key, value] : study.items())
            if (key.rfind("sd_", 0) == 0) sum += value.get<double>();
        return sum;
    };
    EXPECT_EQ(read_json(loose)["lambda"], 0.1);
    EXPECT_LT(spread(read_json(loose)), spread(j));
    const fs::path bad = dir / "bad.json";
    std::ofstream(bad) << R"({"mean_x_01": 0.1})";
    EXPECT_EQ(run_command(appearance_cli() + " train --quiet --data " + (dir / "renders").string() + " --out " + (dir / "m.sdm").string() + " --label-offsets " +
                              bad.string(),
                          &out),
              1);
    EXPECT_NE(out.find("bad.json"), std::string::npos) << out;
    EXPECT_NE(out.find("mean_y_01"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "m.sdm"));
    EXPECT_EQ(run_command(appearance_cli() + " eval conventions -q --photos " + (dir / "nothing").string(), &out), 1);
}

}  // namespace
