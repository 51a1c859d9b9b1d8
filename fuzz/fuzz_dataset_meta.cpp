// Files of a dataset folder written by others, as the synth commands read them: a per-sample meta
// JSON (meta/KEY.json) through `synth merge`'s COCO export and `synth sheet`'s contact sheet (with a
// real 48x48 image beside it, so the landmark drawing is reached), dataset.json's configuration as
// `synth` resume and merge read it, and a shard manifest line by line through `synth merge`.
// (`eval fit --data` has its own meta reader in fit/, covered by its unit tests: linking fit/ would
// bring Ceres into this build.)
#include "fuzz_input.h"
#include "core/atomic_file.h"
#include "synth/config.h"
#include "synth/dataset.h"
#include "synth/scene.h"
#include "synth/sheet.h"

#include <opencv2/imgcodecs.hpp>

namespace {

namespace fs = std::filesystem;
using namespace facesynth;

// A folder with a valid two-sample dataset.json (folder format) and sample 0's image.
fs::path dataset_with_image() {
    static const fs::path dir = [] {
        auto d = fuzz::scratch_dir() / "dataset";
        fs::create_directories(d / "images");
        cv::imwrite((d / "images" / (synth::sample_key(0) + ".png")).string(), cv::Mat(48, 48, CV_8UC3, cv::Scalar(90, 120, 150)));
        synth::SynthConfig config;
        config.count = 2;
        config.output.formats = "folder";
        core::write_file_atomically(d / "dataset.json", nlohmann::json{{"config", synth::to_json(config)}}.dump());
        return d;
    }();
    return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto bytes = fuzz::as_bytes(data, size);
    const auto dataset = dataset_with_image();
    (void)fuzz::write_input(bytes, "dataset/meta/" + synth::sample_key(0) + ".json");
    fuzz::expect_success_or_error([&] { (void)synth::coco_from_meta(dataset, {0}, ".png", synth::kSynthCocoDescription); });
    fuzz::expect_success_or_error([&] { (void)synth::contact_sheet(dataset, {.count = 1, .columns = 1, .tile = 32}); });

    const auto manifest = fuzz::write_input(bytes, "dataset/manifest.jsonl");
    const auto merged = fuzz::scratch_dir() / "merged";
    fs::remove_all(merged);
    fuzz::expect_success_or_error([&] { (void)synth::merge_datasets({dataset}, merged); });
    fs::remove(manifest);

    (void)fuzz::write_input(bytes, "config/dataset.json");
    fuzz::expect_success_or_error([&] { (void)synth::read_dataset_config(fuzz::scratch_dir() / "config"); });
    return 0;
}
