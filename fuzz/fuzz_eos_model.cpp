// eos MorphableModel binary (cereal), model versions 1-4.
#include "fuzz_input.h"
#include "morph/eos_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "model.bin");
    fuzz::expect_success_or_error([&] { (void)morph::read_eos_model(path); });
    return 0;
}
