#pragma once
// Shared CLI plumbing: progress reporting, JSON result files, model loading from --model.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <string>

namespace facesynth::cli {

// A progress bar on a terminal (stderr is a tty), plain log lines every few seconds otherwise,
// nothing with quiet.
class Progress {
public:
    Progress(std::string label, std::size_t total, bool quiet);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    void advance(std::size_t n = 1);
    void finish();

private:
    void draw(bool final_line);

    std::string label_;
    std::size_t total_;
    std::size_t done_ = 0;
    bool quiet_;
    bool tty_;
    bool finished_ = false;
    std::chrono::steady_clock::time_point start_;
    std::chrono::steady_clock::time_point last_draw_;
};

// The "bench" command group, created on first use, so that every tools/cmd_*.cpp can add its
// benchmark to it whatever the registration order.
CLI::App& bench_group(CLI::App& app);
// The "eval" command group, the same way.
CLI::App& eval_group(CLI::App& app);

// The --detector option of detect, eval landmarks, frontalise and eval frontalise: auto, frontal,
// multiview, dlib or dlib+profile (train/regressor.h choose_detector).
CLI::Option* add_detector_option(CLI::App& command, std::string& value);

// A number in [min, max]; NaN and infinities are refused (CLI::Range lets NaN through).
[[nodiscard]] CLI::Validator finite_range(double min, double max);

// Adds a finiteness check to every floating-point option of `app` and its subcommands, so that NaN
// and infinities are usage errors naming the option (CLI11 parses "nan" and "inf" as doubles).
void refuse_non_finite_numbers(CLI::App& app);

// Creates an output folder (and its parents); throws core::Error naming it when it cannot.
void create_output_folder(const std::filesystem::path& dir);

// Writes a flat JSON object atomically to `path` (pretty-printed, trailing newline).
void write_json_file(const std::filesystem::path& path, const nlohmann::json& value);

// Encodes an OpenCV image (B G R [A] or grey, 8-bit) as PNG and writes it atomically.
void write_png_file(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace facesynth::cli
