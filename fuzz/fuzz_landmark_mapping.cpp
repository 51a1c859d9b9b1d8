// eos TOML landmark mapping (ibug_to_*.txt) and our landmark completion TOML, which shares its
// [landmark_mappings] table.
#include "fuzz_input.h"
#include "morph/eos_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    const auto text = fuzz::as_bytes(data, size);
    const auto path = fuzz::write_input(text, "ibug_to_model.txt");
    fuzz::expect_success_or_error([&] { (void)morph::read_landmark_mapping(path); });
    fuzz::expect_success_or_error([&] { (void)morph::parse_landmark_completion(std::string(text), "completion.toml"); });
    return 0;
}
