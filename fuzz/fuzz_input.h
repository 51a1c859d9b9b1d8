#pragma once
// Shared by the libFuzzer harnesses. The readers under test take file paths, so each input is
// written to a scratch file of this process first (TMPDIR, or /tmp). A reader may only answer with
// core::Error: any other exception escapes LLVMFuzzerTestOneInput, and libFuzzer reports it
// as a crash, as it does sanitizer findings, hangs and allocations over -malloc_limit_mb.
#include "core/error.h"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace facesynth::fuzz {

inline std::filesystem::path scratch_dir() {
    static const std::filesystem::path dir = [] {
        auto d = std::filesystem::temp_directory_path() / ("facesynth-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        return d;
    }();
    return dir;
}

// Writes the input to scratch_dir()/name and returns that path.
inline std::filesystem::path write_input(std::string_view bytes, const std::string& name) {
    auto path = scratch_dir() / name;
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return path;
}

inline std::string_view as_bytes(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

// FNV-1a 64, as .fsm and .sdm files use for their checksums: the harnesses recompute it so that
// mutated inputs reach the parsing behind the checksum test.
inline std::uint64_t fnv1a(std::string_view bytes) {
    std::uint64_t hash = 0xcbf29ce484222325ULL;
    for (unsigned char c : bytes) hash = (hash ^ c) * 0x100000001b3ULL;
    return hash;
}

// Runs a reader; core::Error is the expected answer to a bad file.
template <typename Fn>
void expect_success_or_error(Fn&& read) {
    try {
        read();
    } catch (const facesynth::core::Error&) {
    }
}

}  // namespace facesynth::fuzz
