// `facesynth frontalise` (photographs -> isomap + frontal render), `facesynth eval frontalise` (the
// ground-truth benchmark on synthetic faces) and `facesynth bench frontalise`. The algorithms live in
// frontal/; face detection and landmarking (train/) are chosen here and passed in as landmarks.
#include "cli_common.h"
#include "commands.h"

#include "fit/fit_record.h"
#include "frontal/benchmark.h"
#include "frontal/evaluate.h"
#include "frontal/image_metrics.h"
#include "frontal/frontalise.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"
#include "morph/mesh_io.h"
#include "morph/model_io.h"
#include "core/random.h"
#include "report/svg_plot.h"
#include "train/face_box.h"
#include "train/regressor.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>

namespace facesynth::cli {
namespace {

namespace fs = std::filesystem;

std::optional<cv::Vec3b> parse_background(const std::string& text) {
    if (text.empty() || text == "none") return std::nullopt;
    int r = 0, g = 0, b = 0;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%d,%d,%d%c", &r, &g, &b, &tail) != 3 || std::min({r, g, b}) < 0 || std::max({r, g, b}) > 255)
        throw core::Error("--background '" + text + "': expected R,G,B with values 0..255, or none");
    return cv::Vec3b(static_cast<std::uint8_t>(b), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(r));
}

// Arguments as given: folders expand to their image files (sorted, not recursive); files are kept
// whatever their extension, so that a wrong one is reported.
std::vector<fs::path> expand_inputs(const std::vector<std::string>& inputs) {
    std::vector<fs::path> images;
    for (const std::string& input : inputs) {
        const fs::path path(input);
        if (fs::is_directory(path)) {
            std::vector<fs::path> found;
            for (const auto& entry : fs::directory_iterator(path))
                if (entry.is_regular_file() && core::is_image_file(entry.path())) found.push_back(entry.path());
            std::sort(found.begin(), found.end());
            if (found.empty()) std::fprintf(stderr, "facesynth: warning: %s: no image files in this folder\n", input.c_str());
            images.insert(images.end(), found.begin(), found.end());
        } else {
            images.push_back(path);
        }
    }
    return images;
}

struct FrontaliseArgs {
    std::string model = "builtin";
    std::string regressor;
    std::string detector = "auto";
    std::string landmarks;  // dlib | pts
    std::string pts;
    std::vector<std::string> inputs;
    std::string out;
    int isomap_size = 512;
    int size = 256;
    bool mirror_fill = false;
    std::string background;
    std::string json;
    bool quiet = false;
};

// Where each image's landmarks come from: a regressor run on detected face boxes (every face found),
// or .pts files.
class LandmarkSource {
public:
    explicit LandmarkSource(const FrontaliseArgs& a) : args_(a) {
        if (!a.regressor.empty() || a.landmarks == "dlib") {
            regressor_ = train::open_regressor(a.regressor.empty() ? std::string("dlib") : a.regressor);
            const train::LandmarkRegressor* const regressors[] = {regressor_.get()};
            detector_ = std::make_unique<train::FaceDetector>(train::choose_detector(a.detector, regressors));
        }
    }
    [[nodiscard]] std::string label() const {
        if (regressor_) return regressor_->label();
        return args_.pts.empty() ? "pts beside the image" : "pts " + args_.pts;
    }
    // 68 landmarks per face, largest face first; throws core::Error naming the image otherwise.
    [[nodiscard]] std::vector<Eigen::Matrix2Xd> faces(const fs::path& image_path, const cv::Mat& image) const {
        if (regressor_) {
            const cv::Mat gray = train::to_gray8(image);
            const auto boxes = detector_->detect(gray);
            if (boxes.empty()) throw core::file_error(image_path.string(), "no face found");
            std::vector<Eigen::Matrix2Xd> out;
            out.reserve(boxes.size());
            for (const auto& box : boxes) out.push_back(regressor_->predict(gray, box));
            return out;
        }
        const fs::path pts = args_.pts.empty() ? pts_for(image_path) : fs::path(args_.pts);
        Eigen::Matrix2Xd points = morph::read_pts(pts);
        if (points.cols() != morph::kNumIbugLandmarks)
            throw core::file_error(pts.string(), "has " + std::to_string(points.cols()) + " points, expected 68 (iBUG)");
        return {points};
    }

private:
    // IMAGE.pts beside the image, or ../landmarks/STEM.pts in a `facesynth synth` dataset folder.
    static fs::path pts_for(const fs::path& image) {
        fs::path beside = image;
        beside.replace_extension(".pts");
        if (fs::exists(beside)) return beside;
        fs::path dataset = image.parent_path().parent_path() / "landmarks" / (image.stem().string() + ".pts");
        if (fs::exists(dataset)) return dataset;
        throw core::file_error(image.string(), "no landmarks: neither " + beside.string() + " nor " + dataset.string() + " exists");
    }

    const FrontaliseArgs& args_;
    std::unique_ptr<train::LandmarkRegressor> regressor_;
    std::unique_ptr<train::FaceDetector> detector_;
};

nlohmann::json face_record(const fs::path& image, int face, const std::string& source, const Eigen::Matrix2Xd& landmarks,
                           const frontal::Frontalisation& r, const morph::MorphableModel& model, const frontal::FrontaliseOptions& o,
                           double detect_ms) {
    nlohmann::json j;
    j["image"] = image.string();
    j["face"] = face;
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["landmarks_source"] = source;
    j["coordinates"] = "0-based pixels";
    j["landmarks"] = fit::matrix_json(landmarks.transpose());  // one [x, y] per point
    fit::write_json(j, r.fit);
    j["isomap_size"] = o.isomap.size;
    j["frontal_size"] = o.frontal.size;
    j["mirror_fill"] = o.mirror_fill;
    j["mirror_filled_texels"] = r.mirror_filled_texels;
    j["covered_texels"] = r.isomap_stats.covered_texels;
    j["visible_texels"] = r.isomap_stats.visible_texels;
    j["detect_ms"] = detect_ms;
    j.update(nlohmann::json(r.times));
    return j;
}

void write_face_outputs(const fs::path& out, const std::string& stem, const frontal::Frontalisation& r, const morph::MorphableModel& model,
                        const nlohmann::json& record) {
    std::vector<unsigned char> isomap_png;
    if (!cv::imencode(".png", r.isomap, isomap_png)) throw core::file_error((out / (stem + ".isomap.png")).string(), "PNG encoding failed");
    core::write_file_atomically(out / (stem + ".isomap.png"), std::string_view(reinterpret_cast<const char*>(isomap_png.data()), isomap_png.size()));
    write_png_file(out / (stem + ".frontal.png"), r.frontal.image);
    morph::Mesh mesh;
    mesh.vertices = r.vertices;
    mesh.triangles = model.triangles;
    mesh.uv = model.uv;  // no vertex colours: glTF would multiply them into the texture
    morph::write_glb(mesh, out / (stem + ".glb"), isomap_png);
    write_json_file(out / (stem + ".json"), record);
}

void run_frontalise(const FrontaliseArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    frontal::FrontaliseOptions options;
    options.isomap.size = a.isomap_size;
    options.frontal.size = a.size;
    options.frontal.background = parse_background(a.background);
    options.mirror_fill = a.mirror_fill;
    if (a.mirror_fill && model.symmetry.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("--mirror-fill: model '" + model.name + "' (" + a.model + ") has no symmetry map");
    const std::vector<fs::path> images = expand_inputs(a.inputs);
    if (images.empty()) throw core::Error("frontalise: no images to process");
    if (!a.pts.empty() && images.size() != 1) throw core::Error("--pts gives the landmarks of one image, but " + std::to_string(images.size()) + " were given");
    const LandmarkSource source(a);
    frontal::Frontaliser frontaliser(model);
    const fs::path out(a.out);
    fs::create_directories(out);

    int failed = 0, faces = 0;
    frontal::StageTimes sum;
    double detect_ms_sum = 0;
    Progress progress("frontalise", images.size(), a.quiet);
    for (const fs::path& path : images) {
        try {
            if (!fs::is_regular_file(path)) throw core::file_error(path.string(), "file not found");
            core::check_image_not_too_large(path);
            const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
            if (image.empty()) throw core::file_error(path.string(), "cannot read the image (not an image file, or corrupt)");
            const auto detect_start = std::chrono::steady_clock::now();
            const std::vector<Eigen::Matrix2Xd> landmarks = source.faces(path, image);
            const double detect_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - detect_start).count();
            for (std::size_t k = 0; k < landmarks.size(); ++k) {
                frontal::Frontalisation r;
                try {
                    r = frontaliser.frontalise(image, landmarks[k], options);
                } catch (const core::Error& e) {
                    throw core::file_error(path.string(), std::string("face ") + std::to_string(k) + ": " + e.what());
                }
                const std::string stem = path.stem().string() + (k == 0 ? "" : "_" + std::to_string(k));
                write_face_outputs(out, stem, r, model, face_record(path, static_cast<int>(k), source.label(), landmarks[k], r, model, options, detect_ms));
                ++faces;
                sum += r.times;
            }
            detect_ms_sum += detect_ms;
        } catch (const core::Error& e) {
            ++failed;
            std::fprintf(stderr, "facesynth: error: %s\n", e.what());
        }
        progress.advance();
    }
    progress.finish();
    const double n = std::max(faces, 1);
    if (!a.quiet)
        std::printf("%d faces from %zu images -> %s (%d failed); per face: fit %.1f ms, isomap %.1f ms, frontal %.1f ms (CPU %.1f ms in all)\n",
                    faces, images.size() - static_cast<std::size_t>(failed), out.string().c_str(), failed, sum.fit_ms / n, sum.isomap_ms / n,
                    sum.frontal_ms / n, sum.total_cpu_ms() / n);
    if (!a.json.empty()) {
        nlohmann::json j;
        j["model"] = model.name;
        j["images"] = images.size();
        j["faces"] = faces;
        j["failed"] = failed;
        j["landmarks_source"] = source.label();
        j["isomap_size"] = a.isomap_size;
        j["frontal_size"] = a.size;
        j["mirror_fill"] = a.mirror_fill;
        j["out"] = out.string();
        j["detect_ms_per_image"] = detect_ms_sum / std::max<double>(1.0, static_cast<double>(images.size()) - failed);
        j["fit_ms_per_face"] = sum.fit_ms / n;
        j["isomap_ms_per_face"] = sum.isomap_ms / n;
        j["mirror_ms_per_face"] = sum.mirror_ms / n;
        j["frontal_ms_per_face"] = sum.frontal_ms / n;
        j["cpu_ms_per_face"] = sum.total_cpu_ms() / n;
        write_json_file(a.json, j);
    }
    if (failed > 0) throw core::Error(std::to_string(failed) + " of " + std::to_string(images.size()) + " images failed (see the lines above)");
}


struct FrontaliseEvalArgs {
    std::string model = "builtin";
    int count = 10;
    std::int64_t seed = 20261122;
    int isomap_size = 512;
    int size = 256;
    int image_size = 384;
    double fov = frontal::ViewOptions{}.fov_deg;
    double framing = frontal::ViewOptions{}.framing;
    double detection_framing = 2.5;
    std::string lighting = "unlit";
    std::string regressor;
    std::string detector = "auto";
    std::string json;
    std::string plot;
    std::string examples;
    bool quiet = false;
};

// PSNR per yaw bin as an SVG line plot (one line per series; NaN = empty bin, left out).
std::string psnr_plot_svg(const std::vector<std::pair<std::string, std::array<double, frontal::kYawBins>>>& series) {
    std::vector<double> ticks;
    for (int b = 0; b <= frontal::kYawBins; ++b) ticks.push_back(10.0 * b);
    double low = 1e9, high = -1e9;
    report::LinePlot plot;
    plot.title = "frontal render PSNR by yaw";
    plot.x = report::linear_axis("|yaw| (°), points at the 10° bin centres", 0, 10.0 * frontal::kYawBins, ticks);
    for (const auto& [name, values] : series) {
        report::Series s;
        s.label = name;
        s.markers = true;
        for (int b = 0; b < frontal::kYawBins; ++b) {
            const double v = values[static_cast<std::size_t>(b)];
            if (!std::isfinite(v)) continue;
            s.x.push_back(10.0 * b + 5);
            s.y.push_back(v);
            low = std::min(low, v), high = std::max(high, v);
        }
        plot.series.push_back(std::move(s));
    }
    if (!(low <= high)) low = 0, high = 1;
    plot.y = report::linear_axis("PSNR in the face mask (dB)", std::floor(low / 2) * 2 - 2, std::ceil(high / 2) * 2 + 2);
    return report::line_plot_svg(plot);
}

using YawBins = std::array<frontal::ViewScores, frontal::kYawBins>;

void print_table(const char* title, const YawBins& bins, const frontal::ViewScores& total) {
    std::printf("%s\n%-8s %4s %7s %6s %6s %7s %6s %6s %8s %8s %8s %8s\n", title, "|yaw|", "n", "psnr", "ssim", "l1", "psnr_m", "ssim_m", "l1_m",
                "iso_l1", "iso_cov", "iso_l1_m", "iso_cov_m");
    auto row = [](const std::string& label, const frontal::ViewScores& sums) {
        if (sums.count == 0) {
            std::printf("%-8s %4d %7s\n", label.c_str(), 0, "-");
            return;
        }
        const frontal::ViewScores s = sums.mean();
        std::printf("%-8s %4d %7.2f %6.3f %6.2f %7.2f %6.3f %6.2f %8.2f %8.3f %8.2f %8.3f\n", label.c_str(), s.count, s.psnr, s.ssim, s.l1,
                    s.psnr_mirror, s.ssim_mirror, s.l1_mirror, s.isomap_l1, s.isomap_coverage, s.isomap_l1_mirror, s.isomap_coverage_mirror);
    };
    for (int b = 0; b < frontal::kYawBins; ++b) row(frontal::yaw_bin_label(b), bins[static_cast<std::size_t>(b)]);
    row("all", total);
}

std::array<double, frontal::kYawBins> psnr_by_bin(const YawBins& bins, bool mirror) {
    std::array<double, frontal::kYawBins> v{};
    for (int b = 0; b < frontal::kYawBins; ++b) {
        const frontal::ViewScores s = bins[static_cast<std::size_t>(b)].mean();
        v[static_cast<std::size_t>(b)] = s.count > 0 ? (mirror ? s.psnr_mirror : s.psnr) : std::nan("");
    }
    return v;
}

void run_eval_frontalise(const FrontaliseEvalArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    frontal::BenchmarkOptions options;
    options.count = a.count;
    options.seed = static_cast<std::uint64_t>(a.seed);
    options.isomap_size = a.isomap_size;
    options.size = a.size;
    options.view.size = a.image_size;
    options.view.fov_deg = a.fov;
    options.view.framing = a.framing;
    if (a.lighting == "sky") options.view.lighting = render::Lighting{};
    options.detection_framing = a.detection_framing;
    options.examples = a.examples;

    std::unique_ptr<train::LandmarkRegressor> regressor;
    std::unique_ptr<train::FaceDetector> detector;
    frontal::LandmarkFinder find_landmarks;
    if (!a.regressor.empty()) {
        regressor = train::open_regressor(a.regressor);
        const train::LandmarkRegressor* const regressors[] = {regressor.get()};
        detector = std::make_unique<train::FaceDetector>(train::choose_detector(a.detector, regressors));
        find_landmarks = [&](const cv::Mat& image, const Eigen::Matrix2Xd& truth) -> std::optional<Eigen::Matrix2Xd> {
            const cv::Mat gray = train::to_gray8(image);
            const auto box = train::match_detection(detector->detect(gray), truth);
            if (!box) return std::nullopt;
            return regressor->predict(gray, *box);
        };
    }
    Progress progress("eval frontalise", static_cast<std::size_t>(a.count), a.quiet);
    const frontal::BenchmarkResult r = frontal::run_benchmark(model, options, [&] { progress.advance(); }, find_landmarks);
    progress.finish();

    nlohmann::json j = frontal::to_json(r, options, model);
    j["lighting"] = a.lighting;
    if (regressor) {
        j["regressor"] = regressor->label();
        j["detector"] = train::detector_name(detector->kind());
    }
    if (!a.quiet) {
        print_table("frontalised from ground-truth landmarks (_m: with mirror fill):", r.truth, r.truth_all());
        if (regressor) {
            print_table("frontalised from detected landmarks:", r.detected, r.detected_all());
            std::printf("%s detector misses on %d² views at framing %.2f: %d of %d views (per bin:", train::detector_name(detector->kind()),
                        r.detection_image_size, a.detection_framing, r.detector_misses_all(), a.count * frontal::kYawBins);
            for (const int misses : r.detector_misses) std::printf(" %d", misses);
            std::printf(")\n");
        }
        std::printf("CPU %.1f ms per frontalisation (fit + %d² isomap + %d² frontal render)\n", r.truth_all().mean().cpu_ms, a.isomap_size,
                    a.size);
    }
    if (!a.plot.empty()) {
        std::vector<std::pair<std::string, std::array<double, frontal::kYawBins>>> series;
        series.emplace_back("true landmarks", psnr_by_bin(r.truth, false));
        series.emplace_back("+ mirror fill", psnr_by_bin(r.truth, true));
        if (regressor) {
            series.emplace_back("detected", psnr_by_bin(r.detected, false));
            series.emplace_back("detected + mirror", psnr_by_bin(r.detected, true));
        }
        core::write_file_atomically(a.plot, psnr_plot_svg(series));
    }
    if (!a.json.empty()) write_json_file(a.json, j);
}

struct FrontaliseBenchArgs {
    std::string model = "builtin";
    int count = 50;
    int isomap_size = 512;
    int size = 256;
    bool mirror_fill = false;
    std::string json;
    bool quiet = false;
};

// Times the library pipeline (fit + isomap + frontal render, no detection) on `count` posed renders of
// different identities at yaws within ±60°, after one warm-up face (uv raster, shader compilation).
void run_bench_frontalise(const FrontaliseBenchArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    frontal::Frontaliser frontaliser(model);
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    frontal::FrontaliseOptions options;
    options.isomap.size = a.isomap_size;
    options.frontal.size = a.size;
    options.mirror_fill = a.mirror_fill;
    constexpr std::uint64_t kSeed = 77;
    std::vector<frontal::SyntheticView> views;
    for (int i = 0; i <= a.count; ++i) {
        const frontal::TexturedFace face = frontal::make_textured_face(model, frontaliser, kSeed, static_cast<std::uint64_t>(i), a.isomap_size);
        core::Rng rng = core::make_rng(kSeed, static_cast<std::uint64_t>(i), core::RandomStream::kPose);
        views.push_back(frontal::render_view(frontaliser.renderer(), model, face, rng.uniform(-60, 60), {}, &region));
    }
    (void)frontaliser.frontalise(views.front().image, views.front().landmarks, options);
    frontal::StageTimes sum;
    Progress progress("bench frontalise", static_cast<std::size_t>(a.count), a.quiet);
    for (int i = 1; i <= a.count; ++i) {
        const frontal::SyntheticView& view = views[static_cast<std::size_t>(i)];
        sum += frontaliser.frontalise(view.image, view.landmarks, options).times;
        progress.advance();
    }
    progress.finish();
    const double n = a.count;
    const char* lp_threads = std::getenv("LP_NUM_THREADS");
    nlohmann::json j;
    j["model"] = model.name;
    j["vertices"] = model.num_vertices();
    j["count"] = a.count;
    j["isomap_size"] = a.isomap_size;
    j["size"] = a.size;
    j["mirror_fill"] = a.mirror_fill;
    j["image_size"] = frontal::ViewOptions{}.size;
    j["renderer"] = frontaliser.renderer().renderer_string();
    j["lp_num_threads"] = lp_threads ? lp_threads : "";
    const frontal::StageTimes per_face = sum.per(n);
    j.update(nlohmann::json(per_face));
    j["cpu_ms_per_face"] = per_face.total_cpu_ms();
    j["ms_per_face"] = per_face.total_ms();
    if (!a.quiet)
        std::printf("%s, %d faces, isomap %d², frontal %d²%s (LP_NUM_THREADS=%s)\n"
                    "per face, CPU (process) / wall ms: fit %.2f / %.2f, isomap %.2f / %.2f, mirror %.2f / %.2f, frontal %.2f / %.2f, total %.2f / %.2f\n",
                    model.name.c_str(), a.count, a.isomap_size, a.size, a.mirror_fill ? " + mirror fill" : "", lp_threads ? lp_threads : "unset",
                    sum.fit_cpu_ms / n, sum.fit_ms / n, sum.isomap_cpu_ms / n, sum.isomap_ms / n, sum.mirror_cpu_ms / n, sum.mirror_ms / n,
                    sum.frontal_cpu_ms / n, sum.frontal_ms / n, sum.total_cpu_ms() / n, sum.total_ms() / n);
    if (!a.json.empty()) write_json_file(a.json, j);
}

}  // namespace

void register_frontal_commands(CLI::App& app) {
    auto a = std::make_shared<FrontaliseArgs>();
    auto* cmd = app.add_subcommand("frontalise", "Frontalise faces in photographs: fit, isomap (uv texture) and frontal render");
    cmd->add_option("--model", a->model, "Model: builtin, a model file, or a folder such as shared/data/sfm")->capture_default_str();
    auto* regressor = cmd->add_option("--regressor", a->regressor, "Landmarks from this regressor (train/regressor.h specs: PATH, dlib, ert:PATH, ...) on detected face boxes (--detector)");
    auto* landmarks = cmd->add_option("--landmarks", a->landmarks, "dlib: dlib's predictor on detected face boxes; pts: IMAGE.pts beside each image (or ../landmarks/STEM.pts of a synth dataset)")->check(CLI::IsMember({"dlib", "pts"}));
    auto* pts = cmd->add_option("--pts", a->pts, "The 68 landmarks (.pts, 1-based) of the one IMAGE")->check(CLI::ExistingFile);
    regressor->excludes(landmarks)->excludes(pts);
    landmarks->excludes(pts);
    add_detector_option(*cmd, a->detector);
    cmd->add_option("images", a->inputs, "Images or folders of images")->required();
    cmd->add_option("--out", a->out, "Output folder: STEM.isomap.png, STEM.frontal.png, STEM.glb, STEM.json per face")->required();
    cmd->add_option("--isomap-size", a->isomap_size, "Isomap side in texels")->capture_default_str()->check(CLI::Range(16, 4096));
    cmd->add_option("--size", a->size, "Frontal render side in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
    cmd->add_flag("--mirror-fill", a->mirror_fill, "Fill occluded texels from the mirror side (needs the model's symmetry map)");
    cmd->add_option("--background", a->background, "R,G,B behind the frontal face (default: black)");
    cmd->add_option("--json", a->json, "Write a summary (flat keys) here");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or summary");
    cmd->callback([a, regressor, landmarks, pts] {
        if (regressor->count() == 0 && landmarks->count() == 0 && pts->count() == 0)
            throw CLI::ValidationError("frontalise", "say where landmarks come from: --regressor MODEL, --landmarks dlib|pts, or --pts FILE");
        run_frontalise(*a);
    });

    CLI::App* eval = &eval_group(app);
    auto e = std::make_shared<FrontaliseEvalArgs>();
    auto* ev = eval->add_subcommand("frontalise", "Frontalisation against ground truth: posed renders of known faces vs their true frontal render");
    ev->add_option("--model", e->model, "Model: builtin, a model file, or a folder (needs a symmetry map)")->capture_default_str();
    ev->add_option("--count", e->count, "Identities (each seen once per 10° yaw bin from 0 to 70)")->capture_default_str()->check(CLI::PositiveNumber);
    ev->add_option("--seed", e->seed, "Seed of the identities, textures and yaws")->capture_default_str();
    ev->add_option("--isomap-size", e->isomap_size, "Isomap side in texels")->capture_default_str()->check(CLI::Range(16, 4096));
    ev->add_option("--size", e->size, "Frontal render side in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
    ev->add_option("--image-size", e->image_size, "Side of the posed renders in pixels")->capture_default_str()->check(CLI::Range(64, 4096));
    ev->add_option("--fov", e->fov, "Vertical field of view of the posed renders (degrees)")->capture_default_str()->check(CLI::Range(1.0, 90.0));
    ev->add_option("--framing", e->framing,
                   "Posed render side / mean landmark box side: 1.5 fills the image with the face; about 2.5 shows the whole "
                   "head, which the face detectors need at large yaw")
        ->capture_default_str()
        ->check(CLI::Range(1.2, 4.0));
    ev->add_option("--detection-framing", e->detection_framing,
                   "With --regressor: the detector's views show this much around the face (the same camera and face pixels, a larger "
                   "image); 2.5 shows the whole head, which the profile cascade needs")
        ->capture_default_str()
        ->check(CLI::Range(1.2, 4.0));
    ev->add_option("--lighting", e->lighting, "unlit (albedo as is) or sky (the renderer's default soft light), the same for every view")->capture_default_str()->check(CLI::IsMember({"unlit", "sky"}));
    ev->add_option("--regressor", e->regressor, "Also frontalise from landmarks this regressor finds on detected face boxes (detected_* keys)");
    add_detector_option(*ev, e->detector);
    ev->add_option("--json", e->json, "Write the flat metrics here");
    ev->add_option("--plot", e->plot, "Write PSNR per yaw bin as an SVG plot here");
    ev->add_option("--examples", e->examples, "Write the views, isomaps and frontal renders of the first two identities into this folder");
    ev->add_flag("-q,--quiet", e->quiet, "Only the JSON, no table or progress");
    ev->callback([e] { run_eval_frontalise(*e); });

    auto b = std::make_shared<FrontaliseBenchArgs>();
    auto* bench = bench_group(app).add_subcommand("frontalise", "Time fit + isomap + frontal render per face (no detection); CPU and wall time");
    bench->add_option("--model", b->model, "Model: builtin, a model file, or a folder")->capture_default_str();
    bench->add_option("--count", b->count, "Faces timed (after one warm-up)")->capture_default_str()->check(CLI::PositiveNumber);
    bench->add_option("--isomap-size", b->isomap_size, "Isomap side in texels")->capture_default_str()->check(CLI::Range(16, 4096));
    bench->add_option("--size", b->size, "Frontal render side in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
    bench->add_flag("--mirror-fill", b->mirror_fill, "Include mirror filling");
    bench->add_option("--json", b->json, "Write the timings (flat keys) here");
    bench->add_flag("-q,--quiet", b->quiet, "Only the JSON");
    bench->callback([b] { run_bench_frontalise(*b); });
}

}  // namespace facesynth::cli
