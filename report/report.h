#pragma once
// `facesynth report`: one self-contained HTML page from result files (docs/report.md lists the
// files it looks for). Every section whose inputs are absent says so and names the command that
// makes them; an unreadable input becomes a note in its section and a warning, never a failure of
// the whole report.
#include <opencv2/core.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::report {

struct ReportInputs {
    std::filesystem::path dataset;          // a `facesynth synth` folder, or empty
    std::optional<cv::Mat> contact_sheet;   // its contact sheet (RGB, as synth::contact_sheet makes it)
    std::filesystem::path evals;            // the results folder (layout in docs/report.md), or empty
    std::string title = "facesynth report";
};

struct Report {
    std::string html;
    std::vector<std::string> sections_shown;    // section ids with content
    std::vector<std::string> sections_missing;  // section ids shown only as "missing"
    std::vector<std::string> warnings;          // unreadable inputs, one line each naming the file
};

[[nodiscard]] Report build_report(const ReportInputs& inputs);

// Names of the files in the results folder, shared with the commands and scripts that write them.
namespace evals_layout {
inline constexpr const char* kFitPrefix = "eval_fit_";              // eval_fit_<name>.json
inline constexpr const char* kFitSweepDir = "fit_sweep";            // tools/fit_sweep.py output
inline constexpr const char* kLandmarksPrefix = "eval_landmarks_";  // eval_landmarks_<name>.json (+ .nme.csv)
inline constexpr const char* kNmeCsvSuffix = ".nme.csv";
inline constexpr const char* kFrontaliseEval = "eval_frontalise.json";
inline constexpr const char* kRecognitionEval = "eval_recognition.json";
inline constexpr const char* kRecognitionDet = "eval_recognition.det.csv";
inline constexpr const char* kRecognitionPhotos = "eval_recognition_photos.json";  // eval recognition --photos
}  // namespace evals_layout

}  // namespace facesynth::report
