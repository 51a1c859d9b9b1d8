// Generates synth samples in memory, as `facesynth synth` would write them, without touching disk:
// image, landmarks (both jaw modes) and every ground-truth parameter per sample.
//   dataset_in_memory [COUNT] [SEED] [KEY=VALUE ...]   (keys as in `facesynth synth defaults`)
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

using namespace facesynth;

int main(int argc, char** argv) try {
    const int count = argc > 1 ? std::stoi(argv[1]) : 8;
    synth::SynthConfig config;
    config.seed = argc > 2 ? std::stoull(argv[2]) : 1;
    for (int i = 3; i < argc; ++i) synth::apply_override(config, argv[i]);
    synth::validate(config);

    const morph::MorphableModel model = morph::load_model(config.model);
    const synth::ImageLibrary no_images;  // procedural backgrounds, model colours (no texture bank)
    synth::SampleGenerator generator(config, model, no_images, no_images, render::RendererOptions{});

    // Sample i depends only on (seed, i): any subset, in any order, on any thread gives the same.
    for (int i = 0; i < count; ++i) {
        const synth::Sample sample = generator.generate(i);
        int visible = 0;
        for (const int v : sample.labels.visible_contour) visible += v;
        std::printf("sample %d: %dx%d, yaw %+.1f° pitch %+.1f°, %d of 68 landmarks visible, nose tip at (%.1f, %.1f)\n", i,
                    sample.image.cols, sample.image.rows, sample.spec.angles.yaw, sample.spec.angles.pitch, visible,
                    sample.labels.landmarks_contour(0, 30), sample.labels.landmarks_contour(1, 30));
    }
    return 0;
} catch (const std::logic_error&) {  // std::stoi and friends: not a number
    std::fprintf(stderr, "dataset_in_memory: COUNT and SEED must be numbers\n");
    return 2;
} catch (const std::exception& e) {
    std::fprintf(stderr, "dataset_in_memory: %s\n", e.what());
    return 1;
}
