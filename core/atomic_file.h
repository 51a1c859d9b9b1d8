#pragma once
// Files appear complete or not at all: written to a temporary name beside the target, flushed,
// then renamed over it. Every writer of user-visible output goes through here.
#include <filesystem>
#include <string_view>

namespace facesynth::core {

// Writes `contents` to `path` atomically; throws core::Error naming the file on any failure
// (including a full disk), leaving no temporary file behind.
void write_file_atomically(const std::filesystem::path& path, std::string_view contents);

// Temporary sibling name used for `path` ("<name>.tmp.<pid>.<n>"), for writers that must produce
// the file themselves (image encoders) and then call commit_temporary_file.
[[nodiscard]] std::filesystem::path temporary_path_for(const std::filesystem::path& path);
// fsync + rename temp -> path; removes temp and throws core::Error on failure.
void commit_temporary_file(const std::filesystem::path& temp, const std::filesystem::path& path);

// Reads a whole file; throws core::Error naming it when it cannot be read.
[[nodiscard]] std::string read_file(const std::filesystem::path& path);

}  // namespace facesynth::core
