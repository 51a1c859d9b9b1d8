#pragma once
// Landmark smoothing without lag: the 1€ filter (Casiez, Roussel and Vogel, CHI 2012) per landmark.
// A low-pass filter whose cutoff rises with speed: still faces are smoothed hard (jitter removed),
// moving ones barely (no lag). Speeds are measured in face widths per second, so the settings do not
// depend on the face's size in the image.
#include <Eigen/Core>

#include <optional>

namespace facesynth::track {

struct SmoothingSettings {
    double min_cutoff_hz = 1.0;         // cutoff at rest: lower removes more jitter
    double speed_coefficient = 20.0;    // cutoff rise per face width per second of landmark speed (the 1€ β)
    double derivative_cutoff_hz = 1.0;  // cutoff of the speed estimate
};

class LandmarkSmoother {
public:
    LandmarkSmoother() = default;
    explicit LandmarkSmoother(SmoothingSettings settings) : settings_(settings) {}
    // The smoothed points for `points` (2 x N pixels) seen `dt` seconds after the previous call, with
    // the face `face_width` pixels wide. The first call (or after reset) returns `points`.
    [[nodiscard]] Eigen::Matrix2Xd filter(const Eigen::Matrix2Xd& points, double dt, double face_width);
    void reset() { previous_.reset(); }

private:
    SmoothingSettings settings_;
    std::optional<Eigen::Matrix2Xd> previous_;  // the last output
    Eigen::Matrix2Xd speed_;                    // smoothed velocity, face widths per second
};

}  // namespace facesynth::track
