// eos model contour JSON (model_contour.right_contour / left_contour).
#include "fuzz_input.h"
#include "morph/eos_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "model_contours.json");
    fuzz::expect_success_or_error([&] { (void)morph::read_model_contours(path); });
    return 0;
}
