// eos vector<Blendshape> binary.
#include "fuzz_input.h"
#include "morph/eos_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "expression_blendshapes.bin");
    fuzz::expect_success_or_error([&] { (void)morph::read_eos_blendshapes(path); });
    return 0;
}
