#pragma once
// One exception type for every failure the user should see. The message carries its context
// (which file, which sample, which key) so the CLI can print it as one line and exit non-zero.
#include <stdexcept>
#include <string>

namespace facesynth::core {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// "<path>: <problem>" — the form every file-related error takes.
[[nodiscard]] inline Error file_error(const std::string& path, const std::string& problem) {
    return Error(path + ": " + problem);
}

}  // namespace facesynth::core
