// A dataset's per-sample meta JSON (meta/KEY.json), as `synth merge`'s COCO export reads it, and
// dataset.json's configuration, as `synth` resume and merge read it. (`eval fit --data` has its own
// meta reader in fit/, covered by its unit tests: linking fit/ would bring Ceres into this build.)
#include "fuzz_input.h"
#include "synth/dataset.h"
#include "synth/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto bytes = fuzz::as_bytes(data, size);
    const auto meta = fuzz::write_input(bytes, "dataset/meta/" + synth::sample_key(0) + ".json");
    const auto dataset = meta.parent_path().parent_path();
    fuzz::expect_success_or_error([&] { (void)synth::coco_from_meta(dataset, {0}, synth::SynthConfig{}); });
    (void)fuzz::write_input(bytes, "dataset/dataset.json");
    fuzz::expect_success_or_error([&] { (void)synth::read_dataset_config(dataset); });
    return 0;
}
