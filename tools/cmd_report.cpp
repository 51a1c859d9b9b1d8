// `facesynth report`: the HTML report (report/report.h) from a dataset folder and a results folder.
#include "cli_common.h"
#include "commands.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "report/report.h"
#include "synth/sheet.h"

#include <cstdio>
#include <memory>

namespace facesynth::cli {
namespace {

struct ReportArgs {
    std::filesystem::path out;
    std::filesystem::path dataset;
    std::filesystem::path evals;
    std::string title = "facesynth report";
    int sheet_count = 32;
    std::filesystem::path photos;
    bool quiet = false;
};

void run_report(const ReportArgs& args) {
    report::ReportInputs inputs;
    inputs.title = args.title;
    inputs.evals = args.evals;
    if (!args.dataset.empty()) {
        inputs.dataset = args.dataset;
        synth::SheetOptions sheet;
        sheet.count = args.sheet_count;
        sheet.columns = 8;
        sheet.tile = 144;
        sheet.photos = args.photos;
        inputs.contact_sheet = synth::contact_sheet(args.dataset, sheet);  // a bad --dataset is the user's error: exit 1
    }
    const report::Report result = report::build_report(inputs);
    core::write_file_atomically(args.out, result.html);
    for (const auto& warning : result.warnings) std::fprintf(stderr, "facesynth: warning: %s\n", warning.c_str());
    if (!args.quiet) {
        std::printf("report: %s (%.1f MB): %zu sections with results", args.out.c_str(), static_cast<double>(result.html.size()) / 1e6,
                    result.sections_shown.size());
        if (!result.sections_missing.empty()) {
            std::printf(", missing inputs for");
            for (const auto& id : result.sections_missing) std::printf(" %s", id.c_str());
        }
        std::printf("\n");
    }
}

}  // namespace

void register_report_commands(CLI::App& app) {
    auto args = std::make_shared<ReportArgs>();
    auto* cmd = app.add_subcommand("report", "One self-contained HTML page with the samples, fitting, landmark, frontalisation and recognition results");
    cmd->add_option("--out,-o", args->out, "HTML file to write")->required();
    cmd->add_option("--dataset", args->dataset, "A facesynth synth folder: its contact sheet")->check(CLI::ExistingDirectory);
    cmd->add_option("--evals", args->evals, "Results folder (file names in docs/report.md; tools/quickstart.sh writes one)")
        ->check(CLI::ExistingDirectory);
    cmd->add_option("--title", args->title, "Page title")->capture_default_str();
    cmd->add_option("--sheet-count", args->sheet_count, "Samples on the contact sheet")->check(CLI::Range(1, 512))->capture_default_str();
    cmd->add_option("--photos", args->photos, "Photographs with .pts beside them, shown in rows between the contact sheet's renders")
        ->check(CLI::ExistingDirectory);
    cmd->add_flag("-q,--quiet", args->quiet, "Print nothing but warnings and errors");
    cmd->callback([args] { run_report(*args); });
}

}  // namespace facesynth::cli
