// `facesynth model info|export|convert|build|albedo-check`: inspect, instantiate, convert, build
// morphable models and measure their colour draws. The formats live in morph/ (model_io, eos_io,
// bfm_io, mesh_io, model_build), the skin colour check in morph/skin_colour.h.
#include "cli_common.h"
#include "commands.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/mesh_io.h"
#include "morph/model_build.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "morph/sampling.h"
#include "morph/skin_colour.h"
#include "synth/albedo_check.h"
#include "synth/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace facesynth::cli {
namespace {

struct InfoArgs {
    std::string model = "builtin";
    std::string json;
};

struct ExportArgs {
    std::string model = "builtin";
    std::string alpha;
    std::string expression;
    std::string albedo;
    bool random = false;
    std::int64_t seed = 0;
    double truncation = 3.0;
    std::string texture;
    std::string out;
};

struct ConvertArgs {
    std::string model = "builtin";
    std::string out;
};

struct AlbedoCheckArgs {
    std::string model = "builtin";
    std::int64_t count = 2000;
    std::int64_t seed = 1;
    double truncation = 2.0;
    double scale = 1.0;
    std::string json;
    bool quiet = false;
};

struct BuildArgs {
    std::string meshes;
    std::string out;
    int components = 0;
    double variance = 1.0;
    std::string name;
    std::string like;
    bool quiet = false;
};

// "0.5,-1,2" -> {0.5, -1, 2}.
std::vector<float> parse_floats(const std::string& text, const char* option) {
    std::vector<float> values;
    if (text.empty()) return values;
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
        try {
            std::size_t used = 0;
            const float value = std::stof(item, &used);
            if (used != item.size() || !std::isfinite(value)) throw std::invalid_argument(item);
            values.push_back(value);
        } catch (const std::exception&) {
            throw CLI::ValidationError(option, "'" + item + "' is not a number (expected a comma-separated list)");
        }
    }
    return values;
}

std::string expression_kind(const morph::MorphableModel& m) {
    if (!m.expression) return "none";
    return std::holds_alternative<morph::PcaModel>(*m.expression) ? "pca" : "blendshapes";
}

void run_info(const InfoArgs& a) {
    const morph::MorphableModel m = morph::load_model(a.model);
    const Eigen::Matrix3Xf mean = m.shape_instance({});
    const Eigen::Vector3f lo = mean.rowwise().minCoeff(), hi = mean.rowwise().maxCoeff();
    const long mirrored = std::count_if(m.symmetry.begin(), m.symmetry.end(), [](int s) { return s >= 0; });
    const std::string checksum = m.checksum();

    std::printf("model:                %s\n", a.model.c_str());
    std::printf("name:                 %s\n", m.name.c_str());
    std::printf("vertices:             %d\n", m.num_vertices());
    std::printf("triangles:            %zu\n", m.triangles.size());
    std::printf("shape components:     %d\n", m.num_shape_components());
    std::printf("expression:           %d (%s)", m.num_expression_components(), expression_kind(m).c_str());
    if (m.expression && std::holds_alternative<std::vector<morph::Blendshape>>(*m.expression)) {
        std::string names;
        for (const auto& b : std::get<std::vector<morph::Blendshape>>(*m.expression)) {
            if (!names.empty()) names += ", ";
            names += b.name;
        }
        std::printf(": %s", names.c_str());
    }
    std::printf("\n");
    std::printf("albedo components:    %d%s\n", m.num_albedo_components(), m.albedo ? "" : " (no colour model)");
    std::printf("landmarks:            %zu%s\n", m.landmarks.size(), m.landmarks.size() == 68 ? " (iBUG 68)" : "");
    std::printf("contour chains:       %zu right, %zu left\n", m.contour.right.size(), m.contour.left.size());
    std::printf("symmetry:             %ld of %d vertices mirrored\n", mirrored, m.num_vertices());
    std::printf("uv:                   %s\n", m.uv.cols() ? "per vertex" : "none");
    std::printf("units:                mm\n");
    std::printf("bounding box (mean):  x %.1f..%.1f  y %.1f..%.1f  z %.1f..%.1f  (%.1f x %.1f x %.1f mm)\n", lo.x(), hi.x(),
                lo.y(), hi.y(), lo.z(), hi.z(), hi.x() - lo.x(), hi.y() - lo.y(), hi.z() - lo.z());
    std::printf("checksum:             %s\n", checksum.c_str());

    if (!a.json.empty()) {
        nlohmann::json j;
        j["model"] = a.model;
        j["name"] = m.name;
        j["vertices"] = m.num_vertices();
        j["triangles"] = m.triangles.size();
        j["shape_components"] = m.num_shape_components();
        j["expression_components"] = m.num_expression_components();
        j["expression_kind"] = expression_kind(m);
        j["albedo_components"] = m.num_albedo_components();
        j["has_albedo"] = m.albedo.has_value();
        j["landmarks"] = m.landmarks.size();
        j["contour_right"] = m.contour.right.size();
        j["contour_left"] = m.contour.left.size();
        j["symmetric_vertices"] = mirrored;
        j["has_uv"] = m.uv.cols() > 0;
        j["units"] = "mm";
        const char* axes[] = {"x", "y", "z"};
        for (int c = 0; c < 3; ++c) {
            j[std::string("bbox_min_") + axes[c]] = lo[c];
            j[std::string("bbox_max_") + axes[c]] = hi[c];
        }
        j["checksum"] = checksum;
        write_json_file(a.json, j);
    }
}

void run_export(const ExportArgs& a) {
    const std::string ext = std::filesystem::path(a.out).extension().string();
    if (ext != ".obj" && ext != ".glb") throw CLI::ValidationError("--out", "'" + a.out + "' must end in .obj or .glb");
    if (!a.texture.empty() && ext != ".glb") throw CLI::ValidationError("--texture", "a texture needs a .glb output");
    if (a.random && !a.alpha.empty()) throw CLI::ValidationError("--random", "give --alpha or --random, not both");
    std::vector<float> alpha = parse_floats(a.alpha, "--alpha");
    std::vector<float> beta = parse_floats(a.albedo, "--albedo");
    const std::vector<float> psi = parse_floats(a.expression, "--expression");
    const morph::MorphableModel m = morph::load_model(a.model);
    if (static_cast<int>(alpha.size()) > m.num_shape_components())
        throw core::Error("--alpha has " + std::to_string(alpha.size()) + " values, the model has " +
                    std::to_string(m.num_shape_components()) + " shape components");
    if (static_cast<int>(psi.size()) > m.num_expression_components())
        throw core::Error("--expression has " + std::to_string(psi.size()) + " values, the model has " +
                    std::to_string(m.num_expression_components()) + " expression components");
    if (static_cast<int>(beta.size()) > m.num_albedo_components())
        throw core::Error("--albedo has " + std::to_string(beta.size()) + " values, the model has " +
                    std::to_string(m.num_albedo_components()) + " albedo components");
    if (a.random) {
        const auto seed = static_cast<std::uint64_t>(a.seed);
        core::Rng identity = core::make_rng(seed, 0, core::RandomStream::kIdentity);
        alpha = morph::sample_coefficients(identity, m.num_shape_components(), a.truncation);
        if (beta.empty()) {
            core::Rng albedo = core::make_rng(seed, 0, core::RandomStream::kAlbedo);
            beta = morph::sample_coefficients(albedo, m.num_albedo_components(), a.truncation);
        }
    }
    const morph::Mesh mesh = m.instance(alpha, psi, beta);
    if (ext == ".obj") {
        morph::write_obj(mesh, a.out);
    } else {
        std::string png;
        if (!a.texture.empty()) {
            png = core::read_file(a.texture);
            if (png.size() < 8 || png.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) throw core::file_error(a.texture, "not a PNG file");
        }
        morph::write_glb(mesh, a.out, std::span(reinterpret_cast<const std::uint8_t*>(png.data()), png.size()));
    }
    std::printf("wrote %s: %d vertices, %d triangles%s%s\n", a.out.c_str(), mesh.num_vertices(), mesh.num_triangles(),
                mesh.uv.cols() ? ", uv" : "", a.texture.empty() ? ", vertex colours" : ", texture");
}

void run_convert(const ConvertArgs& a) {
    if (std::filesystem::path(a.out).extension() != ".fsm")
        throw CLI::ValidationError("--out", "'" + a.out + "' must end in .fsm (the facesynth model format)");
    const morph::MorphableModel m = morph::load_model(a.model);
    morph::write_model(m, a.out);
    std::printf("wrote %s (%d vertices, checksum %s)\n", a.out.c_str(), m.num_vertices(), m.checksum().c_str());
}

void run_build(const BuildArgs& a) {
    if (std::filesystem::path(a.out).extension() != ".fsm")
        throw CLI::ValidationError("--out", "'" + a.out + "' must end in .fsm (the facesynth model format)");
    if (!std::filesystem::is_directory(a.meshes)) throw core::file_error(a.meshes, "not a folder");
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(a.meshes))
        if (entry.is_regular_file() && morph::is_mesh_file(entry.path())) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    if (files.size() < 2)
        throw core::file_error(a.meshes, "holds " + std::to_string(files.size()) + " mesh files (.obj, .gltf, .glb); need at least 2");

    std::vector<morph::Mesh> meshes;
    std::vector<std::string> sources;
    Progress progress("reading meshes", files.size(), a.quiet);
    for (const auto& f : files) {
        meshes.push_back(morph::read_mesh(f));
        sources.push_back(f.string());
        progress.advance();
    }
    progress.finish();

    morph::ModelBuildOptions options;
    options.shape.max_components = a.components;
    options.shape.variance_fraction = a.variance;
    options.colour = options.shape;
    options.name = a.name.empty() ? std::filesystem::path(a.out).stem().string() : a.name;
    morph::ModelBuildResult built = morph::build_model(meshes, sources, options);
    if (built.length_scale != 1.0)
        std::fprintf(stderr, "facesynth: warning: %s: coordinates look like %s; scaled by %g to mm\n", sources[0].c_str(),
                     built.length_scale < 1.0 ? "micrometres" : "metres", built.length_scale);
    if (!a.like.empty()) {
        // Landmarks, contours and symmetry are facts about the topology: take them from a model
        // with the same mesh.
        const morph::MorphableModel like = morph::load_model(a.like);
        if (like.num_vertices() != built.model.num_vertices() || like.triangles != built.model.triangles)
            throw core::Error("--like " + a.like + ": its mesh differs from the built meshes (vertex count or triangles)");
        built.model.landmarks = like.landmarks;
        built.model.contour = like.contour;
        built.model.symmetry = like.symmetry;
        if (built.model.uv.cols() == 0) built.model.uv = like.uv;
    }
    morph::write_model(built.model, a.out);
    std::printf("wrote %s: %zu meshes, %d vertices, %d shape components, %d albedo components, checksum %s\n",
                a.out.c_str(), meshes.size(), built.model.num_vertices(), built.model.num_shape_components(),
                built.model.num_albedo_components(), built.model.checksum().c_str());
}

// Draws the colour coefficients of samples 0..count-1 exactly as synth does and reports the draws
// the skin colour check rejects, by reason (synth/albedo_check.h).
void run_albedo_check(const AlbedoCheckArgs& a) {
    const morph::MorphableModel m = morph::load_model(a.model);
    synth::SynthConfig config;
    config.seed = static_cast<std::uint64_t>(a.seed);
    config.albedo.truncation = a.truncation;
    config.albedo.scale = a.scale;
    Progress progress("checking colour draws", static_cast<std::size_t>(a.count), a.quiet);
    const synth::AlbedoCheckResult r = synth::check_albedo_draws(m, config, a.count, [&] { progress.advance(); });
    progress.finish();
    const morph::SkinColourLimits& l = r.limits;

    std::printf("model:              %s (%s, checksum %s)\n", a.model.c_str(), m.name.c_str(), m.checksum().c_str());
    std::printf("skin vertices:      %d\n", r.skin_vertices);
    std::printf("draws:              %lld (seed %lld, truncation %g, scale %g; synth's kAlbedo stream)\n", static_cast<long long>(a.count),
                static_cast<long long>(a.seed), a.truncation, a.scale);
    std::printf("limits:             luminance %g..%g, green/red %g..%g, blue/green <= %g, clamped skin <= %g\n", l.min_luminance,
                l.max_luminance, l.min_green_over_red, l.max_green_over_red, l.max_blue_over_green, l.max_clamped_share);
    std::printf("mean colour:        luminance %.3f, green/red %.3f, blue/green %.3f (%s)\n", r.mean.luminance, r.mean.green_over_red,
                r.mean.blue_over_green, r.mean.plausible() ? "plausible" : morph::flaw_names(r.mean.flaws).c_str());
    std::printf("implausible:        %lld (%.2f %%)\n", static_cast<long long>(r.implausible), 100.0 * r.implausible_share());
    for (std::size_t f = 0; f < synth::kSkinColourFlaws.size(); ++f)
        std::printf("  %-17s %lld\n", (morph::flaw_names(synth::kSkinColourFlaws[f]) + ":").c_str(), static_cast<long long>(r.per_flaw[f]));
    if (!r.implausible_indices.empty()) std::printf("first implausible:  %s\n", r.implausible_indices.c_str());
    std::printf("skin luminance:     1 %% %.3f, median %.3f, 99 %% %.3f\n", r.luminance_p01, r.luminance_p50, r.luminance_p99);
    std::printf("skin green/red:     1 %% %.3f, median %.3f, 99 %% %.3f\n", r.green_over_red_p01, r.green_over_red_p50, r.green_over_red_p99);
    std::printf("reject_implausible: %lld samples redrawn (%lld redraws), %lld shrunk toward the mean, %lld implausible after\n",
                static_cast<long long>(r.redrawn), static_cast<long long>(r.redraws), static_cast<long long>(r.shrunk),
                static_cast<long long>(r.implausible_after));
    if (!a.json.empty()) write_json_file(a.json, synth::to_json(r, a.model, m, config));
}

void add_model_option(CLI::App* command, std::string& target) {
    command->add_option("--model,-m", target,
                        "builtin, a model file (.fsm, eos .bin, BFM 2017 .h5) or a folder with a model and its side files")
        ->capture_default_str();
}

}  // namespace

void register_model_commands(CLI::App& app) {
    CLI::App* group = app.add_subcommand("model", "Inspect, export, convert and build morphable models");
    group->require_subcommand(1);

    auto info = std::make_shared<InfoArgs>();
    CLI::App* info_cmd = group->add_subcommand("info", "Print a model's sizes, units, bounding box and checksum");
    add_model_option(info_cmd, info->model);
    info_cmd->add_option("--json", info->json, "Also write the figures as flat JSON to this file");
    info_cmd->callback([info] { run_info(*info); });

    auto exp = std::make_shared<ExportArgs>();
    CLI::App* export_cmd = group->add_subcommand("export", "Write one model instance as a mesh (.obj or .glb)");
    add_model_option(export_cmd, exp->model);
    export_cmd->add_option("--alpha", exp->alpha, "Shape coefficients in standard deviations, comma-separated (missing = 0)");
    export_cmd->add_option("--expression", exp->expression, "Expression coefficients or blendshape weights, comma-separated");
    export_cmd->add_option("--albedo", exp->albedo, "Albedo coefficients in standard deviations, comma-separated");
    export_cmd->add_flag("--random", exp->random, "Draw shape (and albedo unless --albedo) from the model's prior");
    export_cmd->add_option("--seed", exp->seed, "Seed for --random")->capture_default_str();
    export_cmd->add_option("--truncation", exp->truncation, "Truncate --random draws at this many standard deviations")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    export_cmd->add_option("--texture", exp->texture, "PNG embedded as the base colour texture (.glb only; uses the model's uv)")
        ->check(CLI::ExistingFile);
    export_cmd->add_option("--out,-o", exp->out, "Output mesh: FILE.obj or FILE.glb")->required();
    export_cmd->callback([exp] { run_export(*exp); });

    auto convert = std::make_shared<ConvertArgs>();
    CLI::App* convert_cmd = group->add_subcommand("convert", "Save a model (with its side files) as one .fsm file");
    add_model_option(convert_cmd, convert->model);
    convert_cmd->add_option("--out,-o", convert->out, "Output model: FILE.fsm")->required();
    convert_cmd->callback([convert] { run_convert(*convert); });

    auto check = std::make_shared<AlbedoCheckArgs>();
    CLI::App* check_cmd = group->add_subcommand(
        "albedo-check", "Draw colour coefficients as synth does and count implausible skin colours (by reason)");
    add_model_option(check_cmd, check->model);
    check_cmd->add_option("--count,-n", check->count, "Number of draws (samples 0..N-1)")->capture_default_str()->check(CLI::NonNegativeNumber);
    check_cmd->add_option("--seed", check->seed, "Dataset seed, as synth's seed")->capture_default_str()->check(CLI::NonNegativeNumber);
    check_cmd->add_option("--truncation", check->truncation, "As synth's albedo.truncation")->capture_default_str()->check(CLI::NonNegativeNumber);
    check_cmd->add_option("--scale", check->scale, "As synth's albedo.scale")->capture_default_str();
    check_cmd->add_option("--json", check->json, "Also write the figures as flat JSON to this file");
    check_cmd->add_flag("-q,--quiet", check->quiet, "No progress output");
    check_cmd->callback([check] { run_albedo_check(*check); });

    auto build = std::make_shared<BuildArgs>();
    CLI::App* build_cmd = group->add_subcommand(
        "build", "Build a PCA model from meshes in correspondence (same vertex count and triangles)");
    build_cmd->add_option("--meshes", build->meshes, "Folder of .obj/.gltf/.glb meshes, one identity each")->required();
    build_cmd->add_option("--out,-o", build->out, "Output model: FILE.fsm")->required();
    build_cmd->add_option("--components,-k", build->components, "Keep at most K shape (and colour) components; 0 = all (N - 1)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    build_cmd->add_option("--variance", build->variance, "Keep the fewest components explaining this share of the variance")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1.0));
    build_cmd->add_option("--name", build->name, "Model name (default: the output file's stem)");
    build_cmd->add_option("--like", build->like, "Copy landmarks, contours and symmetry from this model (same mesh)");
    build_cmd->add_flag("-q,--quiet", build->quiet, "No progress output");
    build_cmd->callback([build] { run_build(*build); });
}

}  // namespace facesynth::cli
