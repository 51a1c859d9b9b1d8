#pragma once
// Each command group lives in its own tools/cmd_*.cpp and registers its subcommands here.
// Commands parse arguments, call the module libraries, print, and throw facesynth::Error on failure.
#include <CLI/CLI.hpp>

namespace facesynth::cli {

// (one declaration per tools/cmd_*.cpp)

}  // namespace facesynth::cli
