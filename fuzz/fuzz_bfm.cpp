// Basel Face Model 2017 / statismo HDF5, read through a file as the HDF5 library requires.
#include "fuzz_input.h"
#include "morph/bfm_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "model.h5");
    fuzz::expect_success_or_error([&] { (void)morph::read_bfm2017(path); });
    return 0;
}
