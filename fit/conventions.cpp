#include "fit/conventions.h"

#include "core/error.h"
#include "morph/landmarks.h"

#include <cmath>

namespace facesynth::fit {

ConventionStudy study_conventions(const Fitter& fitter, const std::vector<Eigen::Matrix2Xd>& annotations, const FitOptions& options,
                                  double max_abs_yaw_deg) {
    ConventionStudy study;
    Eigen::Matrix2Xd sum = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks), squares = sum;
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
            ++study.faces;
        } catch (const core::Error&) {
            ++study.failed;
        }
    }
    const double n = std::max(study.faces, 1);
    study.mean = sum / n;
    study.stddev = (squares / n - study.mean.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
    return study;
}

}  // namespace facesynth::fit
