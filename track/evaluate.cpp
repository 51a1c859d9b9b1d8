#include "track/evaluate.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "fit/dataset_eval.h"
#include "train/sdm.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

namespace facesynth::track {
namespace {

namespace fs = std::filesystem;

struct Frame {
    std::string key;
    fs::path image;
    int frame = 0;
    Eigen::Matrix2Xd truth;  // the .pts landmarks (the dataset's landmark mode)
    double yaw = 0;
};

Eigen::Matrix2Xd points_from(const nlohmann::json& j, const fs::path& file) {
    if (!j.is_array() || j.size() != 68) throw core::file_error(file.string(), "'landmarks' is not 68 points");
    Eigen::Matrix2Xd out(2, 68);
    for (int i = 0; i < 68; ++i) {
        const auto& p = j[static_cast<std::size_t>(i)];
        if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
            throw core::file_error(file.string(), "landmark " + std::to_string(i) + " is not a pair of numbers");
        out(0, i) = p[0].get<double>();
        out(1, i) = p[1].get<double>();
    }
    return out;
}

// The dataset's clips, each in frame order.
std::map<std::int64_t, std::vector<Frame>> read_clips(const fs::path& dir) {
    std::map<std::int64_t, std::vector<Frame>> clips;
    for (const fit::DatasetEntry& entry : fit::read_dataset_manifest(dir)) {
        const nlohmann::json j = nlohmann::json::parse(core::read_file(entry.meta), nullptr, false);
        if (j.is_discarded() || !j.is_object()) throw core::file_error(entry.meta.string(), "not valid JSON (truncated or corrupt?)");
        const auto sequence = j.find("sequence");
        if (sequence == j.end() || !sequence->is_object())
            throw core::file_error(dir.string(), "is not a dataset of clips (sample " + entry.key + " has no 'sequence'): make one with synth --sequence F");
        Frame frame;
        frame.key = entry.key;
        frame.frame = sequence->value("frame", 0);
        frame.truth = points_from(j.value("landmarks", nlohmann::json()), entry.meta);
        frame.yaw = j.value("yaw", 0.0);
        for (const char* extension : {".png", ".jpg"})
            if (fs::exists(dir / "images" / (entry.key + extension))) frame.image = dir / "images" / (entry.key + extension);
        if (frame.image.empty()) throw core::file_error((dir / "images" / entry.key).string(), "no image for this sample (.png or .jpg)");
        clips[sequence->value("clip", std::int64_t{0})].push_back(std::move(frame));
    }
    if (clips.empty()) throw core::file_error((dir / "manifest.jsonl").string(), "lists no samples");
    for (auto& [clip, frames] : clips) std::sort(frames.begin(), frames.end(), [](const Frame& a, const Frame& b) { return a.frame < b.frame; });
    return clips;
}

// The tracked face that belongs to the truth: the one whose landmarks' centre is nearest the truth's
// centre, within the truth's bounding box.
const FaceState* face_for(const std::vector<FaceState>& faces, const Eigen::Matrix2Xd& truth) {
    const Eigen::Vector2d low = truth.rowwise().minCoeff(), high = truth.rowwise().maxCoeff(), centre = truth.rowwise().mean();
    const FaceState* best = nullptr;
    double best_distance = std::numeric_limits<double>::infinity();
    for (const FaceState& face : faces) {
        const Eigen::Vector2d c = face.landmarks.rowwise().mean();
        if ((c.array() < low.array()).any() || (c.array() > high.array()).any()) continue;
        if (const double d = (c - centre).norm(); d < best_distance) {
            best_distance = d;
            best = &face;
        }
    }
    return best;
}

struct VariantRun {
    VariantRun(VariantFigures& figures_, const train::LandmarkRegressor& regressor, train::DetectorKind detector, const fit::Fitter& fitter,
               const TrackerSettings& settings)
        : figures(figures_), tracker(regressor, detector, fitter, settings) {}

    VariantFigures& figures;
    Tracker tracker;
    std::optional<Eigen::Matrix2Xd> previous;  // the previous frame's prediction (found)
    bool had_success = false;
    std::int64_t failure_run = 0;

    // The id of the face matched to the truth, -1 when none.
    int frame(const cv::Mat& image, const Frame& f, const Frame* before, double failure_threshold, double time_s) {
        const auto start = std::chrono::steady_clock::now();
        const std::vector<FaceState>& faces = tracker.process(image, time_s);
        figures.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        ++figures.frames;
        const FaceState* face = face_for(faces, f.truth);
        double nme = std::numeric_limits<double>::infinity();
        if (face) {
            nme = train::landmark_nme(face->landmarks, f.truth);
            ++figures.found;
            figures.nme_sum += nme;
            const double yaw_error = std::abs(face->fit.pose.angles.yaw - f.yaw);
            figures.yaw_error_sum += yaw_error;
            figures.yaw_errors.push_back(yaw_error);
            const bool still = before && (f.truth - before->truth).cwiseAbs().maxCoeff() < 1e-6;
            if (still && previous) {
                const double iod = (f.truth.col(45) - f.truth.col(36)).norm();
                figures.jitter_sum += (face->landmarks - *previous).colwise().norm().mean() / iod;
                ++figures.jitter_frames;
            }
            previous = face->landmarks;
        } else {
            previous.reset();
            figures.yaw_errors.push_back(std::numeric_limits<double>::quiet_NaN());
        }
        figures.nmes.push_back(nme);
        const bool ok = nme <= failure_threshold;
        if (!ok) {
            ++figures.failed;
            ++failure_run;
        } else {
            if (had_success && failure_run > 0) {
                ++figures.reacquisitions;
                figures.reacquisition_frames += failure_run;
            }
            failure_run = 0;
            had_success = true;
        }
        return face ? face->id : -1;
    }
};

// A run of one clip's frames in the stream.
struct Segment {
    std::int64_t clip = 0;
    const std::vector<Frame>* frames = nullptr;
    std::size_t begin = 0, end = 0;
};

// The id most of a segment's matched frames had; -1 when none matched.
int majority_id(const std::vector<int>& ids) {
    std::map<int, int> counts;
    for (int id : ids)
        if (id >= 0) ++counts[id];
    int best = -1, best_count = 0;
    for (const auto& [id, count] : counts)
        if (count > best_count) best = id, best_count = count;
    return best;
}

void write_variant(nlohmann::json& j, const std::string& prefix, const VariantFigures& v) {
    const auto share = [](double part, std::int64_t whole) { return whole > 0 ? part / static_cast<double>(whole) : 0.0; };
    std::vector<double> sorted = v.nmes;
    std::sort(sorted.begin(), sorted.end());
    j[prefix + "nme_mean"] = share(v.nme_sum, v.found);
    j[prefix + "nme_median"] = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];  // misses count as +inf
    j[prefix + "failure_rate"] = share(static_cast<double>(v.failed), v.frames);
    j[prefix + "found_rate"] = share(static_cast<double>(v.found), v.frames);
    j[prefix + "jitter_static"] = share(v.jitter_sum, v.jitter_frames);
    j[prefix + "jitter_frames"] = v.jitter_frames;
    j[prefix + "reacquisitions"] = v.reacquisitions;
    j[prefix + "reacquire_frames_mean"] = share(static_cast<double>(v.reacquisition_frames), v.reacquisitions);
    j[prefix + "yaw_error_deg"] = share(v.yaw_error_sum, v.found);
    j[prefix + "detector_runs"] = v.detector_runs;
    j[prefix + "losses"] = v.losses;
    j[prefix + "fps"] = v.seconds > 0 ? static_cast<double>(v.frames) / v.seconds : 0.0;
    j[prefix + "ms_per_frame"] = share(1000.0 * v.seconds, v.frames);
}

}  // namespace

nlohmann::json TrackEvaluation::json(double failure_threshold) const {
    nlohmann::json j;
    j["clips"] = clips;
    j["frames"] = frames;
    j["static_frames"] = static_frames;
    j["failure_threshold"] = failure_threshold;
    write_variant(j, "tracked_", tracked);
    write_variant(j, "per_frame_", per_frame);
    if (with_cuts) {
        j["cuts"] = cut.cuts;
        j["cuts_detected"] = cut.cuts_detected;
        j["false_cuts"] = cut.false_cuts;
        j["returns"] = cut.returns;
        j["returns_same_id"] = cut.returns_same_id;
        j["false_merges"] = cut.false_merges;
    }
    return j;
}

TrackEvaluation evaluate_tracking(const train::LandmarkRegressor& regressor, train::DetectorKind detector, const fit::Fitter& fitter,
                                  const TrackEvalSettings& settings, const std::function<void(std::int64_t, std::int64_t)>& on_frame) {
    if (!(settings.failure_threshold > 0)) throw core::Error("eval track: the failure threshold must be positive");
    const auto clips = read_clips(settings.data);
    // The frame rate the clips were made at (dataset.json's config), for the smoother's time steps.
    double fps = 30;
    if (const nlohmann::json d = nlohmann::json::parse(core::read_file(settings.data / "dataset.json"), nullptr, false); d.is_object()) {
        const auto config = d.find("config");
        if (config != d.end() && config->is_object() && config->contains("sequence") && (*config)["sequence"].contains("fps"))
            fps = (*config)["sequence"]["fps"].get<double>();
    }
    TrackEvaluation e;
    e.with_cuts = settings.cuts;
    std::int64_t total = 0;
    std::vector<Segment> segments;
    for (const auto& [clip, frames] : clips) {
        total += static_cast<std::int64_t>(frames.size());
        if (!settings.cuts) segments.push_back({clip, &frames, 0, frames.size()});
    }
    if (settings.cuts)
        for (int half = 0; half < 2; ++half)
            for (const auto& [clip, frames] : clips) {
                const std::size_t middle = frames.size() / 2;
                if (half == 0 ? middle > 0 : middle < frames.size())
                    segments.push_back({clip, &frames, half == 0 ? 0 : middle, half == 0 ? middle : frames.size()});
            }
    TrackerSettings baseline = settings.tracker;
    baseline.track = false;
    std::optional<VariantRun> tracked, per_frame;
    const auto finish_runs = [&] {
        if (!tracked) return;
        e.tracked.detector_runs += tracked->tracker.detector_runs();
        e.tracked.losses += tracked->tracker.losses();
        e.per_frame.detector_runs += per_frame->tracker.detector_runs();
        e.per_frame.losses += per_frame->tracker.losses();
    };
    std::vector<std::pair<std::int64_t, int>> segment_ids;  // with cuts: each segment's clip and id, in stream order
    std::int64_t stream_frame = 0;
    for (const Segment& segment : segments) {
        if (!settings.cuts || !tracked) {
            // Each clip is its own stream without cuts; with them, one stream through all segments.
            finish_runs();
            tracked.emplace(e.tracked, regressor, detector, fitter, settings.tracker);
            per_frame.emplace(e.per_frame, regressor, detector, fitter, baseline);
            ++e.clips;
        }
        const std::vector<Frame>& frames = *segment.frames;
        std::vector<int> ids;
        for (std::size_t k = segment.begin; k < segment.end; ++k) {
            const Frame& f = frames[k];
            const cv::Mat image = cv::imread(f.image.string(), cv::IMREAD_COLOR);
            if (image.empty()) throw core::file_error(f.image.string(), "cannot read the image (sample " + f.key + ")");
            const Frame* before = k > segment.begin && frames[k - 1].frame + 1 == f.frame ? &frames[k - 1] : nullptr;
            if (before && (f.truth - before->truth).cwiseAbs().maxCoeff() < 1e-6) ++e.static_frames;
            // Without cuts the clip's own frame times; with them the stream's.
            const double time_s = static_cast<double>(settings.cuts ? stream_frame : f.frame) / fps;
            ids.push_back(tracked->frame(image, f, before, settings.failure_threshold, time_s));
            per_frame->frame(image, f, before, settings.failure_threshold, time_s);
            if (settings.cuts && k == segment.begin && stream_frame > 0) {
                ++e.cut.cuts;
                if (tracked->tracker.cut()) ++e.cut.cuts_detected;
            }
            ++stream_frame;
            e.keys.push_back(f.key);
            e.yaws.push_back(f.yaw);
            e.clip_of.push_back(segment.clip);
            e.frame_of.push_back(f.frame);
            ++e.frames;
            if (on_frame) on_frame(e.frames, total);
        }
        if (settings.cuts) {
            const int id = majority_id(ids);
            if (id >= 0 && std::any_of(segment_ids.begin(), segment_ids.end(), [&](const auto& s) { return s.second == id && s.first != segment.clip; }))
                ++e.cut.false_merges;
            const auto first = std::find_if(segment_ids.begin(), segment_ids.end(), [&](const auto& s) { return s.first == segment.clip; });
            if (first != segment_ids.end() && first->second >= 0 && id >= 0) {
                ++e.cut.returns;
                if (first->second == id) ++e.cut.returns_same_id;
            }
            segment_ids.emplace_back(segment.clip, id);
        }
    }
    finish_runs();
    if (settings.cuts) e.cut.false_cuts = tracked->tracker.cuts() - e.cut.cuts_detected;
    return e;
}

}  // namespace facesynth::track
