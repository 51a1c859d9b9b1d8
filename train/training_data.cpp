#include "train/training_data.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "core/random.h"
#include "train/parallel.h"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <array>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>

namespace facesynth::train {
namespace {

constexpr std::uint64_t kFallbackBoxStream = 0x424f5800;  // "BOX"

struct Loaded {
    bool ok = false;
    cv::Mat gray;   // kept only until the face is cropped (misses wait for the box statistics)
    cv::Mat crop;   // canonical crop around the detector box
    Eigen::Matrix2Xd truth;
    std::optional<FaceBox> detected;
    std::string warning;
};

struct LandmarkBounds {
    Eigen::Vector2d centre;
    double width;
};

LandmarkBounds bounds_of(const Eigen::Matrix2Xd& points) {
    const Eigen::Vector2d low = points.rowwise().minCoeff(), high = points.rowwise().maxCoeff();
    return {(low + high) / 2, std::max(high.x() - low.x(), high.y() - low.y())};
}

void fnv1a(std::uint64_t& hash, const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
        hash ^= bytes[i];
        hash *= 0x100000001b3ULL;
    }
}

double mean_of(const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0 : s / static_cast<double>(v.size());
}

// Signed horizontal offset of the nose tip (iBUG 31) from the midpoint of the outer eye corners
// (37, 46), in inter-ocular distances: about 0 for a frontal face, its sign says where the nose points.
double yaw_proxy(const Eigen::Matrix2Xd& shape) {
    const double middle = 0.5 * (shape(0, 36) + shape(0, 45));
    return (shape(0, 30) - middle) / std::max(1e-9, morph::inter_ocular_distance(shape));
}

double std_of(const std::vector<double>& v) {
    if (v.size() < 2) return 0;
    const double m = mean_of(v);
    double s = 0;
    for (double x : v) s += (x - m) * (x - m);
    return std::sqrt(s / static_cast<double>(v.size() - 1));
}

}  // namespace

PreparedFaces prepare_training_faces(const std::vector<LabelledImage>& images, const PrepareOptions& options) {
    std::vector<Loaded> loaded(images.size());
    const std::size_t workers = worker_count(options.threads, images.size());
    std::vector<FaceDetector> detectors;
    for (std::size_t w = 0; w < workers; ++w) detectors.emplace_back(options.detector);
    std::mutex progress_mutex;
    std::size_t done = 0;
    parallel_for(0, images.size(), options.threads, [&](std::size_t i, std::size_t worker) {
        Loaded& item = loaded[i];
        try {
            item.truth = morph::read_pts(images[i].pts);
            if (item.truth.cols() != morph::kNumIbugLandmarks)
                throw core::file_error(images[i].pts.string(), "has " + std::to_string(item.truth.cols()) + " points, expected 68");
            const cv::Mat image = cv::imread(images[i].image.string(), cv::IMREAD_UNCHANGED);
            if (image.empty()) throw core::file_error(images[i].image.string(), "cannot read image");
            item.gray = to_gray8(image);
            item.detected = match_detection(detectors[worker].detect(item.gray), item.truth);
            if (options.label_offsets.size() > 0) item.truth = morph::apply_face_frame_offsets(item.truth, options.label_offsets);
            if (item.detected) {
                item.crop = canonical_crop(item.gray, FaceFrame{*item.detected});
                item.gray.release();
            }
            item.ok = true;
        } catch (const core::Error& e) {
            item.ok = false;
            item.gray.release();
            item.warning = std::string(e.what()) + " (skipped)";
        }
        if (options.on_progress) {
            const std::lock_guard lock(progress_mutex);
            options.on_progress(++done, images.size());
        }
    });

    PreparedFaces result;
    BoxStatistics& stats = result.boxes;
    stats.detector = options.detector;
    // Box placement relative to the landmarks, pooled (recorded in the model) and per view (used to
    // synthesise the boxes of missed faces assigned to that view), and the yaw proxy per view.
    struct Placement {
        std::vector<double> ratios, offset_x, offset_y, yaw_proxy;
    };
    Placement pooled;
    std::array<Placement, kFaceViews> per_view;
    for (const auto& item : loaded) {
        if (!item.ok || !item.detected) continue;
        const LandmarkBounds b = bounds_of(item.truth);
        for (Placement* p : {&pooled, &per_view[static_cast<std::size_t>(item.detected->view)]}) {
            p->ratios.push_back(item.detected->width / b.width);
            p->offset_x.push_back((item.detected->centre.x() - b.centre.x()) / b.width);
            p->offset_y.push_back((item.detected->centre.y() - b.centre.y()) / b.width);
            p->yaw_proxy.push_back(yaw_proxy(item.truth));
        }
    }
    const auto placement_statistics = [](const Placement& p, BoxStatistics& into) {
        into.width_ratio_mean = mean_of(p.ratios);
        into.width_ratio_std = std_of(p.ratios);
        into.offset_mean = {mean_of(p.offset_x), mean_of(p.offset_y)};
        into.offset_std = {std_of(p.offset_x), std_of(p.offset_y)};
    };
    if (pooled.ratios.size() >= 5) placement_statistics(pooled, stats);
    std::array<BoxStatistics, kFaceViews> view_stats;
    for (std::size_t v = 0; v < kFaceViews; ++v) {
        view_stats[v] = stats;
        if (per_view[v].ratios.size() >= 5) placement_statistics(per_view[v], view_stats[v]);
    }
    // A missed face's view: the one (with at least 5 detected faces) whose mean yaw proxy is nearest.
    const auto assign_view = [&](const Eigen::Matrix2Xd& truth) {
        FaceView best = FaceView::kFrontal;
        double best_distance = std::numeric_limits<double>::infinity();
        for (std::size_t v = 0; v < kFaceViews; ++v) {
            if (per_view[v].yaw_proxy.size() < 5) continue;
            const double distance = std::abs(yaw_proxy(truth) - mean_of(per_view[v].yaw_proxy));
            if (distance < best_distance) {
                best_distance = distance;
                best = static_cast<FaceView>(v);
            }
        }
        return best;
    };

    std::uint64_t checksum = 0xcbf29ce484222325ULL;
    for (std::size_t i = 0; i < loaded.size(); ++i) {
        Loaded& item = loaded[i];
        if (!item.ok) {
            result.warnings.push_back(item.warning);
            continue;
        }
        FaceBox box;
        if (item.detected) {
            box = *item.detected;
            ++stats.detector_matched;
            ++stats.view_matched[static_cast<std::size_t>(box.view)];
        } else {
            core::Rng rng(options.seed, i, kFallbackBoxStream);
            const LandmarkBounds b = bounds_of(item.truth);
            box.view = assign_view(item.truth);
            const BoxStatistics& placement = view_stats[static_cast<std::size_t>(box.view)];
            box.width = b.width * (placement.width_ratio_mean + placement.width_ratio_std * rng.normal());
            const double dy = rng.normal();  // y before x: GCC's order when they were one expression (train/sdm.cpp)
            const double dx = rng.normal();
            box.centre = b.centre + b.width * (placement.offset_mean + placement.offset_std.cwiseProduct(Eigen::Vector2d(dx, dy)));
            ++stats.detector_missed;
        }
        const FaceFrame frame{box};
        TrainingFace face;
        face.crop = item.detected ? item.crop : canonical_crop(item.gray, frame);
        face.truth = frame.to_canonical(item.truth);
        face.box_from_detector = item.detected.has_value();
        face.view = box.view;
        face.yaw_deg = read_meta_yaw(images[i]);
        face.photograph = images[i].photograph;
        item.gray.release();
        item.crop.release();
        fnv1a(checksum, images[i].key.data(), images[i].key.size());
        fnv1a(checksum, item.truth.data(), sizeof(double) * static_cast<std::size_t>(item.truth.size()));
        result.faces.push_back(std::move(face));
    }
    result.checksum = checksum;
    return result;
}

}  // namespace facesynth::train
