#pragma once
// Where tests find the licensed data in ../shared/data (never committed) and the CLI binary.
// FACESYNTH_DATA overrides the folder. With CI=true a missing folder fails the test instead of
// skipping it.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace facesynth::testkit {

// The shared data folder if it exists (with sfm/ or real/ inside), else nullopt.
std::optional<std::filesystem::path> shared_data_dir();
bool running_in_ci();
// Path to the facesynth executable built with the tests.
std::filesystem::path cli_path();
// tests/data: small input files made by us (fuzzer findings kept as regression tests). A function,
// not a macro in every test file, so that only test_data.cpp's object holds the checkout's path
// (the other objects stay the same in every clone, for ccache).
std::filesystem::path test_files_dir();
// The repository's root (for tests that run its scripts, such as tools/sim2real.sh).
std::filesystem::path source_dir();
// A fresh empty temporary folder for one test (removed at the start of the next run).
std::filesystem::path fresh_temp_dir(const std::string& name);
// Runs a shell command, returns its exit status and captures stdout+stderr into `output`.
int run_command(const std::string& command, std::string* output = nullptr);
// Parses a JSON file (throws nlohmann::json::parse_error when it is not JSON).
nlohmann::json read_json(const std::filesystem::path& path);
// The message of the core::Error that `call` throws, or "" when it throws none.
std::string error_message_of(const std::function<void()>& call);
// How often `what` occurs in `text` (overlapping matches counted).
std::size_t count_occurrences(const std::string& text, const std::string& what);
// Renders made by `facesynth synth --out DIR/renders SYNTH_ARGUMENTS --quiet`, copied with their .pts
// into DIR/photos (IMAGE.png beside IMAGE.pts), as stand-ins for annotated photographs; returns
// DIR/photos. Throws std::runtime_error with the CLI's output when synth fails.
std::filesystem::path photo_folder_from_renders(const std::filesystem::path& dir, const std::string& synth_arguments);

}  // namespace facesynth::testkit

// Resolves `relative` inside the shared data folder into `var`, or skips the test (fails in CI).
#define FACESYNTH_REQUIRE_SHARED_DATA(var, relative)                                              \
    std::filesystem::path var;                                                                    \
    do {                                                                                          \
        auto dir_ = ::facesynth::testkit::shared_data_dir();                                      \
        if (dir_ && std::filesystem::exists(*dir_ / (relative))) {                                \
            var = *dir_ / (relative);                                                             \
        } else if (::facesynth::testkit::running_in_ci()) {                                       \
            FAIL() << "shared data '" << (relative) << "' missing (set FACESYNTH_DATA)";          \
        } else {                                                                                  \
            GTEST_SKIP() << "shared data '" << (relative) << "' not found (set FACESYNTH_DATA)"; \
        }                                                                                         \
    } while (0)
