#pragma once
// Each command group lives in its own tools/cmd_*.cpp and registers its subcommands here.
// Commands parse arguments, call the module libraries, print, and throw core::Error on failure.
#include <CLI/CLI.hpp>

namespace facesynth::cli {

// (one declaration per tools/cmd_*.cpp)
void register_synth_commands(CLI::App& app);  // cmd_synth.cpp
void register_train_commands(CLI::App& app);  // cmd_train.cpp: train, detect, eval landmarks
void register_fit_commands(CLI::App& app);    // cmd_fit.cpp: fit, fit-lambda
void register_model_commands(CLI::App& app);  // cmd_model.cpp: model info, export, convert, build
void register_render_commands(CLI::App& app);  // cmd_render.cpp: render, bench render
void register_report_commands(CLI::App& app);  // cmd_report.cpp: report
void register_frontal_commands(CLI::App& app);  // cmd_frontal.cpp: frontalise, eval frontalise, bench frontalise
void register_recognition_commands(CLI::App& app);  // cmd_recognition.cpp: eval recognition
void register_appearance_commands(CLI::App& app);  // cmd_appearance.cpp: textures, backgrounds
void register_profile_commands(CLI::App& app);  // cmd_profile.cpp: profile
void register_track_commands(CLI::App& app);  // cmd_track.cpp: track, eval track

}  // namespace facesynth::cli
