#include "fit/conventions.h"

#include "core/error.h"
#include "morph/landmarks.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace facesynth::fit {

ConventionStudy study_conventions(const Fitter& fitter, const std::vector<Eigen::Matrix2Xd>& annotations, const FitOptions& options,
                                  double max_abs_yaw_deg) {
    ConventionStudy study;
    Eigen::Matrix2Xd sum = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks), squares = sum;
    // For the depth slopes: sums of s = sin(yaw), s² and s · x offset.
    Eigen::RowVectorXd sum_s_x = Eigen::RowVectorXd::Zero(morph::kNumIbugLandmarks);
    double sum_s = 0, sum_s2 = 0;
    for (const Eigen::Matrix2Xd& annotation : annotations) {
        try {
            const FitResult result = fitter.fit(annotation, options);
            if (std::abs(result.pose.angles.yaw) > max_abs_yaw_deg) {
                ++study.skipped_pose;
                continue;
            }
            const Eigen::Matrix2Xd offsets = morph::face_frame_offsets(annotation, result.projected);
            sum += offsets;
            squares += offsets.cwiseAbs2();
            const double s = std::sin(result.pose.angles.yaw * std::numbers::pi / 180.0);
            sum_s += s;
            sum_s2 += s * s;
            sum_s_x += s * offsets.row(0);
            ++study.faces;
        } catch (const core::Error&) {
            ++study.failed;
        }
    }
    const double n = std::max(study.faces, 1);
    study.mean = sum / n;
    study.stddev = (squares / n - study.mean.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
    const double mean_s = sum_s / n, var_s = std::max(0.0, sum_s2 / n - mean_s * mean_s);
    study.sin_yaw_stddev = std::sqrt(var_s);
    if (study.faces >= 3 && study.sin_yaw_stddev >= kMinDepthYawSpread)
        study.depth = (sum_s_x / n - mean_s * study.mean.row(0)) / var_s;
    return study;
}

}  // namespace facesynth::fit
