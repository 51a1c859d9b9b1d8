// The .sdm landmark regressor file. The header's payload size and FNV-1a checksum are recomputed
// over the mutated payload so that the payload parser is exercised too; a second call reads the
// input as it came.
#include "fuzz_input.h"
#include "train/model_file.h"

#include <cstring>

namespace {
// magic 8, version 4, six uint32 4·6, box width 8, training checksum 8, faces 4, augment 4.
constexpr std::size_t kPayloadSizeOffset = 8 + 4 + 24 + 8 + 8 + 4 + 4;
constexpr std::size_t kPayloadOffset = kPayloadSizeOffset + 16;
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    std::string bytes(fuzz::as_bytes(data, size));
    fuzz::expect_success_or_error([&] { (void)train::read_sdm_model(fuzz::write_input(bytes, "raw.sdm")); });
    if (bytes.size() >= kPayloadOffset) {
        const std::uint64_t payload_size = bytes.size() - kPayloadOffset;
        const std::uint64_t checksum = fuzz::fnv1a(std::string_view(bytes).substr(kPayloadOffset));
        std::memcpy(bytes.data() + kPayloadSizeOffset, &payload_size, 8);
        std::memcpy(bytes.data() + kPayloadSizeOffset + 8, &checksum, 8);
        fuzz::expect_success_or_error([&] { (void)train::read_sdm_model(fuzz::write_input(bytes, "model.sdm")); });
    }
    return 0;
}
