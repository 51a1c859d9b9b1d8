#pragma once
// Face tracking (docs/track.md): each face is followed from its previous landmarks, the face detector
// runs every `detect_every` frames or when a face is lost, a per-frame 3DMM fit gives pose and
// expression and decides whether the landmarks are still on a face, landmarks are smoothed without
// lag, and the identity is fused over the face's frames.
#include "fit/fit.h"
#include "morph/pose.h"
#include "track/smoothing.h"
#include "train/face_box.h"
#include "train/regressor.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>
#include <vector>

namespace facesynth::track {

struct TrackerSettings {
    int detect_every = 5;       // frames between detector runs while faces are tracked
    int max_faces = 1;          // faces followed at once (the largest detections first)
    // false: the per-frame baseline: the detector every frame, landmarks from its box, no smoothing.
    bool track = true;
    bool smooth = true;
    SmoothingSettings smoothing;
    // Lost when the fit's reprojection RMS exceeds this share of the inter-ocular distance (landmarks
    // that no face shape explains), measured on synthetic clips (docs/track.md).
    double max_fit_error = 0.08;
    // A face found again within this many frames of its loss, where it was lost, keeps its id and identity.
    int reacquire_frames = 45;
    // Scene cuts: a frame whose grey 32 x 32 thumbnail differs from the previous frame's by more than this
    // mean absolute difference (grey levels) starts a new shot. The faces followed are let go and the
    // detector runs: landmarks left where a face was would follow whoever is there in the new shot.
    // 0: no cut detection. Measured on the real clip and on clips cut together (docs/track.md).
    double cut_threshold = 18;
    // Re-identification: a new face whose appearance (the LBPH distance of its eye-aligned crop to the
    // nearest of a lost face's crops, recognition/appearance.h) is below this takes the lost face's id
    // and fused identity: faces that come back after a cut, or later than reacquire_frames. 0: off.
    double max_reid_distance = 70;
    int reid_faces = 32;  // lost faces remembered for re-identification (the most recent)
    // Followed boxes that grow or shrink by more than this factor since the face's last detection call
    // the detector in the next frame; a face it does not find there is lost (landmarks drifting in scale).
    double max_scale_drift = 1.3;
    // A followed face keeps its box until its landmarks' box moves or scales by more than this share of
    // its width: the regressor's output depends on its box, so a box that followed every wobble of the
    // output would let the landmarks wander on a still face.
    double box_dead_zone = 0.04;

    double lambda = fit::FitOptions{}.lambda;  // prior weight of the per-frame fits and the fused identity
    // With dlib's detector: where it finds no face at all, or misses a followed one, the multi-view
    // cascades look too (dlib's HOG detector does not find faces much under 40 pixels).
    bool multiview_fallback = true;
};

struct FaceState {
    int id = 0;
    Eigen::Matrix2Xd landmarks;      // 2 x 68, 0-based pixels (smoothed when tracking)
    Eigen::Matrix2Xd raw_landmarks;  // the regressor's output
    train::FaceBox box;              // the box the regressor ran on
    bool from_detector = false;      // that box came from this frame's detector run
    double fit_error = 0;            // reprojection RMS / inter-ocular distance of the frame's fit
    fit::FitResult fit;              // the frame's fit (camera, pose, expression) to `landmarks`
    std::vector<float> identity;     // fused over the face's frames so far (σ units)
    int identity_frames = 0;
};

class Tracker {
public:
    // `fitter` (and its model) must outlive the tracker.
    Tracker(const train::LandmarkRegressor& regressor, train::DetectorKind detector, const fit::Fitter& fitter, TrackerSettings settings = {});

    // The faces in `frame` (8-bit BGR or grey) seen at `time_s` seconds; faces lost in this frame are
    // not among them.
    const std::vector<FaceState>& process(const cv::Mat& frame, double time_s);

    [[nodiscard]] int detector_runs() const { return detector_runs_; }
    [[nodiscard]] int fallback_runs() const { return fallback_runs_; }  // runs of the multi-view fallback
    [[nodiscard]] int losses() const { return losses_; }       // faces dropped by the fit check
    [[nodiscard]] int reacquired() const { return reacquired_; }  // losses found again with their id
    [[nodiscard]] int cuts() const { return cuts_; }              // scene cuts seen
    [[nodiscard]] bool cut() const { return cut_; }               // the last frame began a new shot
    // The last frame's thumbnail difference from the frame before (grey levels; 0 for the first frame
    // and without cut detection).
    [[nodiscard]] double scene_change() const { return scene_change_; }
    [[nodiscard]] int reidentified() const { return reidentified_; }  // of reacquired: by appearance

private:
    struct BoxCalibration {  // the detector's box relative to the landmarks' bounding box
        double width_ratio = 1;
        Eigen::Vector2d offset = Eigen::Vector2d::Zero();  // in landmark box widths
    };
    struct Track {
        FaceState state;
        LandmarkSmoother smoother;
        BoxCalibration calibration;
        double detected_width = 0;      // the box width at the last detection on this face
        bool drifted = false;           // this frame's box is off that width by more than max_scale_drift
        // The last detector run did not find this face: it looks again in the next frame and the face
        // is lost if it is not found there either (landmarks left on the background after a cut).
        bool missed = false;
        Eigen::Matrix2Xd last_good;     // the landmarks of the last frame that passed the fit check
        fit::IdentityEvidence evidence;
        double last_time = 0;
        std::vector<cv::Mat> appearance;  // LBPH descriptors of some of its good frames (the latest few)
        int good_frames = 0;
    };
    struct LostTrack {
        Track track;
        int frame = 0;  // when it was lost
        int shot = 0;   // in which shot
    };

    void start_track(const cv::Mat& gray, const train::FaceBox& detection, double time_s);
    // The lost face a new track is: the one lost nearby not long ago in this shot, else the one its
    // appearance matches (with max_reid_distance); lost_.end() when none.
    std::vector<LostTrack>::iterator find_lost(const cv::Mat& gray, const Track& track, const train::FaceBox& detection);
    // True when `gray` begins a new shot (cut_threshold).
    bool scene_cut(const cv::Mat& gray);
    void lose(Track&& track);
    // Landmarks from a detector box; the box's relation to them calibrates the boxes that follow.
    void place_on_detection(Track& track, const cv::Mat& gray, const train::FaceBox& detection) const;
    // Smooths, fits and checks a track's new landmarks; false when the face is lost.
    bool update(Track& track, double time_s, const cv::Mat& gray);

    const train::LandmarkRegressor& regressor_;
    train::FaceDetector detector_;
    std::optional<train::FaceDetector> fallback_;
    const fit::Fitter& fitter_;
    TrackerSettings settings_;
    fit::FitOptions fit_options_, identity_options_;
    std::vector<Track> tracks_;
    std::vector<LostTrack> lost_;
    std::vector<FaceState> states_;
    cv::Mat previous_thumbnail_;
    int frame_ = -1;
    int shot_ = 0;
    bool cut_ = false;
    double scene_change_ = 0;
    int frames_since_detection_ = 0;
    int next_id_ = 0;
    int detector_runs_ = 0, fallback_runs_ = 0, losses_ = 0, reacquired_ = 0, cuts_ = 0, reidentified_ = 0;
};

}  // namespace facesynth::track
