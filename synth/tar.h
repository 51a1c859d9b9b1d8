#pragma once
// Deterministic tar files (WebDataset shards) written with libarchive: members in the given order,
// fixed mtime, owner and mode, so the same members give the same bytes on every machine.
#include <filesystem>
#include <string>
#include <vector>

namespace facesynth::synth {

struct TarMember {
    std::string name;                // name inside the tar, e.g. "s00001234.png"
    std::filesystem::path source;    // file whose bytes become the member
};

// Writes the tar to a temporary name and renames it into place; throws core::Error naming the
// tar or the member on failure.
void write_tar_file(const std::filesystem::path& path, const std::vector<TarMember>& members);

// Names and sizes of a tar's members in order (for tests and `synth merge` checks).
struct TarEntry {
    std::string name;
    std::size_t size = 0;
};
[[nodiscard]] std::vector<TarEntry> list_tar(const std::filesystem::path& path);

}  // namespace facesynth::synth
