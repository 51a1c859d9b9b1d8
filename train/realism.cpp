#include "train/realism.h"

#include "morph/error.h"
#include "morph/image_header.h"
#include "morph/landmarks.h"
#include "train/sdm.h"

#include <opencv2/imgcodecs.hpp>

#include <limits>

namespace facesynth::train {

RealismSide measure_realism(const std::vector<LabelledImage>& images, const LandmarkRegressor& regressor, DetectorKind detector_kind,
                            const std::function<void()>& on_image) {
    RealismSide side;
    side.bias = Eigen::Matrix2Xd::Zero(2, kNumIbugLandmarks);
    const FaceDetector detector(detector_kind);
    for (const LabelledImage& image : images) {
        ++side.faces;
        double nme = std::numeric_limits<double>::infinity();
        try {
            const Eigen::Matrix2Xd truth = read_pts(image.pts);
            if (truth.cols() != kNumIbugLandmarks) throw file_error(image.pts.string(), "expected 68 points");
            check_image_not_too_large(image.image);
            const cv::Mat loaded = cv::imread(image.image.string(), cv::IMREAD_UNCHANGED);
            if (loaded.empty()) throw file_error(image.image.string(), "cannot read image");
            const cv::Mat gray = to_gray8(loaded);
            if (const auto box = match_detection(detector.detect(gray), truth)) {
                const Eigen::Matrix2Xd predicted = regressor.predict(gray, *box);
                nme = landmark_nme(predicted, truth);
                side.bias += face_frame_offsets(predicted, truth);
                ++side.detected;
            }
        } catch (const Error& e) {
            side.warnings.push_back(std::string(e.what()) + " (counted as a miss)");
        }
        side.nmes.push_back(nme);
        if (on_image) on_image();
    }
    if (side.detected > 0) side.bias /= side.detected;
    side.nme = summarise_nme(side.nmes);
    return side;
}

}  // namespace facesynth::train
