// The .sdm landmark regressor file. The header's payload size and FNV-1a checksum are recomputed
// over the mutated payload so that the payload parser is exercised too; a second call reads the
// input as it came, and a third the mended input as both members of an ensemble file (train merge)
// read with the ensemble reader, whose own header is then also mutated by the input's first bytes.
#include "fuzz_input.h"
#include "train/model_file.h"

#include <cstdint>
#include <cstring>
#include <string>

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
    fuzz::expect_success_or_error([&] { (void)train::read_sdm_members(fuzz::write_input(bytes, "raw_members.sdm")); });
    std::string ensemble("FSYNSDME", 8);
    const auto append = [&ensemble](const void* value, std::size_t n) { ensemble.append(static_cast<const char*>(value), n); };
    const std::uint32_t version = 1, members = 2;
    const std::uint64_t member_size = bytes.size();
    append(&version, 4);
    append(&members, 4);
    for (int m = 0; m < 2; ++m) {
        append(&member_size, 8);
        ensemble += bytes;
    }
    fuzz::expect_success_or_error([&] { (void)train::read_sdm_members(fuzz::write_input(ensemble, "ensemble.sdm")); });
    if (size >= 1) {
        ensemble[8 + static_cast<std::size_t>(data[0]) % 16] ^= static_cast<char>(size);  // the version, count or first size
        fuzz::expect_success_or_error([&] { (void)train::read_sdm_members(fuzz::write_input(ensemble, "ensemble_header.sdm")); });
    }
    return 0;
}
