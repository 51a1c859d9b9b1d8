#include "train/realism.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "train/sdm.h"

#include <limits>

namespace facesynth::train {

RealismSide measure_realism(const std::vector<LabelledImage>& images, const LandmarkRegressor& regressor, DetectorKind detector_kind,
                            const std::function<void()>& on_image) {
    RealismSide side;
    side.bias = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks);
    const FaceDetector detector(detector_kind);
    for (const LabelledImage& image : images) {
        ++side.faces;
        double nme = std::numeric_limits<double>::infinity();
        try {
            const auto [truth, gray] = load_labelled_face(image);
            if (const auto box = match_detection(detector.detect(gray), truth)) {
                const Eigen::Matrix2Xd predicted = regressor.predict(gray, *box);
                nme = landmark_nme(predicted, truth);
                side.bias += morph::face_frame_offsets(predicted, truth);
                ++side.detected;
            }
        } catch (const core::Error& e) {
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
