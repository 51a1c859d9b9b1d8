// eos reference symmetry list (one 1-based mirror vertex per line), for a 200-vertex model.
#include "fuzz_input.h"
#include "morph/eos_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "reference_symmetry.txt");
    fuzz::expect_success_or_error([&] { (void)morph::read_symmetry(path, 200); });
    return 0;
}
