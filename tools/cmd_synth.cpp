// `facesynth synth` (generate a dataset), `synth merge`, `synth sheet` and `bench synth`.
#include "cli_common.h"
#include "commands.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "synth/dataset.h"
#include "synth/sheet.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>
#include <utility>
#include <sys/resource.h>
#include <unistd.h>

namespace facesynth::cli {
namespace {

struct SynthArgs {
    std::string out;
    std::string config_file;
    std::vector<std::string> overrides;
    std::int64_t count = -1;
    std::int64_t seed = -1;
    std::string size;
    std::string model;
    std::string formats;
    int sequence = -1;
    int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    std::string shard = "0/1";
    int shard_count = 0;
    bool overwrite = false;
    std::string backend = "auto";
    bool quiet = false;
    std::string json;
};

// Config file, then the direct flags, then --set overrides (in order).
synth::SynthConfig resolve_config(const SynthArgs& a) {
    synth::SynthConfig config;
    if (!a.config_file.empty()) synth::apply_toml_file(config, a.config_file);
    if (a.count >= 0) config.count = a.count;
    if (a.seed >= 0) config.seed = static_cast<std::uint64_t>(a.seed);
    if (!a.model.empty()) config.model = a.model;
    if (!a.formats.empty()) config.output.formats = a.formats;
    if (a.sequence >= 0) config.sequence.frames = a.sequence;
    if (!a.size.empty()) {
        int width = 0, height = 0;
        char rest = 0;
        if (std::sscanf(a.size.c_str(), "%dx%d%c", &width, &height, &rest) == 2) {
        } else if (std::sscanf(a.size.c_str(), "%d%c", &width, &rest) == 1) {
            height = width;
        } else {
            throw core::Error("--size '" + a.size + "': expected N or WxH");
        }
        config.camera.width = width;
        config.camera.height = height;
    }
    for (const auto& o : a.overrides) synth::apply_override(config, o);
    synth::validate(config);
    return config;
}

void add_run_options(CLI::App* cmd, SynthArgs& a) {
    cmd->add_option("--threads", a.threads, "worker threads, one GL context each (default: all cores)")->check(CLI::PositiveNumber);
    cmd->add_option("--backend", a.backend, "renderer backend: auto, egl, osmesa")->check(CLI::IsMember({"auto", "egl", "osmesa"}));
    cmd->add_option("--model", a.model, "model: builtin, a model file or folder (overrides the config's model)");
    cmd->add_option("--size", a.size, "image size N or WxH (camera.width, camera.height)");
    cmd->add_option("--set", a.overrides, "override a config key: key.sub=value (repeatable)");
    cmd->add_option("--json", a.json, "write results as flat JSON to FILE");
    cmd->add_flag("-q,--quiet", a.quiet, "no progress output");
}

void run_generate(const SynthArgs& a) {
    if (a.out.empty()) throw CLI::RequiredError("--out");
    synth::RunOptions options;
    options.config = resolve_config(a);
    options.out = a.out;
    options.threads = a.threads;
    options.shard = synth::parse_shard(a.shard, a.shard_count);
    options.overwrite = a.overwrite;
    options.renderer.backend = render::parse_backend(a.backend);
    const morph::MorphableModel model = morph::load_model(options.config.model);
    std::unique_ptr<Progress> progress;
    options.on_start = [&](std::size_t todo, std::size_t done) {
        if (!a.quiet && done > 0) std::fprintf(stderr, "synth: resuming, %zu samples of this shard already complete\n", done);
        progress = std::make_unique<Progress>("synth", todo, a.quiet);
    };
    options.on_sample = [&] { progress->advance(); };
    const auto result = synth::run_synth(options, model);
    if (progress) progress->finish();
    const double rate = result.seconds > 0 ? result.generated / result.seconds : 0.0;
    if (!a.quiet)
        std::printf("synth: %zu samples generated, %zu already present, shard %d/%d, %.1f samples/s, renderer %s -> %s\n", result.generated,
                    result.already_done, options.shard.index, options.shard.count, rate, result.renderer.c_str(), a.out.c_str());
    if (!a.json.empty())
        write_json_file(a.json, {{"generated", result.generated}, {"already_done", result.already_done}, {"tars_written", result.tars_written},
                                 {"seconds", result.seconds}, {"samples_per_s", rate}, {"shard_index", options.shard.index},
                                 {"shard_count", options.shard.count}, {"threads", a.threads}, {"renderer", result.renderer},
                                 {"out", a.out}});
}

// User + system CPU time of the whole process (all threads, Mesa's included).
double process_cpu_seconds() {
    rusage usage{};
    ::getrusage(RUSAGE_SELF, &usage);
    const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
    return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

struct SynthBenchArgs {
    SynthArgs run;
    std::string work;
    std::int64_t count = 300;
};

void run_bench(SynthBenchArgs& b) {
    SynthArgs a = b.run;
    if (a.size.empty()) a.size = "256";
    a.count = b.count;
    a.formats = "folder";
    const synth::SynthConfig config = resolve_config(a);
    const morph::MorphableModel model = morph::load_model(config.model);
    const std::filesystem::path work = b.work.empty() ? std::filesystem::temp_directory_path() / ("facesynth-bench-synth-" + std::to_string(::getpid())) : std::filesystem::path(b.work);
    nlohmann::json report = {{"model", model.name}, {"vertices", model.num_vertices()}, {"width", config.camera.width},
                             {"height", config.camera.height}, {"count", config.count}, {"image_format", config.output.image_format},
                             {"png_compression", config.output.png_compression}, {"antialiasing", config.render.antialiasing},
                             {"antialiasing_samples", render::antialiasing_from(config.render.antialiasing, config.render.antialiasing_samples).samples},
                             {"lights_per_vertex", config.render.lights_per_vertex}};
    const char* lp_threads = std::getenv("LP_NUM_THREADS");
    report["lp_num_threads"] = lp_threads ? lp_threads : "";
    const int all = a.threads;
    for (const int threads : {1, all}) {
        synth::RunOptions options;
        options.config = config;
        // A folder per run: the second run must not first delete the first run's files (kernel time
        // counted as its own, and ext4 then searches past the freed inodes for new files).
        options.out = work / ("threads-" + std::to_string(threads));
        options.threads = threads;
        options.overwrite = true;
        options.renderer.backend = render::parse_backend(a.backend);
        const double cpu_before = process_cpu_seconds();
        const auto r = synth::run_synth(options, model);
        const double cpu_ms = 1e3 * (process_cpu_seconds() - cpu_before) / std::max<double>(static_cast<double>(r.generated), 1.0);
        const double rate = r.generated / r.seconds;
        const double n = static_cast<double>(std::max<std::size_t>(r.generated, 1));
        const std::string suffix = threads == 1 ? "_1_thread" : "_all_threads";
        report["samples_per_s" + suffix] = rate;
        report["threads" + suffix] = threads;
        report["cpu_ms_per_sample" + suffix] = cpu_ms;
        report["renderer"] = r.renderer;
        // Worker thread times summed over the workers, per sample: the 1-thread run's under the plain
        // keys, the all-threads run's (what sharing the cores costs each stage) with the suffix.
        const std::pair<const char*, const synth::StageTimes::Stage*> stages[] = {
            {"sample", &r.times.sample}, {"render", &r.times.render}, {"composite", &r.times.composite},
            {"encode", &r.times.encode}, {"write", &r.times.write}};
        for (const auto& [name, stage] : stages) {
            const std::string stage_suffix = threads == 1 ? "" : "_all_threads";
            report[std::string("ms_") + name + stage_suffix] = 1e3 * stage->wall / n;
            report[std::string("cpu_ms_") + name + stage_suffix] = 1e3 * stage->cpu / n;
        }
        if (!a.quiet) {
            std::printf("bench synth: %d thread(s): %.1f samples/s (%zu samples, %.2f s), process CPU %.2f ms/sample\n", threads, rate,
                        r.generated, r.seconds, cpu_ms);
            const auto& t = r.times;
            std::printf("  per sample, worker thread wall / CPU ms: sample %.2f / %.2f, render+readback %.2f / %.2f, composite+labels %.2f / %.2f, "
                        "encode %.2f / %.2f, write %.2f / %.2f\n",
                        1e3 * t.sample.wall / n, 1e3 * t.sample.cpu / n, 1e3 * t.render.wall / n, 1e3 * t.render.cpu / n,
                        1e3 * t.composite.wall / n, 1e3 * t.composite.cpu / n, 1e3 * t.encode.wall / n, 1e3 * t.encode.cpu / n,
                        1e3 * t.write.wall / n, 1e3 * t.write.cpu / n);
        }
        if (threads == all) break;
    }
    if (!a.quiet) std::printf("  model %s (%d vertices), %dx%d %s, renderer %s\n", model.name.c_str(), model.num_vertices(), config.camera.width,
                              config.camera.height, config.output.image_format.c_str(), report["renderer"].get<std::string>().c_str());
    if (b.work.empty()) std::filesystem::remove_all(work);
    if (!a.json.empty()) write_json_file(a.json, report);
}

}  // namespace

void register_synth_commands(CLI::App& app) {
    auto args = std::make_shared<SynthArgs>();
    CLI::App* synth_cmd = app.add_subcommand("synth", "Generate a synthetic face dataset (images, .pts, meta JSON, WebDataset, COCO)");
    synth_cmd->add_option("--out,-o", args->out, "output dataset folder");
    synth_cmd->add_option("--config,-c", args->config_file, "TOML config file (keys in docs/synth.md)")->check(CLI::ExistingFile);
    synth_cmd->add_option("--count,-n", args->count, "number of samples (config key count)")->check(CLI::NonNegativeNumber);
    synth_cmd->add_option("--seed", args->seed, "dataset seed (config key seed)")->check(CLI::NonNegativeNumber);
    synth_cmd->add_option("--sequence", args->sequence, "clips of this many frames: sample i is frame i % F of clip i / F (config key sequence.frames; 0: still samples)")
        ->check(CLI::NonNegativeNumber);
    synth_cmd->add_option("--format", args->formats, "output formats, comma-separated: folder, wds, coco (config key output.formats)");
    synth_cmd->add_option("--shard", args->shard, "K/N (0-based) or auto (JOB_COMPLETION_INDEX or SLURM_ARRAY_TASK_ID)");
    synth_cmd->add_option("--shard-count", args->shard_count, "total shards for --shard auto (else FACESYNTH_SHARD_COUNT / SLURM_ARRAY_TASK_COUNT)");
    synth_cmd->add_flag("--overwrite", args->overwrite, "replace a dataset made with a different config in --out");
    add_run_options(synth_cmd, *args);
    // A later flag wins over an earlier one (scripts append overrides).
    for (const char* name : {"--count", "--seed", "--sequence", "--format", "--model", "--size", "--threads", "--shard", "--backend"})
        synth_cmd->get_option(name)->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    synth_cmd->require_subcommand(0, 1);

    auto merge_inputs = std::make_shared<std::vector<std::string>>();
    auto merge_out = std::make_shared<std::string>();
    auto merge_quiet = std::make_shared<bool>(false);
    CLI::App* merge = synth_cmd->add_subcommand("merge", "Merge shard manifests (and their files) into one dataset folder");
    merge->add_option("inputs", *merge_inputs, "dataset folders written by shards (one folder may hold all shards)")->required()->check(CLI::ExistingDirectory);
    merge->add_option("--into", *merge_out, "merged dataset folder (default: the first input)");
    merge->add_flag("-q,--quiet", *merge_quiet, "no summary line");
    merge->callback([=] {
        std::vector<std::filesystem::path> inputs(merge_inputs->begin(), merge_inputs->end());
        const std::filesystem::path out = merge_out->empty() ? inputs.front() : std::filesystem::path(*merge_out);
        const auto r = synth::merge_datasets(inputs, out);
        if (!*merge_quiet)
            std::printf("synth merge: %zu samples in %s/manifest.jsonl (%zu missing, %zu listed twice)\n", r.samples, out.c_str(), r.missing, r.duplicates);
        if (r.missing > 0) std::fprintf(stderr, "facesynth: warning: %zu samples below count are in no manifest (unfinished shards?)\n", r.missing);
    });

    CLI::App* defaults = synth_cmd->add_subcommand("defaults", "Print the configuration (defaults, or --config/--set applied) as commented TOML");
    defaults->add_option("--config,-c", args->config_file, "TOML config file to resolve")->check(CLI::ExistingFile);
    defaults->add_option("--set", args->overrides, "override a config key: key.sub=value (repeatable)");
    defaults->callback([=] { std::fputs(synth::to_commented_toml(resolve_config(*args)).c_str(), stdout); });

    auto sheet_dir = std::make_shared<std::string>();
    auto sheet_out = std::make_shared<std::string>();
    auto sheet_options = std::make_shared<synth::SheetOptions>();
    CLI::App* sheet = synth_cmd->add_subcommand("sheet", "Contact sheet of the first samples with landmarks drawn");
    sheet->add_option("dataset", *sheet_dir, "dataset folder (folder format)")->required()->check(CLI::ExistingDirectory);
    sheet->add_option("--out,-o", *sheet_out, "output PNG")->required();
    sheet->add_option("--count", sheet_options->count, "samples to show")->check(CLI::PositiveNumber);
    sheet->add_option("--columns", sheet_options->columns, "tiles per row")->check(CLI::PositiveNumber);
    sheet->add_option("--tile", sheet_options->tile, "tile side, px")->check(CLI::Range(16, 2048));
    sheet->add_option("--photos", sheet_options->photos,
                      "photographs with .pts beside them: rows of these between the rows of renders, every tile framed on its face")
        ->check(CLI::ExistingDirectory);
    sheet->callback([=] {
        const cv::Mat rgb = synth::contact_sheet(*sheet_dir, *sheet_options);
        cv::Mat bgr;
        cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
        std::vector<uchar> bytes;
        if (!cv::imencode(".png", bgr, bytes)) throw core::Error(*sheet_out + ": PNG encoding failed");
        core::write_file_atomically(*sheet_out, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    });

    synth_cmd->callback([=] {
        if (synth_cmd->get_subcommands().empty()) run_generate(*args);
    });

    auto bench_args = std::make_shared<SynthBenchArgs>();
    CLI::App* bench = bench_group(app).add_subcommand("synth", "Dataset generation speed, end to end (samples/s, 1 thread and all threads)");
    bench->add_option("--count,-n", bench_args->count, "samples per run")->check(CLI::PositiveNumber);
    bench->add_option("--work", bench_args->work, "folder for the generated samples, a subfolder per run (default: a temporary folder, removed)");
    bench->add_option("--config,-c", bench_args->run.config_file, "TOML config file")->check(CLI::ExistingFile);
    add_run_options(bench, bench_args->run);
    bench->callback([=] { run_bench(*bench_args); });
}

}  // namespace facesynth::cli
