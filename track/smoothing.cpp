#include "track/smoothing.h"

#include <cmath>
#include <numbers>

namespace facesynth::track {
namespace {

// The exponential smoothing factor of a first-order low-pass filter with this cutoff at this step.
double smoothing_factor(double cutoff_hz, double dt) {
    const double tau = 1.0 / (2.0 * std::numbers::pi * cutoff_hz);
    return 1.0 / (1.0 + tau / dt);
}

}  // namespace

Eigen::Matrix2Xd LandmarkSmoother::filter(const Eigen::Matrix2Xd& points, double dt, double face_width) {
    if (!previous_ || previous_->cols() != points.cols() || !(dt > 0) || !(face_width > 0)) {
        previous_ = points;
        speed_ = Eigen::Matrix2Xd::Zero(2, points.cols());
        return points;
    }
    const Eigen::Matrix2Xd raw_speed = (points - *previous_) / (dt * face_width);
    speed_ += smoothing_factor(settings_.derivative_cutoff_hz, dt) * (raw_speed - speed_);
    Eigen::Matrix2Xd out(2, points.cols());
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
        const double cutoff = settings_.min_cutoff_hz + settings_.speed_coefficient * speed_.col(i).norm();
        const double a = smoothing_factor(cutoff, dt);
        out.col(i) = previous_->col(i) + a * (points.col(i) - previous_->col(i));
    }
    previous_ = out;
    return out;
}

}  // namespace facesynth::track
