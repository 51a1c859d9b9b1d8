// iBUG .pts landmark files.
#include "fuzz_input.h"
#include "morph/landmarks.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto path = fuzz::write_input(fuzz::as_bytes(data, size), "face.pts");
    fuzz::expect_success_or_error([&] { (void)morph::read_pts(path); });
    return 0;
}
