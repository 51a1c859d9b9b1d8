// Our .fsm model file. The trailing FNV-1a checksum is recomputed over the mutated bytes so that
// the section parser, not only the checksum test, is exercised; a second call reads the input as
// it came (checksum mismatch path).
#include "fuzz_input.h"
#include "morph/model_io.h"

#include <cstring>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    std::string bytes(fuzz::as_bytes(data, size));
    fuzz::expect_success_or_error([&] { (void)morph::read_model(fuzz::write_input(bytes, "raw.fsm")); });
    if (bytes.size() >= 8) {
        const std::uint64_t checksum = fuzz::fnv1a(std::string_view(bytes).substr(0, bytes.size() - 8));
        std::memcpy(bytes.data() + bytes.size() - 8, &checksum, 8);
        fuzz::expect_success_or_error([&] { (void)morph::read_model(fuzz::write_input(bytes, "model.fsm")); });
    }
    return 0;
}
