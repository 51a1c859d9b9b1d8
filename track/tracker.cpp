#include "track/tracker.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "recognition/appearance.h"
#include "recognition/face_crop.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace facesynth::track {
namespace {

struct LandmarkBounds {
    Eigen::Vector2d centre;
    double width = 0;
};

LandmarkBounds bounds_of(const Eigen::Matrix2Xd& points) {
    const Eigen::Vector2d low = points.rowwise().minCoeff(), high = points.rowwise().maxCoeff();
    return {(low + high) / 2, std::max(high.x() - low.x(), high.y() - low.y())};
}

double inter_ocular(const Eigen::Matrix2Xd& points) { return (points.col(45) - points.col(36)).norm(); }

// The points whose model correspondences do not move with the view (all but the jaw's contour
// points): the identity evidence uses only these.
std::vector<int> fixed_correspondence_points() {
    std::vector<int> points{8};
    for (int i = 17; i < morph::kNumIbugLandmarks; ++i) points.push_back(i);
    return points;
}

// Appearance for re-identification: a descriptor every kAppearanceEvery good frames, the latest
// kAppearanceViews kept; faces whose eye centres are closer than kAppearanceMinEyes pixels give none
// (their crop would be mostly interpolation).
constexpr int kAppearanceEvery = 5;
constexpr std::size_t kAppearanceViews = 8;
constexpr double kAppearanceMinEyes = 20;

std::optional<cv::Mat> appearance_of(const cv::Mat& gray, const Eigen::Matrix2Xd& landmarks) {
    const Eigen::Vector2d left = landmarks.middleCols(36, 6).rowwise().mean(), right = landmarks.middleCols(42, 6).rowwise().mean();
    if (!landmarks.allFinite() || (right - left).norm() < kAppearanceMinEyes) return std::nullopt;
    return recognition::lbph_descriptor(recognition::eye_aligned_crop(gray, landmarks));
}

}  // namespace

Tracker::Tracker(const train::LandmarkRegressor& regressor, train::DetectorKind detector, const fit::Fitter& fitter, TrackerSettings settings)
    : regressor_(regressor), detector_(detector), fitter_(fitter), settings_(settings) {
    if (settings_.detect_every < 1) throw core::Error("tracker: detect_every must be at least 1 frame");
    if (settings_.max_faces < 1) throw core::Error("tracker: max_faces must be at least 1");
    if (!(settings_.max_fit_error > 0)) throw core::Error("tracker: max_fit_error must be positive");
    if (!(settings_.cut_threshold >= 0) || !(settings_.max_reid_distance >= 0) || settings_.reid_faces < 1)
        throw core::Error("tracker: cut_threshold and max_reid_distance must be >= 0 and reid_faces at least 1");
    fit_options_.jaw = fit::JawMode::kContour;
    fit_options_.lambda = fit_options_.expression_lambda = settings_.lambda;
    identity_options_.subset = fixed_correspondence_points();
    identity_options_.lambda = settings_.lambda;
    if (settings_.multiview_fallback && detector == train::DetectorKind::kDlib) fallback_.emplace(train::DetectorKind::kMultiView);
}

void Tracker::place_on_detection(Track& track, const cv::Mat& gray, const train::FaceBox& detection) const {
    track.state.raw_landmarks = regressor_.predict(gray, detection);
    track.state.box = detection;
    track.state.from_detector = true;
    track.detected_width = detection.width;
    const LandmarkBounds b = bounds_of(track.state.raw_landmarks);
    if (b.width > 0) track.calibration = {detection.width / b.width, (detection.centre - b.centre) / b.width};
}

std::vector<Tracker::LostTrack>::iterator Tracker::find_lost(const cv::Mat& gray, const Track& track, const train::FaceBox& detection) {
    // A face lost nearby not long ago, in this shot, is the same face.
    const auto nearby = std::find_if(lost_.begin(), lost_.end(), [&](const LostTrack& lost) {
        return lost.shot == shot_ && frame_ - lost.frame <= settings_.reacquire_frames &&
               train::match_detection({detection}, lost.track.last_good).has_value();
    });
    if (nearby != lost_.end() || !(settings_.max_reid_distance > 0)) return nearby;
    if (std::none_of(lost_.begin(), lost_.end(), [](const LostTrack& lost) { return !lost.track.appearance.empty(); })) return lost_.end();
    const std::optional<cv::Mat> appearance = appearance_of(gray, track.state.raw_landmarks);
    if (!appearance) return lost_.end();
    auto best = lost_.end();
    double best_distance = settings_.max_reid_distance;
    for (auto lost = lost_.begin(); lost != lost_.end(); ++lost)
        for (const cv::Mat& seen : lost->track.appearance)
            if (const double d = recognition::lbph_distance(*appearance, seen); d < best_distance) {
                best_distance = d;
                best = lost;
            }
    if (best != lost_.end()) ++reidentified_;
    return best;
}

void Tracker::start_track(const cv::Mat& gray, const train::FaceBox& detection, double time_s) {
    Track track;
    track.smoother = LandmarkSmoother(settings_.smoothing);
    place_on_detection(track, gray, detection);
    const auto found = find_lost(gray, track, detection);
    if (found != lost_.end()) {
        track.state.id = found->track.state.id;
        track.evidence = found->track.evidence;
        track.state.identity = found->track.state.identity;
        track.state.identity_frames = found->track.state.identity_frames;
        track.appearance = std::move(found->track.appearance);
        lost_.erase(found);
        ++reacquired_;
    } else {
        track.state.id = next_id_++;
    }
    track.last_time = time_s;
    tracks_.push_back(std::move(track));
}

void Tracker::lose(Track&& track) { lost_.push_back({std::move(track), frame_, shot_}); }

bool Tracker::scene_cut(const cv::Mat& gray) {
    if (!(settings_.cut_threshold > 0)) return false;
    cv::Mat thumbnail;
    cv::resize(gray, thumbnail, cv::Size(32, 32), 0, 0, cv::INTER_AREA);
    scene_change_ = previous_thumbnail_.empty() ? 0.0 : cv::norm(thumbnail, previous_thumbnail_, cv::NORM_L1) / static_cast<double>(thumbnail.total());
    previous_thumbnail_ = thumbnail;
    return scene_change_ > settings_.cut_threshold;
}

bool Tracker::update(Track& track, double time_s, const cv::Mat& gray) {
    const cv::Size image = gray.size();
    FaceState& s = track.state;
    const double raw_iod = inter_ocular(s.raw_landmarks);
    if (!s.raw_landmarks.allFinite() || raw_iod < 3) return false;
    const LandmarkBounds b = bounds_of(s.raw_landmarks);
    if (b.centre.x() < 0 || b.centre.y() < 0 || b.centre.x() >= image.width || b.centre.y() >= image.height) return false;
    s.landmarks = settings_.track && settings_.smooth ? track.smoother.filter(s.raw_landmarks, time_s - track.last_time, b.width) : s.raw_landmarks;
    track.last_time = time_s;
    try {
        s.fit = fitter_.fit(s.landmarks, fit_options_);
    } catch (const core::Error&) {
        return false;  // degenerate landmarks: no face there
    }
    s.fit_error = s.fit.reprojection_rms_px / std::max(inter_ocular(s.landmarks), 1e-9);
    // A face the detector has just found stays; the check catches landmarks that have left the face.
    if (!s.from_detector && !(s.fit_error <= settings_.max_fit_error)) return false;
    track.last_good = s.landmarks;

    track.evidence += fit::identity_evidence(fitter_.model(), s.fit.camera, s.landmarks, identity_options_, s.fit.psi);
    s.identity = fit::solve_identity(track.evidence, settings_.lambda, fitter_.model().num_shape_components());
    ++s.identity_frames;
    // The per-frame baseline gives ids by place only: it needs no descriptors.
    if (settings_.track && settings_.max_reid_distance > 0 && track.good_frames++ % kAppearanceEvery == 0) {
        if (std::optional<cv::Mat> appearance = appearance_of(gray, s.landmarks)) {
            if (track.appearance.size() == kAppearanceViews) track.appearance.erase(track.appearance.begin());
            track.appearance.push_back(std::move(*appearance));
        }
    }
    return true;
}

const std::vector<FaceState>& Tracker::process(const cv::Mat& frame, double time_s) {
    ++frame_;
    const cv::Mat gray = train::to_gray8(frame);
    cut_ = scene_cut(gray);
    if (cut_) {
        ++cuts_;
        for (Track& track : tracks_) lose(std::move(track));
        tracks_.clear();
        ++shot_;
    }
    // Follow every face from its previous landmarks, through the box the detector would give them.
    bool drifted = false;
    if (settings_.track) {
        for (Track& track : tracks_) {
            const LandmarkBounds b = bounds_of(track.state.raw_landmarks);
            train::FaceBox box;
            box.view = track.state.box.view;
            box.width = track.calibration.width_ratio * b.width;
            box.centre = b.centre + b.width * track.calibration.offset;
            const train::FaceBox& kept = track.state.box;
            const double zone = settings_.box_dead_zone * kept.width;
            if ((box.centre - kept.centre).norm() > zone || std::abs(box.width - kept.width) > zone) track.state.box = box;
            track.state.from_detector = false;
            track.state.raw_landmarks = regressor_.predict(gray, track.state.box);
            const double scale = track.state.box.width / track.detected_width;
            track.drifted = !(scale <= settings_.max_scale_drift && scale >= 1 / settings_.max_scale_drift);
            drifted = drifted || track.drifted;
        }
    }
    const bool detect = !settings_.track || tracks_.empty() || drifted || frames_since_detection_ + 1 >= settings_.detect_every;
    if (detect) {
        std::vector<train::FaceBox> detections = detector_.detect(gray);
        ++detector_runs_;
        const auto unmatched = [&](const Track& t) { return !train::match_detection(detections, t.state.raw_landmarks); };
        if (fallback_ && (tracks_.empty() ? detections.empty() : std::any_of(tracks_.begin(), tracks_.end(), unmatched))) {
            ++fallback_runs_;
            for (const train::FaceBox& extra : fallback_->detect(gray)) {
                const bool known = std::any_of(detections.begin(), detections.end(), [&](const train::FaceBox& d) {
                    return (d.centre - extra.centre).norm() < 0.5 * std::max(d.width, extra.width);
                });
                if (!known) detections.push_back(extra);
            }
        }
        frames_since_detection_ = 0;
        std::vector<bool> used(detections.size(), false);
        if (settings_.track) {
            // A detection on a tracked face puts its landmarks back where the regressor was trained to
            // start (the smoothing hides the step); the others start faces. A drifted face the
            // detector does not find is lost.
            std::vector<Track> kept;
            for (Track& track : tracks_) {
                const auto match = train::match_detection(detections, track.state.raw_landmarks);
                if (!match) {
                    if (track.drifted || track.missed) {
                        ++losses_;
                        lose(std::move(track));
                    } else {
                        track.missed = true;  // looked for again in the next frame (below)
                        kept.push_back(std::move(track));
                    }
                    continue;
                }
                track.missed = false;
                for (std::size_t d = 0; d < detections.size(); ++d)
                    if (detections[d].centre == match->centre && detections[d].width == match->width) used[d] = true;
                place_on_detection(track, gray, *match);
                track.drifted = false;
                kept.push_back(std::move(track));
            }
            tracks_ = std::move(kept);
        } else {
            // The baseline: every face from this frame's detections; a face keeps its id (and fused
            // identity) when a detection lands on its previous landmarks.
            std::vector<Track> previous = std::move(tracks_);
            tracks_.clear();
            for (std::size_t d = 0; d < detections.size() && static_cast<int>(tracks_.size()) < settings_.max_faces; ++d) {
                used[d] = true;
                const auto same = std::find_if(previous.begin(), previous.end(), [&](const Track& t) {
                    return train::match_detection({detections[d]}, t.state.raw_landmarks).has_value();
                });
                Track track = same != previous.end() ? std::move(*same) : Track{};
                if (same == previous.end()) track.state.id = next_id_++;
                else previous.erase(same);
                place_on_detection(track, gray, detections[d]);
                track.last_time = time_s;
                tracks_.push_back(std::move(track));
            }
        }
        for (std::size_t d = 0; d < detections.size() && static_cast<int>(tracks_.size()) < settings_.max_faces; ++d)
            if (!used[d]) start_track(gray, detections[d], time_s);
    } else {
        ++frames_since_detection_;
    }
    if (std::any_of(tracks_.begin(), tracks_.end(), [](const Track& t) { return t.missed; }))
        frames_since_detection_ = settings_.detect_every;  // the detector looks again in the next frame
    // Two tracks on one face: the younger goes.
    std::sort(tracks_.begin(), tracks_.end(), [](const Track& a, const Track& b) { return a.state.id < b.state.id; });
    for (std::size_t a = 0; a < tracks_.size(); ++a)
        for (std::size_t b = tracks_.size(); b-- > a + 1;) {
            const LandmarkBounds first = bounds_of(tracks_[a].state.raw_landmarks), second = bounds_of(tracks_[b].state.raw_landmarks);
            if ((first.centre - second.centre).norm() < 0.3 * std::max(first.width, second.width))
                tracks_.erase(tracks_.begin() + static_cast<std::ptrdiff_t>(b));
        }

    states_.clear();
    std::vector<Track> kept;
    for (Track& track : tracks_) {
        if (update(track, time_s, gray)) {
            states_.push_back(track.state);
            kept.push_back(std::move(track));
        } else {
            ++losses_;
            lose(std::move(track));
            frames_since_detection_ = settings_.detect_every;  // look again in the next frame
        }
    }
    tracks_ = std::move(kept);
    // Kept while they may be found again nearby, and for re-identification (the most recent, with a
    // descriptor) for as long as there is room.
    const auto forgotten = [&](const LostTrack& lost) {
        return frame_ - lost.frame > settings_.reacquire_frames && (!(settings_.max_reid_distance > 0) || lost.track.appearance.empty());
    };
    std::erase_if(lost_, forgotten);
    if (lost_.size() > static_cast<std::size_t>(settings_.reid_faces))
        lost_.erase(lost_.begin(), lost_.end() - settings_.reid_faces);
    return states_;
}

}  // namespace facesynth::track
