// The synth TOML configuration (--config), applied to the defaults and validated as `synth` does.
#include "fuzz_input.h"
#include "synth/config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "config.toml");
    fuzz::expect_success_or_error([&] {
        synth::SynthConfig config;
        synth::apply_toml_file(config, path);
        synth::validate(config);
    });
    return 0;
}
