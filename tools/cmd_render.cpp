// `facesynth render` (one image with every ground-truth map and an overlay to check by eye) and
// `facesynth bench render` (renders per second). The renderer lives in render/.
#include "cli_common.h"
#include "commands.h"
#include "fit/fit_record.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "morph/regions.h"
#include "morph/sampling.h"
#include "render/bare_renderer.h"
#include "render/framing.h"
#include "render/landmarks.h"
#include "render/renderer.h"
#include "synth/exr.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <numbers>
#include <optional>
#include <mutex>
#include <thread>

namespace facesynth::cli {
namespace {

struct ViewArgs {
    std::string model = "builtin";
    double yaw = 0, pitch = 0, roll = 0;
    int size = 256, width = 0, height = 0;
    double fov = 30.0;
    double distance = 0.0;  // 0: frame the mesh
    bool orthographic = false;
    std::string backend = "auto";
    std::string antialiasing = "msaa";
    int antialiasing_samples = 0;
    std::string lighting_file;
    bool shadows = false;
    int shadow_map_size = render::RenderSettings{}.shadow_map_size;
    bool lights_per_vertex = false;
};

struct RenderArgs {
    ViewArgs view;
    std::optional<std::int64_t> seed;
    double truncation = 3.0;
    std::string out;
    std::string json;
    bool quiet = false;
};

struct RenderBenchArgs {
    ViewArgs view;
    int count = 1000;
    int threads = 1;
    bool barycentrics = false;
    bool colour_only = false;
    bool no_normals = false;
    bool bare = false;
    std::string json;
    bool quiet = false;
};

void add_view_options(CLI::App* cmd, ViewArgs& v) {
    cmd->add_option("--model,-m", v.model, "model: builtin, a model file or a model folder")->capture_default_str();
    cmd->add_option("--yaw", v.yaw, "degrees; > 0 turns the face toward the image right")->check(CLI::Range(-180.0, 180.0))->capture_default_str();
    cmd->add_option("--pitch", v.pitch, "degrees; > 0 looks up")->check(CLI::Range(-180.0, 180.0))->capture_default_str();
    cmd->add_option("--roll", v.roll, "degrees; > 0 counter-clockwise in the image")->check(CLI::Range(-180.0, 180.0))->capture_default_str();
    cmd->add_option("--size", v.size, "image width and height in pixels")->check(CLI::Range(1, 16384))->capture_default_str();
    cmd->add_option("--width", v.width, "image width (overrides --size)")->check(CLI::Range(1, 16384));
    cmd->add_option("--height", v.height, "image height (overrides --size)")->check(CLI::Range(1, 16384));
    cmd->add_option("--fov", v.fov, "vertical field of view, degrees")->check(CLI::Range(1.0, 170.0))->capture_default_str();
    cmd->add_option("--distance", v.distance, "camera to mesh-centre distance in mm (0: fit the mesh in 80% of the image)")
        ->check(CLI::NonNegativeNumber)->capture_default_str();
    cmd->add_flag("--orthographic", v.orthographic, "orthographic camera scaled to fit the mesh (ignores --fov, --distance)");
    cmd->add_option("--backend", v.backend, "auto, egl or osmesa (auto: EGL, then OSMesa)")
        ->check(CLI::IsMember({"auto", "egl", "osmesa"}))->capture_default_str();
    cmd->add_option("--antialiasing", v.antialiasing,
                    "msaa, supersampling, edges (silhouette edges blended on the CPU after a single-sample render) or none")
        ->check(CLI::IsMember({"none", "msaa", "supersampling", "edges"}))->capture_default_str();
    cmd->add_option("--antialiasing-samples", v.antialiasing_samples,
                    "msaa: samples per pixel (2-16); supersampling: N x N per pixel (N 2-4); 0: 4 for msaa, 2 for supersampling")
        ->check(CLI::Range(0, 16))->capture_default_str();
    cmd->add_option("--lighting", v.lighting_file, "lighting JSON (docs/render.md)")->check(CLI::ExistingFile);
    cmd->add_flag("--shadows", v.shadows, "directional lights cast shadows (shadow maps; sets the lighting's \"shadows\")");
    cmd->add_option("--shadow-map-size", v.shadow_map_size, "shadow map texels per side, per light")
        ->check(CLI::Range(16, 16384))->capture_default_str();
    cmd->add_flag("--lights-per-vertex", v.lights_per_vertex,
                  "directional lights (diffuse and specular) evaluated per vertex and interpolated: cheaper, "
                  "within a few levels at 256^2 (docs/render.md \"Shading\"); not with --shadows");
}

// The settings both render.json and the benchmark's JSON record (render.json adds the whole lighting,
// the benchmark its light count and shadow flag).
nlohmann::json settings_json(const render::RenderSettings& settings) {
    return {{"antialiasing", render::antialiasing_name(settings.antialiasing.method)},
            {"antialiasing_samples", settings.antialiasing.samples},
            {"shadow_map_size", settings.shadow_map_size},
            {"lights_per_vertex", settings.lights_per_vertex}};
}

// The render settings the view options ask for: anti-aliasing, the lighting file and shadows.
render::RenderSettings view_settings(const ViewArgs& v) {
    render::RenderSettings settings;
    try {
        settings.antialiasing = render::antialiasing_from(v.antialiasing, v.antialiasing_samples);
    } catch (const core::Error& e) {
        throw CLI::ValidationError("--antialiasing-samples", e.what());
    }
    settings.shadow_map_size = v.shadow_map_size;
    settings.lights_per_vertex = v.lights_per_vertex;
    if (!v.lighting_file.empty()) {
        try {
            settings.lighting = nlohmann::json::parse(core::read_file(v.lighting_file)).get<render::Lighting>();
        } catch (const nlohmann::json::exception& e) {
            throw core::file_error(v.lighting_file, e.what());
        } catch (const core::Error& e) {
            throw core::file_error(v.lighting_file, e.what());
        }
    }
    if (v.shadows) settings.lighting.shadows = true;
    return settings;
}

// Shadows come from directional lights only; without one the flag changes nothing, which a user
// who asked for shadows should hear about.
void warn_if_shadows_have_no_light(const render::RenderSettings& settings, bool quiet) {
    if (!quiet && settings.lighting.shadows && settings.lighting.lights.empty())
        std::fprintf(stderr, "facesynth: warning: shadows have no effect without directional lights (add \"lights\" to --lighting)\n");
}

render::Camera frame_camera(const ViewArgs& v, const morph::Mesh& mesh) {
    return render::frame_mesh(mesh, {v.yaw, v.pitch, v.roll, v.width > 0 ? v.width : v.size, v.height > 0 ? v.height : v.size, v.fov,
                                     v.distance, v.orthographic});
}

cv::Mat to_bgr(const cv::Mat& rgb) {
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    return bgr;
}

// Normals as a picture: x right -> red, y up -> green, toward the camera -> blue, (n + 1) / 2.
cv::Mat normals_picture(const cv::Mat& normals, const cv::Mat& mask) {
    cv::Mat bgr(normals.size(), CV_8UC3, cv::Scalar::all(0));
    for (int y = 0; y < normals.rows; ++y)
        for (int x = 0; x < normals.cols; ++x) {
            if (mask.at<std::uint8_t>(y, x) == 0) continue;
            const cv::Vec3f& n = normals.at<cv::Vec3f>(y, x);
            auto byte = [](float value) { return cv::saturate_cast<std::uint8_t>(127.5f * (value + 1.0f)); };
            bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(byte(-n[2]), byte(-n[1]), byte(n[0]));
        }
    return bgr;
}

// Region labels as a picture (morph/regions.h colours), for a person to check at a glance.
cv::Mat labels_picture(const cv::Mat& labels) {
    cv::Mat bgr(labels.size(), CV_8UC3);
    for (int y = 0; y < labels.rows; ++y)
        for (int x = 0; x < labels.cols; ++x) {
            const morph::RegionColour c = morph::region_colour(static_cast<morph::Region>(labels.at<std::uint8_t>(y, x)));
            bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(c.b, c.g, c.r);
        }
    return bgr;
}

// The render, enlarged for legibility, with fixed landmarks (green visible, red hidden, with their
// 1-based number) and contour jaw points (crosses: yellow visible, magenta hidden) drawn on it.
cv::Mat overlay_picture(const cv::Mat& rgb, const render::ProjectedLandmarks& lm) {
    const int scale = std::max(1, static_cast<int>(std::ceil(768.0 / std::max(rgb.cols, rgb.rows))));
    cv::Mat big;
    cv::resize(to_bgr(rgb), big, cv::Size(), scale, scale, cv::INTER_CUBIC);
    auto at = [scale](const Eigen::Vector2d& p) {
        // Pixel centre (x, y) sits at scale·(x + 0.5) - 0.5 in the enlarged image; 4 fractional bits.
        return cv::Point(static_cast<int>(std::lround(16.0 * (scale * (p.x() + 0.5) - 0.5))),
                         static_cast<int>(std::lround(16.0 * (scale * (p.y() + 0.5) - 0.5))));
    };
    const cv::Scalar green(60, 220, 60), red(40, 40, 255), yellow(0, 230, 255), magenta(255, 40, 255);
    for (Eigen::Index i = 0; i < lm.pixels.cols(); ++i) {
        const bool visible = lm.visible[static_cast<std::size_t>(i)] != 0;
        cv::circle(big, at(lm.pixels.col(i)), 3 * 16, visible ? green : red, visible ? cv::FILLED : 2, cv::LINE_AA, 4);
        const cv::Point label = at(lm.pixels.col(i)) / 16 + cv::Point(4, -4);
        cv::putText(big, std::to_string(i + 1), label, cv::FONT_HERSHEY_PLAIN, 0.7, visible ? green : red, 1, cv::LINE_AA);
    }
    for (Eigen::Index i = 0; i < std::min<Eigen::Index>(17, lm.contour_pixels.cols()); ++i) {
        if (lm.contour_pixels.col(i) == lm.pixels.col(i)) continue;
        const cv::Point p = at(lm.contour_pixels.col(i));
        const cv::Scalar colour = lm.contour_visible[static_cast<std::size_t>(i)] != 0 ? yellow : magenta;
        cv::drawMarker(big, p / 16, colour, cv::MARKER_TILTED_CROSS, 9, 2, cv::LINE_AA);
        cv::line(big, at(lm.pixels.col(i)), p, colour, 1, cv::LINE_AA, 4);
    }
    return big;
}

// One [x, y(, z)] array per column.
nlohmann::json points_json(const Eigen::MatrixXd& points) { return fit::matrix_json(points.transpose()); }

void run_render(const RenderArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.view.model);
    std::vector<float> alpha, psi, beta;
    if (a.seed) {
        morph::FaceCoefficients face = morph::sample_face(model, static_cast<std::uint64_t>(*a.seed), a.truncation);
        alpha = std::move(face.alpha);
        beta = std::move(face.beta);
    }
    const morph::Mesh mesh = model.instance(alpha, psi, beta);
    const render::Camera camera = frame_camera(a.view, mesh);
    render::RenderSettings settings = view_settings(a.view);
    settings.barycentrics = false;
    warn_if_shadows_have_no_light(settings, a.quiet);
    const morph::JawContourRegion contour_region = morph::jaw_contour_region(model);
    render::Renderer renderer({render::parse_backend(a.view.backend), true});
    render::MeshExtras extras;
    extras.vertex_labels = model.vertex_labels;
    const render::Frame frame = renderer.render(mesh, camera, settings, extras);
    const render::ProjectedLandmarks lm = render::project_landmarks(model.landmarks, mesh, camera, frame, {}, &contour_region);

    const std::filesystem::path out(a.out);
    create_output_folder(out);
    write_png_file(out / "image.png", to_bgr(frame.rgb));
    write_png_file(out / "mask.png", frame.mask);
    const std::string exr = synth::encode_depth_exr(frame.depth, (out / "depth.exr").string());
    core::write_file_atomically(out / "depth.exr", exr);
    write_png_file(out / "normals.png", normals_picture(frame.normals, frame.mask));
    write_png_file(out / "labels.png", frame.labels);
    write_png_file(out / "labels_colour.png", labels_picture(frame.labels));
    write_png_file(out / "overlay.png", overlay_picture(frame.rgb, lm));

    nlohmann::json j;
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["backend"] = renderer.backend();
    j["renderer"] = renderer.renderer_string();
    j["width"] = camera.intrinsics.width;
    j["height"] = camera.intrinsics.height;
    j["projection"] = a.view.orthographic ? "orthographic" : "perspective";
    j["fx"] = camera.intrinsics.fx;
    j["fy"] = camera.intrinsics.fy;
    j["cx"] = camera.intrinsics.cx;
    j["cy"] = camera.intrinsics.cy;
    j["yaw"] = a.view.yaw;
    j["pitch"] = a.view.pitch;
    j["roll"] = a.view.roll;
    j["rotation"] = fit::matrix_json(camera.pose.rotation);  // rows of R
    j["translation"] = {camera.pose.translation.x(), camera.pose.translation.y(), camera.pose.translation.z()};
    j["seed"] = a.seed ? nlohmann::json(*a.seed) : nlohmann::json(nullptr);
    j["alpha"] = alpha;
    j["beta"] = beta;
    j["lighting"] = settings.lighting;
    j.update(settings_json(settings));
    j["landmarks_fixed"] = points_json(lm.pixels);
    j["landmarks_contour"] = points_json(lm.contour_pixels);
    j["landmarks_3d_fixed"] = points_json(lm.model_points);
    j["landmarks_3d_contour"] = points_json(lm.contour_model_points);
    j["landmarks_camera_fixed"] = points_json(lm.camera_points);
    j["visible_fixed"] = lm.visible;
    j["visible_contour"] = lm.contour_visible;
    write_json_file(out / "render.json", j);
    if (!a.json.empty()) write_json_file(a.json, j);
    if (!a.quiet) {
        const auto visible = std::count(lm.visible.begin(), lm.visible.end(), 1);
        std::printf("render: %s, %dx%d, %ld of %zu landmarks visible -> %s (%s | %s)\n", model.name.c_str(),
                    camera.intrinsics.width, camera.intrinsics.height, static_cast<long>(visible), lm.visible.size(),
                    out.string().c_str(), renderer.backend().c_str(), renderer.renderer_string().c_str());
    }
}

struct BenchResult {
    double seconds = 0;
    std::string backend, renderer;
};

// --bare draws positions only, without anti-aliasing, shading or extra outputs.
void check_bare_options(const RenderBenchArgs& b) {
    if (!b.bare) return;
    if (b.view.antialiasing != "none")
        throw CLI::ValidationError("--bare", "draws without anti-aliasing: give --antialiasing none");
    if (!b.view.lighting_file.empty() || b.view.shadows)
        throw CLI::ValidationError("--bare", "draws a constant colour: --lighting and --shadows do not apply");
    if (b.barycentrics || b.colour_only || b.no_normals)
        throw CLI::ValidationError("--bare", "reads back RGBA only: --barycentrics, --colour-only and --no-normals do not apply");
}

void run_bench(const RenderBenchArgs& b) {
    check_bare_options(b);
    const morph::MorphableModel model = morph::load_model(b.view.model);
    const morph::Mesh mesh = model.instance({});
    const int threads = std::max(1, b.threads);
    const int per_thread = std::max(1, b.count / threads);
    std::vector<std::string> errors(static_cast<std::size_t>(threads));
    std::vector<std::string> backends(static_cast<std::size_t>(threads)), renderers(static_cast<std::size_t>(threads));
    std::vector<double> seconds(static_cast<std::size_t>(threads), 0.0);
    // Contexts are created (and warmed up) before timing: the benchmark measures steady-state renders.
    const render::RendererOptions options{render::parse_backend(b.view.backend), true};
    std::vector<render::Renderer> pool;
    std::vector<render::BareRenderer> bare_pool;
    for (int t = 0; t < threads; ++t) {
        render::RendererOptions worker_options = options;
        worker_options.software_display = options.software_display + t;  // as synth's workers: one llvmpipe rasteriser each for two threads
        if (b.bare)
            bare_pool.emplace_back(mesh, worker_options);
        else
            pool.emplace_back(worker_options);
    }
    render::RenderSettings settings = view_settings(b.view);
    if (settings.lighting.shadows && settings.lighting.lights.empty())
        throw core::Error("bench render: --shadows needs directional lights to measure (--lighting FILE with \"lights\")");
    settings.geometry = !b.colour_only;
    settings.normals = !b.no_normals;
    settings.barycentrics = b.barycentrics;
    Progress progress("bench render", static_cast<std::size_t>(per_thread) * static_cast<std::size_t>(threads), b.quiet);
    std::mutex progress_mutex;
    auto worker = [&](int t) {
        try {
            render::Frame frame;
            cv::Mat bare_rgba;
            auto render_one = [&](const render::Camera& camera) {
                if (b.bare)
                    bare_pool[static_cast<std::size_t>(t)].render(camera, bare_rgba);
                else
                    pool[static_cast<std::size_t>(t)].render(mesh, camera, settings, frame);
            };
            ViewArgs view = b.view;
            for (int i = 0; i < 5; ++i) render_one(frame_camera(view, mesh));
            std::vector<render::Camera> cameras;
            for (int i = 0; i < per_thread; ++i) {
                core::Rng rng = core::make_rng(1, static_cast<std::uint64_t>(t) * static_cast<std::uint64_t>(per_thread) + static_cast<std::uint64_t>(i), core::RandomStream::kPose);
                view.yaw = rng.uniform(-60, 60);
                view.pitch = rng.uniform(-20, 20);
                view.roll = rng.uniform(-15, 15);
                cameras.push_back(frame_camera(view, mesh));
            }
            const auto start = std::chrono::steady_clock::now();
            for (int i = 0; i < per_thread; ++i) {
                render_one(cameras[static_cast<std::size_t>(i)]);
                if (i % 50 == 49) {
                    std::lock_guard lock(progress_mutex);
                    progress.advance(50);
                }
            }
            seconds[static_cast<std::size_t>(t)] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (b.bare) {
                render::BareRenderer& renderer = bare_pool[static_cast<std::size_t>(t)];
                backends[static_cast<std::size_t>(t)] = renderer.backend();
                renderers[static_cast<std::size_t>(t)] = renderer.renderer_string();
                renderer.detach();
            } else {
                render::Renderer& renderer = pool[static_cast<std::size_t>(t)];
                backends[static_cast<std::size_t>(t)] = renderer.backend();
                renderers[static_cast<std::size_t>(t)] = renderer.renderer_string();
                renderer.detach();
            }
        } catch (const std::exception& e) {
            errors[static_cast<std::size_t>(t)] = e.what();
        }
    };
    const std::clock_t cpu_start = std::clock();
    if (threads == 1) {
        worker(0);
    } else {
        std::vector<std::thread> workers;
        workers.reserve(static_cast<std::size_t>(threads));
        for (int t = 0; t < threads; ++t) workers.emplace_back(worker, t);
        for (auto& w : workers) w.join();
    }
    const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    progress.finish();
    for (const auto& e : errors)
        if (!e.empty()) throw core::Error("bench render: " + e);
    const double wall = *std::max_element(seconds.begin(), seconds.end());
    const int total = per_thread * threads;
    const double rate = total / wall;
    const char* lp_threads = std::getenv("LP_NUM_THREADS");
    nlohmann::json j;
    j["renders_per_s"] = rate;
    j["ms_per_render"] = 1000.0 * wall / per_thread;
    // Process CPU time per render (all threads, including the warm-up): meaningful on a busy machine.
    j["cpu_ms_per_render"] = 1000.0 * cpu_seconds / (total + 5 * threads);
    j["backend"] = backends[0];
    j["renderer"] = renderers[0];
    j["model"] = model.name;
    j["vertices"] = mesh.num_vertices();
    j["triangles"] = mesh.num_triangles();
    j["width"] = b.view.width > 0 ? b.view.width : b.view.size;
    j["height"] = b.view.height > 0 ? b.view.height : b.view.size;
    j["count"] = total;
    j["threads"] = threads;
    j.update(settings_json(settings));
    j["lights"] = settings.lighting.lights.size();
    j["shadows"] = settings.lighting.shadows;
    j["barycentrics"] = b.barycentrics;
    j["geometry"] = !b.colour_only && !b.bare;
    j["normals"] = !b.colour_only && !b.no_normals && !b.bare;
    j["bare"] = b.bare;
    j["lp_num_threads"] = lp_threads ? lp_threads : "";
    if (!b.json.empty()) write_json_file(b.json, j);
    std::printf("bench render%s: %s (%d vertices) %dx%d, %d thread(s), %s anti-aliasing (%d), %zu light(s), shadows %s: %.1f renders/s, %.3f ms/render per thread, %.3f CPU ms/render [%s | %s]\n",
                b.bare ? " (bare)" : "", model.name.c_str(), mesh.num_vertices(), j["width"].get<int>(), j["height"].get<int>(), threads,
                j["antialiasing"].get<std::string>().c_str(), settings.antialiasing.samples, settings.lighting.lights.size(), settings.lighting.shadows ? "on" : "off", rate, j["ms_per_render"].get<double>(), j["cpu_ms_per_render"].get<double>(), backends[0].c_str(), renderers[0].c_str());
}

}  // namespace

void register_render_commands(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd = app.add_subcommand("render", "Render one face with depth, mask, normals, labels, landmarks and an overlay");
    add_view_options(cmd, args->view);
    cmd->add_option("--seed", args->seed, "draw identity and albedo from the model's prior with this seed (default: mean face)");
    cmd->add_option("--truncation", args->truncation, "coefficient truncation in standard deviations")->capture_default_str();
    cmd->add_option("--out,-o", args->out, "output folder")->required();
    cmd->add_option("--json", args->json, "also write render.json's content to this file");
    cmd->add_flag("-q,--quiet", args->quiet, "print nothing");
    cmd->callback([args] { run_render(*args); });

    auto bench_args = std::make_shared<RenderBenchArgs>();
    CLI::App* bench = bench_group(app).add_subcommand("render", "Renders per second (RGB, mask, depth, normals, ids, labels + read-back)");
    add_view_options(bench, bench_args->view);
    bench->add_option("--count,-n", bench_args->count, "renders in total")->check(CLI::PositiveNumber)->capture_default_str();
    bench->add_option("--threads,-t", bench_args->threads, "worker threads, one renderer each")->check(CLI::Range(1, 256))->capture_default_str();
    bench->add_flag("--barycentrics", bench_args->barycentrics, "also render and read back barycentrics");
    bench->add_flag("--colour-only", bench_args->colour_only, "RGB and mask only (no depth, normals, ids, labels)");
    bench->add_flag("--no-normals", bench_args->no_normals, "everything but normals (what synth renders by default)");
    bench->add_flag("--bare", bench_args->bare,
                    "the floor: positions only, constant colour, RGBA8 + 24-bit depth, RGBA read back (needs --antialiasing none)");
    bench->add_option("--json", bench_args->json, "write the result (renders_per_s, ms_per_render, backend, renderer, ...) here");
    bench->add_flag("-q,--quiet", bench_args->quiet, "no progress output");
    bench->callback([bench_args] { run_bench(*bench_args); });
}

}  // namespace facesynth::cli
