// The facesynth command line: parses arguments, dispatches to the command groups, and turns every
// failure into one line on stderr and an exit code (2: usage error, 1: failure).
#include "cli_common.h"
#include "commands.h"

#include "core/error.h"

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
    CLI::App app{"facesynth: synthetic 3DMM faces, landmark regression, fitting and frontalisation"};
    app.require_subcommand(1);
    app.set_version_flag("--version", FACESYNTH_VERSION);
    // Command groups register themselves here, one call per tools/cmd_*.cpp.
    facesynth::cli::register_synth_commands(app);
    facesynth::cli::register_train_commands(app);
    facesynth::cli::register_fit_commands(app);
    facesynth::cli::register_model_commands(app);
    facesynth::cli::register_render_commands(app);
    facesynth::cli::register_report_commands(app);
    facesynth::cli::register_frontal_commands(app);
    facesynth::cli::register_recognition_commands(app);
    facesynth::cli::register_appearance_commands(app);
    facesynth::cli::register_profile_commands(app);
    facesynth::cli::register_track_commands(app);
    facesynth::cli::refuse_non_finite_numbers(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "facesynth: usage error: %s\nRun with --help for usage.\n", e.what());
        return 2;
    } catch (const facesynth::core::Error& e) {
        std::fprintf(stderr, "facesynth: error: %s\n", e.what());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "facesynth: internal error: %s\n", e.what());
        return 1;
    }
    return 0;
}
