// The view-specific ERT/LBF baseline bundle (train/view_baselines.h). The FNV-1a checksum over
// everything after it is recomputed over the mutated bytes so that the fields behind it are parsed
// too; a second call reads the input as it came. Both methods are asked for, so the method check
// is passed by one of them. The two model files inside are handed on unparsed (dlib and OpenCV read
// them), so they are not part of this harness.
#include "fuzz_input.h"
#include "train/view_baselines.h"

#include <cstring>

namespace {
constexpr std::size_t kChecksumOffset = 8 + 4 + 4;  // magic, version, method
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace facesynth;
    std::string bytes(fuzz::as_bytes(data, size));
    const auto read_both = [](const std::filesystem::path& path) {
        fuzz::expect_success_or_error([&] { (void)train::read_view_baseline_bundle(path, train::BaselineMethod::kErt); });
        fuzz::expect_success_or_error([&] { (void)train::read_view_baseline_bundle(path, train::BaselineMethod::kLbf); });
    };
    read_both(fuzz::write_input(bytes, "raw.bundle"));
    if (bytes.size() >= kChecksumOffset + 8) {
        const std::uint64_t checksum = fuzz::fnv1a(std::string_view(bytes).substr(kChecksumOffset + 8));
        std::memcpy(bytes.data() + kChecksumOffset, &checksum, 8);
        read_both(fuzz::write_input(bytes, "bundle.dat"));
    }
    return 0;
}
