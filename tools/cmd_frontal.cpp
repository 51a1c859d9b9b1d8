// `facesynth frontalise` (photographs -> isomap + frontal render), `facesynth eval frontalise` (the
// ground-truth benchmark on synthetic faces) and `facesynth bench frontalise`. The algorithms live in
// frontal/; face detection and landmarking (train/) are chosen here and passed in as landmarks.
#include "cli_common.h"
#include "commands.h"

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
    nlohmann::json points = nlohmann::json::array();
    for (Eigen::Index i = 0; i < landmarks.cols(); ++i) points.push_back({landmarks(0, i), landmarks(1, i)});
    j["landmarks"] = points;
    j["yaw_deg"] = r.fit.pose.angles.yaw;
    j["pitch_deg"] = r.fit.pose.angles.pitch;
    j["roll_deg"] = r.fit.pose.angles.roll;
    j["rotation"] = matrix_json(r.fit.pose.rotation);
    j["scale_px_per_mm"] = r.fit.pose.scale;
    j["translation_px"] = {r.fit.pose.translation.x(), r.fit.pose.translation.y()};
    j["affine_camera"] = matrix_json(r.fit.camera.matrix);
    j["alpha"] = r.fit.alpha;
    j["psi"] = r.fit.psi;
    j["reprojection_rms_px"] = r.fit.reprojection_rms_px;
    j["isomap_size"] = o.isomap.size;
    j["frontal_size"] = o.frontal.size;
    j["mirror_fill"] = o.mirror_fill;
    j["mirror_filled_texels"] = r.mirror_filled_texels;
    j["covered_texels"] = r.isomap_stats.covered_texels;
    j["visible_texels"] = r.isomap_stats.visible_texels;
    j["detect_ms"] = detect_ms;
    j["fit_ms"] = r.times.fit_ms;
    j["isomap_ms"] = r.times.isomap_ms;
    j["mirror_ms"] = r.times.mirror_ms;
    j["frontal_ms"] = r.times.frontal_ms;
    j["fit_cpu_ms"] = r.times.fit_cpu_ms;
    j["isomap_cpu_ms"] = r.times.isomap_cpu_ms;
    j["mirror_cpu_ms"] = r.times.mirror_cpu_ms;
    j["frontal_cpu_ms"] = r.times.frontal_cpu_ms;
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

constexpr int kYawBins = 7;  // 10° bins of |yaw| from 0 to 70

struct EvalSums {
    int count = 0;
    double psnr = 0, ssim = 0, l1 = 0, psnr_mirror = 0, ssim_mirror = 0, l1_mirror = 0;
    double isomap_l1 = 0, isomap_psnr = 0, isomap_coverage = 0, isomap_l1_mirror = 0, isomap_coverage_mirror = 0;
    double cpu_ms = 0;

    void add(const EvalSums& s) {
        count += s.count;
        psnr += s.psnr, ssim += s.ssim, l1 += s.l1, psnr_mirror += s.psnr_mirror, ssim_mirror += s.ssim_mirror, l1_mirror += s.l1_mirror;
        isomap_l1 += s.isomap_l1, isomap_psnr += s.isomap_psnr, isomap_coverage += s.isomap_coverage;
        isomap_l1_mirror += s.isomap_l1_mirror, isomap_coverage_mirror += s.isomap_coverage_mirror;
        cpu_ms += s.cpu_ms;
    }
    // Empty bins (every detection missed) have only their count.
    void write(nlohmann::json& j, const std::string& prefix) const {
        j[prefix + "count"] = count;
        if (count == 0) return;
        const double n = count;
        j[prefix + "psnr"] = psnr / n;
        j[prefix + "ssim"] = ssim / n;
        j[prefix + "l1"] = l1 / n;
        j[prefix + "psnr_mirror"] = psnr_mirror / n;
        j[prefix + "ssim_mirror"] = ssim_mirror / n;
        j[prefix + "l1_mirror"] = l1_mirror / n;
        j[prefix + "isomap_l1"] = isomap_l1 / n;
        j[prefix + "isomap_psnr"] = isomap_psnr / n;
        j[prefix + "isomap_coverage"] = isomap_coverage / n;
        j[prefix + "isomap_l1_mirror"] = isomap_l1_mirror / n;
        j[prefix + "isomap_coverage_mirror"] = isomap_coverage_mirror / n;
        j[prefix + "cpu_ms_per_face"] = cpu_ms / n;
    }
};

std::string bin_label(int b) { return std::to_string(10 * b) + "_" + std::to_string(10 * b + 10); }

// Frontalises one posed view from `landmarks` with and without mirror filling and scores both.
EvalSums score_view(frontal::Frontaliser& frontaliser, const frontal::TexturedFace& face, const frontal::SyntheticView& view,
                    const Eigen::Matrix2Xd& landmarks, const frontal::TrueFrontal& truth, const cv::Mat& layout, const FrontaliseEvalArgs& a,
                    const fs::path* examples_stem) {
    frontal::FrontaliseOptions options;
    options.isomap.size = a.isomap_size;
    options.frontal.size = a.size;
    const std::clock_t cpu_start = std::clock();
    frontal::Frontalisation plain = frontaliser.frontalise(view.image, landmarks, options);
    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    cv::Mat filled = plain.isomap.clone();
    (void)frontaliser.mirror_fill(filled);
    const frontal::FrontalImage mirrored = frontaliser.render_frontal(plain.vertices, filled, options.frontal);

    const frontal::ImageComparison c = frontal::compare_images(plain.frontal.image, truth.render.image, truth.face_mask);
    const frontal::ImageComparison m = frontal::compare_images(mirrored.image, truth.render.image, truth.face_mask);
    const frontal::IsomapComparison ic = frontal::compare_isomap(plain.isomap, face.true_isomap, layout);
    const frontal::IsomapComparison im = frontal::compare_isomap(filled, face.true_isomap, layout);
    if (examples_stem) {
        write_png_file(examples_stem->string() + "_input.png", view.image);
        write_png_file(examples_stem->string() + "_isomap.png", plain.isomap);
        write_png_file(examples_stem->string() + "_frontal.png", plain.frontal.image);
        write_png_file(examples_stem->string() + "_frontal_mirror.png", mirrored.image);
        write_png_file(examples_stem->string() + "_truth.png", truth.render.image);
    }
    EvalSums s;
    s.count = 1;
    s.psnr = c.psnr_db, s.ssim = c.ssim, s.l1 = c.l1;
    s.psnr_mirror = m.psnr_db, s.ssim_mirror = m.ssim, s.l1_mirror = m.l1;
    s.isomap_l1 = ic.l1, s.isomap_psnr = ic.psnr_db, s.isomap_coverage = ic.coverage;
    s.isomap_l1_mirror = im.l1, s.isomap_coverage_mirror = im.coverage;
    s.cpu_ms = cpu_ms;
    return s;
}

// PSNR per yaw bin as an SVG line plot (one line per series; NaN = empty bin, left out).
std::string psnr_plot_svg(const std::vector<std::pair<std::string, std::array<double, kYawBins>>>& series) {
    std::vector<double> ticks;
    for (int b = 0; b <= kYawBins; ++b) ticks.push_back(10.0 * b);
    double low = 1e9, high = -1e9;
    report::LinePlot plot;
    plot.title = "frontal render PSNR by yaw";
    plot.x = report::linear_axis("|yaw| (°), points at the 10° bin centres", 0, 10.0 * kYawBins, ticks);
    for (const auto& [name, values] : series) {
        report::Series s;
        s.label = name;
        s.markers = true;
        for (int b = 0; b < kYawBins; ++b) {
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

void run_eval_frontalise(const FrontaliseEvalArgs& a) {
    const morph::MorphableModel model = morph::load_model(a.model);
    if (model.symmetry.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("eval frontalise: model '" + model.name + "' has no symmetry map, so the mirror-fill half cannot be measured");
    frontal::Frontaliser frontaliser(model);
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    const cv::Mat layout = frontal::layout_mask(frontaliser.uv_raster(a.isomap_size));
    frontal::ViewOptions view_options;
    view_options.size = a.image_size;
    view_options.fov_deg = a.fov;
    view_options.framing = a.framing;
    if (a.lighting == "sky") view_options.lighting = render::Lighting{};
    if (!a.regressor.empty() && a.detection_framing < a.framing)
        throw core::Error("eval frontalise: --detection-framing " + std::to_string(a.detection_framing) + " is below --framing " + std::to_string(a.framing) +
                    " (the detector's view shows the standard view and more)");
    // The detected-landmark run sees the same camera with more around the face (the detectors need
    // the head's outline), and is scored against the same truth at the standard framing.
    const frontal::ViewOptions detection_view_options =
        a.regressor.empty() ? view_options : frontal::with_context(view_options, a.detection_framing);
    std::unique_ptr<train::LandmarkRegressor> regressor;
    std::unique_ptr<train::FaceDetector> detector;
    if (!a.regressor.empty()) {
        regressor = train::open_regressor(a.regressor);
        const train::LandmarkRegressor* const regressors[] = {regressor.get()};
        detector = std::make_unique<train::FaceDetector>(train::choose_detector(a.detector, regressors));
    }
    if (!a.examples.empty()) fs::create_directories(a.examples);

    std::array<EvalSums, kYawBins> truth_bins{}, detected_bins{};
    int detector_misses = 0;
    std::array<int, kYawBins> bin_misses{};  // detector misses and failed fits per yaw bin
    Progress progress("eval frontalise", static_cast<std::size_t>(a.count), a.quiet);
    for (int i = 0; i < a.count; ++i) {
        const auto index = static_cast<std::uint64_t>(i);
        const frontal::TexturedFace face = frontal::make_textured_face(model, frontaliser, static_cast<std::uint64_t>(a.seed), index, a.isomap_size);
        const frontal::TrueFrontal truth = frontal::render_true_frontal(frontaliser, face, a.size, view_options.lighting);
        core::Rng yaw_rng = core::make_rng(static_cast<std::uint64_t>(a.seed), index, core::RandomStream::kPose);
        for (int b = 0; b < kYawBins; ++b) {
            const double magnitude = 10.0 * b + yaw_rng.uniform(0, 10);
            const double yaw = yaw_rng.uniform() < 0.5 ? -magnitude : magnitude;
            const frontal::SyntheticView view = frontal::render_view(frontaliser.renderer(), model, face, yaw, view_options, &region);
            const fs::path stem = fs::path(a.examples) / ("face" + std::to_string(i) + "_yaw" + bin_label(b));
            const bool keep = !a.examples.empty() && i < 2;
            try {
                truth_bins[static_cast<std::size_t>(b)].add(score_view(frontaliser, face, view, view.landmarks, truth, layout, a, keep ? &stem : nullptr));
            } catch (const core::Error& e) {
                throw core::Error("eval frontalise: identity " + std::to_string(i) + " at yaw " + std::to_string(yaw) + ": " + e.what());
            }
            if (regressor) {
                const frontal::SyntheticView wide = detection_view_options.size == view_options.size
                                                        ? view
                                                        : frontal::render_view(frontaliser.renderer(), model, face, yaw, detection_view_options, &region);
                const cv::Mat gray = train::to_gray8(wide.image);
                const auto box = train::match_detection(detector->detect(gray), wide.landmarks);
                if (!box) {
                    ++detector_misses;
                    ++bin_misses[static_cast<std::size_t>(b)];
                    continue;
                }
                try {
                    detected_bins[static_cast<std::size_t>(b)].add(
                        score_view(frontaliser, face, wide, regressor->predict(gray, *box), truth, layout, a, nullptr));
                } catch (const core::Error& e) {
                    ++detector_misses;  // a fit that fails on detected landmarks counts as a miss
                    ++bin_misses[static_cast<std::size_t>(b)];
                }
            }
        }
        progress.advance();
    }
    progress.finish();

    nlohmann::json j;
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["count"] = a.count;
    j["seed"] = a.seed;
    j["isomap_size"] = a.isomap_size;
    j["size"] = a.size;
    j["image_size"] = a.image_size;
    j["fov_deg"] = a.fov;
    j["framing"] = a.framing;
    j["lighting"] = a.lighting;
    j["texture"] = model.albedo && !model.albedo->empty() ? "albedo" : "procedural";
    EvalSums all, detected_all;
    for (int b = 0; b < kYawBins; ++b) {
        truth_bins[static_cast<std::size_t>(b)].write(j, "yaw_" + bin_label(b) + "_");
        all.add(truth_bins[static_cast<std::size_t>(b)]);
        if (regressor) {
            detected_bins[static_cast<std::size_t>(b)].write(j, "detected_yaw_" + bin_label(b) + "_");
            detected_all.add(detected_bins[static_cast<std::size_t>(b)]);
        }
    }
    all.write(j, "all_");
    if (regressor) {
        detected_all.write(j, "detected_all_");
        j["regressor"] = regressor->label();
        j["detector"] = train::detector_name(detector->kind());
        j["detector_misses"] = detector_misses;
        j["detection_framing"] = a.detection_framing;
        j["detection_image_size"] = detection_view_options.size;
        for (int b = 0; b < kYawBins; ++b)
            j["detector_misses_yaw_" + bin_label(b)] = bin_misses[static_cast<std::size_t>(b)];
    }
    if (!a.quiet) {
        auto table = [](const char* title, const std::array<EvalSums, kYawBins>& bins, const EvalSums& total) {
            std::printf("%s\n%-8s %4s %7s %6s %6s %7s %6s %6s %8s %8s %8s %8s\n", title, "|yaw|", "n", "psnr", "ssim", "l1", "psnr_m", "ssim_m",
                        "l1_m", "iso_l1", "iso_cov", "iso_l1_m", "iso_cov_m");
            auto row = [](const std::string& label, const EvalSums& s) {
                if (s.count == 0) {
                    std::printf("%-8s %4d %7s\n", label.c_str(), 0, "-");
                    return;
                }
                const double n = s.count;
                std::printf("%-8s %4d %7.2f %6.3f %6.2f %7.2f %6.3f %6.2f %8.2f %8.3f %8.2f %8.3f\n", label.c_str(), s.count, s.psnr / n, s.ssim / n,
                            s.l1 / n, s.psnr_mirror / n, s.ssim_mirror / n, s.l1_mirror / n, s.isomap_l1 / n, s.isomap_coverage / n,
                            s.isomap_l1_mirror / n, s.isomap_coverage_mirror / n);
            };
            for (int b = 0; b < kYawBins; ++b) row(bin_label(b), bins[static_cast<std::size_t>(b)]);
            row("all", total);
        };
        table("frontalised from ground-truth landmarks (_m: with mirror fill):", truth_bins, all);
        if (regressor) {
            table("frontalised from detected landmarks:", detected_bins, detected_all);
            std::printf("%s detector misses on %d² views at framing %.2f: %d of %d views (per bin:", train::detector_name(detector->kind()),
                        detection_view_options.size, detection_view_options.framing, detector_misses, a.count * kYawBins);
            for (int b = 0; b < kYawBins; ++b) std::printf(" %d", bin_misses[static_cast<std::size_t>(b)]);
            std::printf(")\n");
        }
        std::printf("CPU %.1f ms per frontalisation (fit + %d² isomap + %d² frontal render)\n", all.cpu_ms / std::max(all.count, 1), a.isomap_size, a.size);
    }
    if (!a.plot.empty()) {
        std::vector<std::pair<std::string, std::array<double, kYawBins>>> series;
        auto psnr_of = [](const std::array<EvalSums, kYawBins>& bins, bool mirror) {
            std::array<double, kYawBins> v{};
            for (int b = 0; b < kYawBins; ++b) {
                const EvalSums& s = bins[static_cast<std::size_t>(b)];
                v[static_cast<std::size_t>(b)] = s.count > 0 ? (mirror ? s.psnr_mirror : s.psnr) / s.count : std::nan("");
            }
            return v;
        };
        series.emplace_back("true landmarks", psnr_of(truth_bins, false));
        series.emplace_back("+ mirror fill", psnr_of(truth_bins, true));
        if (regressor) {
            series.emplace_back("detected", psnr_of(detected_bins, false));
            series.emplace_back("detected + mirror", psnr_of(detected_bins, true));
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
    j["fit_cpu_ms"] = sum.fit_cpu_ms / n;
    j["isomap_cpu_ms"] = sum.isomap_cpu_ms / n;
    j["mirror_cpu_ms"] = sum.mirror_cpu_ms / n;
    j["frontal_cpu_ms"] = sum.frontal_cpu_ms / n;
    j["cpu_ms_per_face"] = sum.total_cpu_ms() / n;
    j["ms_per_face"] = sum.total_ms() / n;
    j["fit_ms"] = sum.fit_ms / n;
    j["isomap_ms"] = sum.isomap_ms / n;
    j["mirror_ms"] = sum.mirror_ms / n;
    j["frontal_ms"] = sum.frontal_ms / n;
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
    cmd->add_flag("--quiet", a->quiet, "No progress or summary");
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
    ev->add_flag("--quiet", e->quiet, "Only the JSON, no table or progress");
    ev->callback([e] { run_eval_frontalise(*e); });

    auto b = std::make_shared<FrontaliseBenchArgs>();
    auto* bench = bench_group(app).add_subcommand("frontalise", "Time fit + isomap + frontal render per face (no detection); CPU and wall time");
    bench->add_option("--model", b->model, "Model: builtin, a model file, or a folder")->capture_default_str();
    bench->add_option("--count", b->count, "Faces timed (after one warm-up)")->capture_default_str()->check(CLI::PositiveNumber);
    bench->add_option("--isomap-size", b->isomap_size, "Isomap side in texels")->capture_default_str()->check(CLI::Range(16, 4096));
    bench->add_option("--size", b->size, "Frontal render side in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
    bench->add_flag("--mirror-fill", b->mirror_fill, "Include mirror filling");
    bench->add_option("--json", b->json, "Write the timings (flat keys) here");
    bench->add_flag("--quiet", b->quiet, "Only the JSON");
    bench->callback([b] { run_bench_frontalise(*b); });
}

}  // namespace facesynth::cli
