// End-to-end tests of `facesynth synth`: byte-identical outputs whatever the threads and shards,
// resume after SIGKILL, refusing a folder made with another config, WebDataset tars and COCO JSON.
// They run the real CLI on the toy model (written to a .fsm file) at 64x64.
#include "common/test_data.h"
#include "common/toy_model.h"
#include "morph/atomic_file.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "morph/random.h"
#include "morph/regions.h"
#include "synth/tar.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <csignal>
#include <map>
#include <set>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace facesynth::synth {
namespace {

namespace fs = std::filesystem;

const fs::path& toy_model_file() {
    static const fs::path path = [] {
        // One folder per test process: ctest runs the cases of this file in parallel processes,
        // and a shared folder would be wiped by one while another reads its model.
        const auto dir = testkit::fresh_temp_dir("synth_toy_model_" + std::to_string(::getpid()));
        write_model(testkit::make_toy_model(), dir / "toy.fsm");
        return dir / "toy.fsm";
    }();
    return path;
}

// The toy model with region labels: hair above y = 60 mm, the rest skin.
const fs::path& labelled_toy_model_file() {
    static const fs::path path = [] {
        const auto dir = testkit::fresh_temp_dir("synth_labelled_toy_model");
        MorphableModel toy = testkit::make_toy_model();
        const auto mean = as_points(toy.shape.mean);
        for (int v = 0; v < toy.num_vertices(); ++v)
            toy.vertex_labels.push_back(static_cast<std::uint8_t>(mean(1, v) > 60.0f ? Region::kHair : Region::kSkin));
        write_model(toy, dir / "toy.fsm");
        return dir / "toy.fsm";
    }();
    return path;
}

std::string base_args(int count) {
    return " --model " + toy_model_file().string() + " -n " + std::to_string(count) +
           " --size 64 --seed 5 --format folder,wds,coco --set output.wds_shard_size=5 --quiet";
}

int synth(const std::string& args, std::string* output = nullptr) {
    return testkit::run_command(testkit::cli_path().string() + " synth" + args, output);
}

// Every file under `dir` (relative path -> contents), except per-shard manifests and COCO files.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        if (!entry.is_regular_file()) continue;
        const std::string name = entry.path().filename().string();
        if (name.find("-of-") != std::string::npos) continue;
        files[fs::relative(entry.path(), dir).string()] = read_file(entry.path());
    }
    return files;
}

int count_files(const fs::path& dir) {
    std::error_code error;
    int n = 0;
    for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) n += it->path().extension() == ".json";
    return n;
}

void expect_same_files(const std::map<std::string, std::string>& a, const std::map<std::string, std::string>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [name, contents] : a) {
        ASSERT_TRUE(b.count(name)) << name;
        EXPECT_TRUE(b.at(name) == contents) << name << " differs";
    }
}

TEST(SynthCli, OutputsAreIdenticalWhateverThreadsAndShards) {
    const auto dir = testkit::fresh_temp_dir("synth_determinism");
    std::string log;
    const std::string args = base_args(12) + " --set output.labels=true";
    ASSERT_EQ(synth(" -o " + (dir / "one").string() + args + " --threads 1", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "two").string() + args + " --threads 2", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "sharded").string() + args + " --threads 1 --shard 1/2", &log), 0) << log;
    ASSERT_EQ(synth(" -o " + (dir / "sharded").string() + args + " --threads 2 --shard 0/2", &log), 0) << log;
    ASSERT_EQ(synth(" merge " + (dir / "sharded").string() + " --quiet", &log), 0) << log;

    const auto one = snapshot(dir / "one");
    EXPECT_EQ(one.count("images/s00000011.png"), 1u);
    EXPECT_EQ(one.count("landmarks/s00000011.pts"), 1u);
    EXPECT_EQ(one.count("meta/s00000011.json"), 1u);
    EXPECT_EQ(one.count("labels/s00000011.png"), 1u);
    EXPECT_EQ(one.count("shard-000002.tar"), 1u);
    EXPECT_EQ(one.count("manifest.jsonl"), 1u);
    EXPECT_EQ(one.count("coco.json"), 1u);
    expect_same_files(one, snapshot(dir / "two"));
    expect_same_files(one, snapshot(dir / "sharded"));
}

TEST(SynthCli, MetaCarriesGroundTruthConsistentWithPts) {
    const auto dir = testkit::fresh_temp_dir("synth_meta");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(3) + " --threads 1", &log), 0) << log;
    const auto meta = nlohmann::json::parse(read_file(dir / "meta" / "s00000001.json"));
    for (const char* key : {"key", "index", "seed", "model_name", "model_checksum", "alpha", "psi", "beta", "rotation", "yaw", "pitch", "roll",
                            "translation", "intrinsics", "image_width", "image_height", "lighting", "background", "landmark_mode",
                            "landmarks", "visibility", "landmarks_fixed", "landmarks_contour", "landmarks_3d_fixed", "bbox"})
        EXPECT_TRUE(meta.contains(key)) << key;
    EXPECT_EQ(meta["index"], 1);
    EXPECT_EQ(meta["landmarks"].size(), 68u);
    const auto pts = read_pts(dir / "landmarks" / "s00000001.pts");
    ASSERT_EQ(pts.cols(), 68);
    for (int i = 0; i < 68; ++i) {
        EXPECT_NEAR(pts(0, i), meta["landmarks"][static_cast<std::size_t>(i)][0].get<double>(), 1e-3);
        EXPECT_NEAR(pts(1, i), meta["landmarks"][static_cast<std::size_t>(i)][1].get<double>(), 1e-3);
    }
    const auto manifest = read_file(dir / "manifest.jsonl");
    EXPECT_EQ(std::count(manifest.begin(), manifest.end(), '\n'), 3);
}

TEST(SynthCli, ResumesAfterSigkillWithoutPartialOrDuplicateFiles) {
    const auto dir = testkit::fresh_temp_dir("synth_resume");
    const int count = 60;
    std::string log;
    ASSERT_EQ(synth(" -o " + (dir / "clean").string() + base_args(count) + " --threads 2", &log), 0) << log;
    const fs::path out = dir / "killed";
    const std::string args = " synth -o " + out.string() + base_args(count) + " --threads 2";
    Rng rng(2024, 0, 0);
    int killed_mid_run = 0;
    for (int attempt = 0; attempt < 4; ++attempt) {
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            ::execl("/bin/sh", "sh", "-c", ("exec " + testkit::cli_path().string() + args + " >/dev/null 2>&1").c_str(), nullptr);
            ::_exit(127);
        }
        // Kill once a random number of samples exist (so the kill lands mid-run on any machine
        // speed), after a further random few milliseconds; the first attempt kills at startup.
        const int target = attempt == 0 ? 0 : rng.uniform_int(1, count / 2);
        int status = 0;
        bool exited = false;
        while (!exited && count_files(out / "meta") < target) {
            exited = ::waitpid(pid, &status, WNOHANG) == pid;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(rng.uniform_int(0, 8)));
        if (!exited) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
        }
        killed_mid_run += count_files(out / "meta") < count;
    }
    EXPECT_GE(killed_mid_run, 3);
    ASSERT_EQ(testkit::run_command(testkit::cli_path().string() + args, &log), 0) << log;
    for (const auto& entry : fs::recursive_directory_iterator(out))
        EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
    expect_same_files(snapshot(dir / "clean"), snapshot(out));
}

TEST(SynthCli, RefusesAFolderMadeWithAnotherConfigUnlessOverwrite) {
    const auto dir = testkit::fresh_temp_dir("synth_refuse");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(2), &log), 0) << log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(2) + " --set pose.yaw.max=10", &log), 1);
    EXPECT_NE(log.find("different config"), std::string::npos) << log;
    EXPECT_NE(log.find("pose/yaw/max"), std::string::npos) << log;
    // A larger count extends the same dataset.
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(3), &log), 0) << log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(2) + " --set pose.yaw.max=10 --overwrite", &log), 0) << log;
    EXPECT_FALSE(fs::exists(dir / "meta" / "s00000002.json"));
}

TEST(SynthCli, UnknownConfigKeyIsAnErrorNamingIt) {
    const auto dir = testkit::fresh_temp_dir("synth_unknown_key");
    std::string log;
    EXPECT_EQ(synth(" -o " + dir.string() + base_args(1) + " --set pose.yaww.max=3", &log), 1);
    EXPECT_NE(log.find("unknown config key 'pose.yaww.max'"), std::string::npos) << log;
    write_file_atomically(dir / "c.toml", "[lighting]\nshadowz = true\n");
    EXPECT_EQ(synth(" -o " + (dir / "out").string() + base_args(1) + " -c " + (dir / "c.toml").string(), &log), 1);
    EXPECT_NE(log.find("lighting.shadowz"), std::string::npos) << log;
    EXPECT_NE(log.find("c.toml"), std::string::npos) << log;
    EXPECT_EQ(synth(" --count 2", &log), 2) << log;  // no --out: usage error
}

TEST(SynthCli, WebDatasetTarsHoldEachSampleInOrder) {
    const auto dir = testkit::fresh_temp_dir("synth_wds");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(7) + " --format wds", &log), 0) << log;
    EXPECT_FALSE(fs::exists(dir / "images"));  // wds only: per-sample files are not kept
    const auto first = list_tar(dir / "shard-000000.tar");
    ASSERT_EQ(first.size(), 15u);
    EXPECT_EQ(first[0].name, "s00000000.png");
    EXPECT_EQ(first[1].name, "s00000000.pts");
    EXPECT_EQ(first[2].name, "s00000000.json");
    EXPECT_EQ(first[14].name, "s00000004.json");
    for (const auto& entry : first) EXPECT_GT(entry.size, 0u);
    EXPECT_EQ(list_tar(dir / "shard-000001.tar").size(), 6u);
}

TEST(SynthCli, LabelMapsHoldTheModelsRegionIds) {
    const auto dir = testkit::fresh_temp_dir("synth_labels");
    std::string log;
    const std::string args = " --model " + labelled_toy_model_file().string() +
                             " -n 4 --size 64 --seed 5 --format folder,wds --set output.labels=true --set output.mask=true"
                             " --set render.msaa_samples=0 --quiet";
    ASSERT_EQ(synth(" -o " + dir.string() + args, &log), 0) << log;
    for (int i = 0; i < 4; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        const cv::Mat labels = cv::imread((dir / "labels" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        const cv::Mat mask = cv::imread((dir / "mask" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        ASSERT_EQ(labels.type(), CV_8UC1) << key;
        ASSERT_EQ(labels.size(), mask.size()) << key;
        int skin = 0, hair = 0;
        for (int y = 0; y < labels.rows; ++y)
            for (int x = 0; x < labels.cols; ++x) {
                const int id = labels.at<std::uint8_t>(y, x);
                ASSERT_TRUE(id == 0 || id == static_cast<int>(Region::kSkin) || id == static_cast<int>(Region::kHair)) << key << " id " << id;
                EXPECT_EQ(id != 0, mask.at<std::uint8_t>(y, x) != 0) << key << " at " << x << "," << y;  // no MSAA: same coverage
                skin += id == static_cast<int>(Region::kSkin);
                hair += id == static_cast<int>(Region::kHair);
            }
        EXPECT_GT(skin, 100) << key;
        EXPECT_GT(hair, 0) << key;  // the top of the toy head shows at every pose
    }
    const auto members = list_tar(dir / "shard-000000.tar");
    EXPECT_TRUE(std::any_of(members.begin(), members.end(), [](const TarEntry& e) { return e.name == "s00000003.labels.png"; }));
}

TEST(SynthCli, UvTexturesComeFromTheFolderSkippingUnreadableOnes) {
    const auto dir = testkit::fresh_temp_dir("synth_textures");
    const fs::path textures = dir / "textures";
    fs::create_directories(textures);
    // Pure red, green and blue maps (BGR on disk), and a file that is no image.
    const std::map<std::string, cv::Scalar> maps = {{"red.png", {0, 0, 255}}, {"green.png", {0, 255, 0}}, {"blue.png", {255, 0, 0}}};
    for (const auto& [name, bgr] : maps) ASSERT_TRUE(cv::imwrite((textures / name).string(), cv::Mat(32, 32, CV_8UC3, bgr)));
    write_file_atomically(textures / "broken.png", "not a png");
    std::string log;
    const std::string args = base_args(6) + " --format folder --set output.mask=true --set albedo.texture_folder=" + textures.string();
    ASSERT_EQ(synth(" -o " + (dir / "out").string() + args, &log), 0) << log;
    EXPECT_NE(log.find("broken.png"), std::string::npos) << log;  // the warning names the skipped file
    std::set<std::string> used;
    for (int i = 0; i < 6; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        const auto meta = testkit::read_json(dir / "out" / "meta" / (key + ".json"));
        ASSERT_TRUE(meta["texture"].is_string()) << key;
        const std::string name = meta["texture"];
        ASSERT_TRUE(maps.count(name)) << key << " " << name;
        used.insert(name);
        // The face takes the map's colour: its channel dominates the covered pixels.
        const cv::Mat image = cv::imread((dir / "out" / "images" / (key + ".png")).string(), cv::IMREAD_COLOR);
        const cv::Mat mask = cv::imread((dir / "out" / "mask" / (key + ".png")).string(), cv::IMREAD_UNCHANGED);
        const cv::Scalar mean = cv::mean(image, mask == 255);
        int channel = 0;
        for (int c = 1; c < 3; ++c)
            if (mean[c] > mean[channel]) channel = c;
        const int expected = name == "blue.png" ? 0 : (name == "green.png" ? 1 : 2);
        EXPECT_EQ(channel, expected) << key << " " << name << " mean BGR " << mean;
    }
    EXPECT_GE(used.size(), 2u);  // the choice varies with the index
    // The same run again picks the same maps (sample i depends only on (seed, i)).
    ASSERT_EQ(synth(" -o " + (dir / "again").string() + args, &log), 0) << log;
    for (int i = 0; i < 6; ++i) {
        const std::string key = "s0000000" + std::to_string(i);
        EXPECT_EQ(testkit::read_json(dir / "again" / "meta" / (key + ".json"))["texture"],
                  testkit::read_json(dir / "out" / "meta" / (key + ".json"))["texture"]) << key;
    }
    // A folder with no readable image is an error naming it.
    fs::create_directories(dir / "empty");
    write_file_atomically(dir / "empty" / "broken.png", "not a png");
    EXPECT_EQ(synth(" -o " + (dir / "none").string() + base_args(1) + " --set albedo.texture_folder=" + (dir / "empty").string(), &log), 1);
    EXPECT_NE(log.find((dir / "empty").string()), std::string::npos) << log;
    EXPECT_NE(log.find("no readable texture images"), std::string::npos) << log;
}

TEST(SynthCli, CocoKeypointsHaveTheExpectedStructure) {
    const auto dir = testkit::fresh_temp_dir("synth_coco");
    std::string log;
    ASSERT_EQ(synth(" -o " + dir.string() + base_args(4) + " --format coco --set pose.yaw.min=60 --set pose.yaw.max=80", &log), 0) << log;
    const auto coco = nlohmann::json::parse(read_file(dir / "coco.json"));
    ASSERT_EQ(coco["images"].size(), 4u);
    ASSERT_EQ(coco["annotations"].size(), 4u);
    ASSERT_EQ(coco["categories"].size(), 1u);
    EXPECT_EQ(coco["categories"][0]["keypoints"].size(), 68u);
    EXPECT_GT(coco["categories"][0]["skeleton"].size(), 60u);
    int hidden = 0;
    for (const auto& annotation : coco["annotations"]) {
        ASSERT_EQ(annotation["keypoints"].size(), 3u * 68u);
        EXPECT_EQ(annotation["bbox"].size(), 4u);
        EXPECT_GT(annotation["bbox"][2].get<double>(), 5.0);
        for (std::size_t k = 2; k < annotation["keypoints"].size(); k += 3) {
            const int v = annotation["keypoints"][k];
            EXPECT_TRUE(v == 0 || v == 1 || v == 2);
            hidden += v == 1;
        }
        const std::string file = coco["images"][annotation["image_id"].get<std::size_t>() - 1]["file_name"];
        EXPECT_TRUE(fs::exists(dir / file)) << file;
    }
    EXPECT_GT(hidden, 0);  // at yaw 60-80 some landmarks are self-occluded
}

}  // namespace
}  // namespace facesynth::synth
