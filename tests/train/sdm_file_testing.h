#pragma once
// Helpers for the .sdm file tests: rewriting a file's header after editing its payload, and checking
// that reading a file fails with an error naming it.
#include "train/model_file.h"

#include "core/error.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>

namespace facesynth::testkit {

// Sets the format version and makes the payload size and FNV-1a checksum match the bytes again
// (header layout in docs/train.md: version at byte 8, payload size at 60, checksum at 68, payload from 76).
inline void rewrite_sdm_header(std::string& bytes, std::uint32_t version) {
    constexpr std::size_t kPayload = 76;
    std::memcpy(bytes.data() + 8, &version, 4);
    const std::uint64_t payload_size = bytes.size() - kPayload;
    std::memcpy(bytes.data() + 60, &payload_size, 8);
    std::uint64_t hash = 0xcbf29ce484222325ULL;
    for (std::size_t i = kPayload; i < bytes.size(); ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * 0x100000001b3ULL;
    std::memcpy(bytes.data() + 68, &hash, 8);
}

// `read` is the reader under test (default: the one-model reader); `name` what the message must name
// (default: the file).
inline void expect_sdm_error_naming(const std::filesystem::path& path, const std::string& fragment,
                                    const std::function<void(const std::filesystem::path&)>& read =
                                        [](const std::filesystem::path& p) { (void)train::read_sdm_model(p); },
                                    const std::string& name = {}) {
    try {
        read(path);
        FAIL() << "no error for " << path;
    } catch (const core::Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(name.empty() ? path.string() : name), std::string::npos) << message;
        EXPECT_NE(message.find(fragment), std::string::npos) << message;
    }
}

}  // namespace facesynth::testkit
