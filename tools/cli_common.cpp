#include "cli_common.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <string>
#include <unistd.h>

namespace facesynth::cli {

Progress::Progress(std::string label, std::size_t total, bool quiet)
    : label_(std::move(label)),
      total_(total),
      quiet_(quiet),
      tty_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() {
    if (!finished_ && tty_ && !quiet_ && done_ > 0) std::fputc('\n', stderr);
}

void Progress::advance(std::size_t n) {
    done_ += n;
    if (quiet_) return;
    const auto now = std::chrono::steady_clock::now();
    const auto interval = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(5000);
    if (now - last_draw_ >= interval || done_ == total_) {
        last_draw_ = now;
        draw(false);
    }
}

void Progress::finish() {
    if (finished_) return;
    finished_ = true;
    if (!quiet_) draw(true);
}

void Progress::draw(bool final_line) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double rate = elapsed > 0 ? static_cast<double>(done_) / elapsed : 0.0;
    const double eta = rate > 0 && total_ > done_ ? static_cast<double>(total_ - done_) / rate : 0.0;
    if (tty_) {
        constexpr int kWidth = 30;
        const int filled = total_ ? static_cast<int>(kWidth * static_cast<double>(done_) / static_cast<double>(total_)) : kWidth;
        std::string bar(static_cast<std::size_t>(filled), '#');
        bar.resize(kWidth, '.');
        std::fprintf(stderr, "\r%s [%s] %zu/%zu %.1f/s ETA %.0fs ", label_.c_str(), bar.c_str(), done_, total_, rate, eta);
        if (final_line) std::fputc('\n', stderr);
    } else {
        std::fprintf(stderr, "%s: %zu/%zu (%.1f/s, ETA %.0fs)\n", label_.c_str(), done_, total_, rate, eta);
    }
    std::fflush(stderr);
}

CLI::App& bench_group(CLI::App& app) {
    for (CLI::App* sub : app.get_subcommands([](CLI::App* s) { return s->get_name() == "bench"; })) return *sub;
    CLI::App* bench = app.add_subcommand("bench", "Benchmarks (timings, not tests)");
    bench->require_subcommand(1);
    return *bench;
}

CLI::App& eval_group(CLI::App& app) {
    for (CLI::App* sub : app.get_subcommands([](CLI::App* s) { return s->get_name() == "eval"; })) return *sub;
    CLI::App* eval = app.add_subcommand("eval", "Evaluate against ground truth");
    eval->require_subcommand(1);
    return *eval;
}

CLI::Option* add_detector_option(CLI::App& command, std::string& value) {
    return command
        .add_option("--detector", value,
                    "Face detector: frontal (OpenCV's Haar frontal cascade), multiview (frontal + profile cascades on the "
                    "image and its mirror, overlapping boxes merged), dlib (dlib's HOG detector), dlib+profile (dlib, plus "
                    "the Haar profile cascades where dlib finds nothing), or auto (the one recorded in the first SDM "
                    "model given, else multiview)")
        ->check(CLI::IsMember({"auto", "frontal", "multiview", "dlib", "dlib+profile"}))
        ->capture_default_str();
}

CLI::Validator finite_range(double min, double max) {
    return CLI::Validator(
        [min, max](const std::string& text) -> std::string {
            double value = 0;
            std::size_t used = 0;
            try {
                value = std::stod(text, &used);
            } catch (const std::exception&) {
                return "'" + text + "' is not a number";
            }
            if (used != text.size() || !std::isfinite(value)) return "'" + text + "' is not a finite number";
            if (value < min || value > max) return "'" + text + "' is not in [" + CLI::detail::to_string(min) + ", " + CLI::detail::to_string(max) + "]";
            return {};
        },
        "FLOAT in [" + CLI::detail::to_string(min) + " - " + CLI::detail::to_string(max) + "]");
}

void refuse_non_finite_numbers(CLI::App& app) {
    const CLI::Validator finite(
        [](const std::string& text) -> std::string {
            char* end = nullptr;
            const double value = std::strtod(text.c_str(), &end);
            if (end != text.c_str() && *end == '\0' && !std::isfinite(value)) return "'" + text + "' is not a finite number";
            return {};
        },
        "", "finite");
    for (CLI::Option* option : app.get_options())
        if (option->get_type_name().starts_with("FLOAT")) option->check(finite);
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_non_finite_numbers(*sub);
}

void write_json_file(const std::filesystem::path& path, const nlohmann::json& value) {
    core::write_file_atomically(path, value.dump(2) + "\n");
}

void write_png_file(const std::filesystem::path& path, const cv::Mat& image) {
    std::vector<unsigned char> bytes;
    if (!cv::imencode(".png", image, bytes)) throw core::file_error(path.string(), "PNG encoding failed");
    core::write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

void create_output_folder(const std::filesystem::path& dir) {
    std::error_code error;
    std::filesystem::create_directories(dir, error);
    if (error) throw core::file_error(dir.string(), "cannot create the output folder: " + error.message());
}

}  // namespace facesynth::cli
