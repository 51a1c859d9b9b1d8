#include "common/test_data.h"

#include "core/error.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sys/wait.h>

namespace facesynth::testkit {

std::optional<std::filesystem::path> shared_data_dir() {
    std::filesystem::path dir = FACESYNTH_DEFAULT_DATA_DIR;
    if (const char* env = std::getenv("FACESYNTH_DATA"); env && *env) dir = env;
    if (std::filesystem::is_directory(dir)) return dir;
    return std::nullopt;
}

bool running_in_ci() {
    const char* ci = std::getenv("CI");
    return ci && std::string(ci) == "true";
}

std::filesystem::path cli_path() { return FACESYNTH_CLI; }

std::filesystem::path test_files_dir() { return FACESYNTH_TEST_FILES; }

std::filesystem::path source_dir() { return FACESYNTH_SOURCE_DIR; }

std::filesystem::path fresh_temp_dir(const std::string& name) {
    std::filesystem::path base = std::filesystem::temp_directory_path() / "facesynth-tests";
    if (const char* env = std::getenv("FACESYNTH_TEST_TMP"); env && *env) base = env;
    const auto dir = base / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

int run_command(const std::string& command, std::string* output) {
    const std::string full = command + " 2>&1";
    FILE* pipe = ::popen(full.c_str(), "r");
    if (!pipe) return -1;
    std::array<char, 4096> buffer{};
    std::string captured;
    while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) captured += buffer.data();
    const int status = ::pclose(pipe);
    if (output) *output = captured;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

nlohmann::json read_json(const std::filesystem::path& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

std::size_t count_occurrences(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

std::string error_message_of(const std::function<void()>& call) {
    try {
        call();
    } catch (const core::Error& e) {
        return e.what();
    }
    return "";
}

std::filesystem::path photo_folder_from_renders(const std::filesystem::path& dir, const std::string& synth_arguments) {
    namespace fs = std::filesystem;
    const fs::path renders = dir / "renders";
    std::string output;
    if (run_command(cli_path().string() + " synth --out " + renders.string() + " " + synth_arguments + " --quiet", &output) != 0)
        throw std::runtime_error("facesynth synth failed: " + output);
    const fs::path photos = dir / "photos";
    fs::create_directories(photos);
    for (const auto& entry : fs::directory_iterator(renders / "images")) {
        const std::string stem = entry.path().stem().string();
        fs::copy_file(entry.path(), photos / entry.path().filename());
        fs::copy_file(renders / "landmarks" / (stem + ".pts"), photos / (stem + ".pts"));
    }
    return photos;
}

}  // namespace facesynth::testkit
