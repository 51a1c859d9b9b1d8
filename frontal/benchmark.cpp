#include "frontal/benchmark.h"

#include "frontal/frontalise.h"
#include "frontal/image_metrics.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/random.h"
#include "morph/jaw_contour.h"

#include <opencv2/imgcodecs.hpp>

#include <ctime>
#include <vector>

namespace facesynth::frontal {
namespace {

namespace fs = std::filesystem;

void write_png(const fs::path& path, const cv::Mat& image) {
    std::vector<unsigned char> bytes;
    if (!cv::imencode(".png", image, bytes)) throw core::file_error(path.string(), "PNG encoding failed");
    core::write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

// Frontalises one posed view from `landmarks` with and without mirror filling and scores both.
ViewScores score_view(Frontaliser& frontaliser, const TexturedFace& face, const SyntheticView& view, const Eigen::Matrix2Xd& landmarks,
                      const TrueFrontal& truth, const cv::Mat& layout, const BenchmarkOptions& o, const fs::path* examples_stem) {
    FrontaliseOptions options;
    options.isomap.size = o.isomap_size;
    options.frontal.size = o.size;
    const std::clock_t cpu_start = std::clock();
    Frontalisation plain = frontaliser.frontalise(view.image, landmarks, options);
    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    cv::Mat filled = plain.isomap.clone();
    (void)frontaliser.mirror_fill(filled);
    const FrontalImage mirrored = frontaliser.render_frontal(plain.vertices, filled, options.frontal);

    const ImageComparison c = compare_images(plain.frontal.image, truth.render.image, truth.face_mask);
    const ImageComparison m = compare_images(mirrored.image, truth.render.image, truth.face_mask);
    const IsomapComparison ic = compare_isomap(plain.isomap, face.true_isomap, layout);
    const IsomapComparison im = compare_isomap(filled, face.true_isomap, layout);
    if (examples_stem) {
        write_png(examples_stem->string() + "_input.png", view.image);
        write_png(examples_stem->string() + "_isomap.png", plain.isomap);
        write_png(examples_stem->string() + "_frontal.png", plain.frontal.image);
        write_png(examples_stem->string() + "_frontal_mirror.png", mirrored.image);
        write_png(examples_stem->string() + "_truth.png", truth.render.image);
    }
    ViewScores s;
    s.count = 1;
    s.psnr = c.psnr_db, s.ssim = c.ssim, s.l1 = c.l1;
    s.psnr_mirror = m.psnr_db, s.ssim_mirror = m.ssim, s.l1_mirror = m.l1;
    s.isomap_l1 = ic.l1, s.isomap_psnr = ic.psnr_db, s.isomap_coverage = ic.coverage;
    s.isomap_l1_mirror = im.l1, s.isomap_coverage_mirror = im.coverage;
    s.cpu_ms = cpu_ms;
    return s;
}

ViewScores sum_of(const std::array<ViewScores, kYawBins>& bins) {
    ViewScores all;
    for (const ViewScores& s : bins) all.add(s);
    return all;
}

}  // namespace

std::string yaw_bin_label(int bin) { return std::to_string(10 * bin) + "_" + std::to_string(10 * bin + 10); }

void ViewScores::add(const ViewScores& s) {
    count += s.count;
    psnr += s.psnr, ssim += s.ssim, l1 += s.l1, psnr_mirror += s.psnr_mirror, ssim_mirror += s.ssim_mirror, l1_mirror += s.l1_mirror;
    isomap_l1 += s.isomap_l1, isomap_psnr += s.isomap_psnr, isomap_coverage += s.isomap_coverage;
    isomap_l1_mirror += s.isomap_l1_mirror, isomap_coverage_mirror += s.isomap_coverage_mirror;
    cpu_ms += s.cpu_ms;
}

ViewScores ViewScores::mean() const {
    if (count == 0) return *this;
    const double n = count;
    ViewScores m = *this;
    m.psnr /= n, m.ssim /= n, m.l1 /= n, m.psnr_mirror /= n, m.ssim_mirror /= n, m.l1_mirror /= n;
    m.isomap_l1 /= n, m.isomap_psnr /= n, m.isomap_coverage /= n, m.isomap_l1_mirror /= n, m.isomap_coverage_mirror /= n;
    m.cpu_ms /= n;
    return m;
}

void ViewScores::write_json(nlohmann::json& j, const std::string& prefix) const {
    j[prefix + "count"] = count;
    if (count == 0) return;
    const ViewScores m = mean();
    j[prefix + "psnr"] = m.psnr;
    j[prefix + "ssim"] = m.ssim;
    j[prefix + "l1"] = m.l1;
    j[prefix + "psnr_mirror"] = m.psnr_mirror;
    j[prefix + "ssim_mirror"] = m.ssim_mirror;
    j[prefix + "l1_mirror"] = m.l1_mirror;
    j[prefix + "isomap_l1"] = m.isomap_l1;
    j[prefix + "isomap_psnr"] = m.isomap_psnr;
    j[prefix + "isomap_coverage"] = m.isomap_coverage;
    j[prefix + "isomap_l1_mirror"] = m.isomap_l1_mirror;
    j[prefix + "isomap_coverage_mirror"] = m.isomap_coverage_mirror;
    j[prefix + "cpu_ms_per_face"] = m.cpu_ms;
}

ViewScores BenchmarkResult::truth_all() const { return sum_of(truth); }
ViewScores BenchmarkResult::detected_all() const { return sum_of(detected); }
int BenchmarkResult::detector_misses_all() const {
    int n = 0;
    for (const int m : detector_misses) n += m;
    return n;
}

BenchmarkResult run_benchmark(const morph::MorphableModel& model, const BenchmarkOptions& o, const std::function<void()>& on_identity,
                              const LandmarkFinder& find_landmarks) {
    if (model.symmetry.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("eval frontalise: model '" + model.name + "' has no symmetry map, so the mirror-fill half cannot be measured");
    if (find_landmarks && o.detection_framing < o.view.framing)
        throw core::Error("eval frontalise: --detection-framing " + std::to_string(o.detection_framing) + " is below --framing " +
                          std::to_string(o.view.framing) + " (the detector's view shows the standard view and more)");
    Frontaliser frontaliser(model);
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    const cv::Mat layout = layout_mask(frontaliser.uv_raster(o.isomap_size));
    // The detected-landmark run sees the same camera with more around the face (the detectors need
    // the head's outline), and is scored against the same truth at the standard framing.
    const ViewOptions detection_view = find_landmarks ? with_context(o.view, o.detection_framing) : o.view;
    if (!o.examples.empty()) fs::create_directories(o.examples);

    BenchmarkResult result;
    result.has_detected = static_cast<bool>(find_landmarks);
    result.detection_image_size = detection_view.size;
    for (int i = 0; i < o.count; ++i) {
        const auto index = static_cast<std::uint64_t>(i);
        const TexturedFace face = make_textured_face(model, frontaliser, o.seed, index, o.isomap_size);
        const TrueFrontal truth = render_true_frontal(frontaliser, face, o.size, o.view.lighting);
        core::Rng yaw_rng = core::make_rng(o.seed, index, core::RandomStream::kPose);
        for (int b = 0; b < kYawBins; ++b) {
            const auto bin = static_cast<std::size_t>(b);
            const double magnitude = 10.0 * b + yaw_rng.uniform(0, 10);
            const double yaw = yaw_rng.uniform() < 0.5 ? -magnitude : magnitude;
            const SyntheticView view = render_view(frontaliser.renderer(), model, face, yaw, o.view, &region);
            const fs::path stem = o.examples / ("face" + std::to_string(i) + "_yaw" + yaw_bin_label(b));
            const bool keep = !o.examples.empty() && i < 2;
            try {
                result.truth[bin].add(score_view(frontaliser, face, view, view.landmarks, truth, layout, o, keep ? &stem : nullptr));
            } catch (const core::Error& e) {
                throw core::Error("eval frontalise: identity " + std::to_string(i) + " at yaw " + std::to_string(yaw) + ": " + e.what());
            }
            if (!find_landmarks) continue;
            const SyntheticView wide =
                detection_view.size == o.view.size ? view : render_view(frontaliser.renderer(), model, face, yaw, detection_view, &region);
            const std::optional<Eigen::Matrix2Xd> found = find_landmarks(wide.image, wide.landmarks);
            if (!found) {
                ++result.detector_misses[bin];
                continue;
            }
            try {
                result.detected[bin].add(score_view(frontaliser, face, wide, *found, truth, layout, o, nullptr));
            } catch (const core::Error&) {
                ++result.detector_misses[bin];  // a fit that fails on detected landmarks counts as a miss
            }
        }
        if (on_identity) on_identity();
    }
    return result;
}

nlohmann::json to_json(const BenchmarkResult& r, const BenchmarkOptions& o, const morph::MorphableModel& model) {
    nlohmann::json j;
    j["model"] = model.name;
    j["model_checksum"] = model.checksum();
    j["count"] = o.count;
    j["seed"] = o.seed;
    j["isomap_size"] = o.isomap_size;
    j["size"] = o.size;
    j["image_size"] = o.view.size;
    j["fov_deg"] = o.view.fov_deg;
    j["framing"] = o.view.framing;
    j["texture"] = model.albedo && !model.albedo->empty() ? "albedo" : "procedural";
    for (int b = 0; b < kYawBins; ++b) r.truth[static_cast<std::size_t>(b)].write_json(j, "yaw_" + yaw_bin_label(b) + "_");
    r.truth_all().write_json(j, "all_");
    if (!r.has_detected) return j;
    for (int b = 0; b < kYawBins; ++b) {
        r.detected[static_cast<std::size_t>(b)].write_json(j, "detected_yaw_" + yaw_bin_label(b) + "_");
        j["detector_misses_yaw_" + yaw_bin_label(b)] = r.detector_misses[static_cast<std::size_t>(b)];
    }
    r.detected_all().write_json(j, "detected_all_");
    j["detector_misses"] = r.detector_misses_all();
    j["detection_framing"] = o.detection_framing;
    j["detection_image_size"] = r.detection_image_size;
    return j;
}

}  // namespace facesynth::frontal
