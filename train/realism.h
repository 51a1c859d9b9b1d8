#pragma once
// The realism measure (docs/textures.md, "Realism"): a landmark predictor trained on real photographs
// (dlib's) run on near-frontal renders and on near-frontal photographs. A render that a real-trained
// predictor cannot read is not realistic yet: the ratio of its NMEs, the failure rates and the
// per-landmark bias (where the predictor puts each point against our label) say how far off it is.
#include "train/dataset.h"
#include "train/face_box.h"
#include "train/metrics.h"
#include "train/regressor.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::train {

struct RealismSide {
    int faces = 0;      // images evaluated
    int detected = 0;   // the detector found the labelled face
    NmeSummary nme;     // misses count as failures (NmeSummary's convention)
    std::vector<double> nmes;  // per image, +inf for a miss
    // Mean of (prediction - label) over the detected faces in the label's face frame, in inter-ocular
    // distances (morph/landmarks.h face_frame_offsets): 2 x 68.
    Eigen::Matrix2Xd bias;
    std::vector<std::string> warnings;  // unreadable images or .pts files (counted as misses)
    // The face's grey level (mean over the labelled landmarks' convex hull, [0, 1]) over all readable
    // images: how brightly the face is exposed, which synth's face-metered exposure matches
    // (lighting.face_luminance_mean, synth/exposure.h).
    double face_grey_mean = 0, face_grey_stddev = 0;
    // The skin under the chin against the face: the mean grey of a disc (radius 0.06 inter-ocular
    // distances) centred 0.12 below the labelled chin (iBUG 9, face frame), and of one 0.30 below it,
    // each over the face's grey as above; means over the images where the disc lies inside. Photographs
    // are darker there than lit skin (the chin and jaw hide the sky from the neck).
    double under_chin_shade = 0, neck_shade = 0;
    // Fine detail: face_detail (below) averaged over the readable images. Renders that are smoother
    // than photographs at the size a detector reads them give its finest stages other gradients.
    double face_detail = 0;
    // The labels' outer-eye-corner distance in pixels (median over the readable images, before any
    // rescaling), and the median factor the images were scaled by (1 without rescaling).
    double iod_px_median = 0, scale_median = 1;
};

// The face's fine detail: the spread (standard deviation) of the 3x3 Laplacian of the grey image, in
// [0, 1] grey levels, inside the label's convex hull (2 px in from its border), the image first scaled
// so that the label's outer eye corners lie kDetailIodPx apart (area averaging when shrinking). NaN
// when the hull is empty or the label degenerate.
inline constexpr double kDetailIodPx = 72;
[[nodiscard]] double face_detail(const cv::Mat& gray, const Eigen::Matrix2Xd& label);

// Runs `regressor` on the faces `detector` finds in `images` (the detection matching each label). With
// `iod_px`, each image and its label are first scaled so that the label's outer eye corners lie iod_px
// pixels apart (area averaging when shrinking): the face as if photographed at that size.
[[nodiscard]] RealismSide measure_realism(const std::vector<LabelledImage>& images, const LandmarkRegressor& regressor,
                                          DetectorKind detector, const std::function<void()>& on_image = {},
                                          std::optional<double> iod_px = std::nullopt);

// `facesynth eval realism` as a function (the CLI and the Python package call it).
struct RealismSettings {
    std::string data;     // a `facesynth synth` dataset (its meta/ gives each render's yaw)
    std::string photos;   // optional: photographs with .pts
    double max_yaw_deg = 20;  // near-frontal: |yaw| at most this
    // Photographs scaled to the renders' median face size (outer-eye-corner distance) before they are
    // read: a photograph's face is often twice a 256² render's, and a predictor reads larger faces better.
    bool match_face_size = false;
};
// A photograph's yaw from its 68-point annotation (the built-in model fitted to it: fit::annotated_yaw,
// passed in because train does not depend on fit); nullopt when it cannot be estimated.
using AnnotationYaw = std::function<std::optional<double>(const Eigen::Matrix2Xd& annotation)>;
struct RealismReport {
    RealismSide renders, photos;  // photos empty without settings.photos
    double nme_ratio = 0;         // renders' NME mean / photographs' (0 without photographs)
    std::vector<int> largest_gaps;  // landmarks (0-based) by decreasing |render bias - photo bias|
    nlohmann::json json;          // the flat keys of `eval realism --json`
};
// Throws core::Error naming the folder when it has no near-frontal render or photograph.
[[nodiscard]] RealismReport evaluate_realism(const RealismSettings& settings, const LandmarkRegressor& regressor, DetectorKind detector,
                                             const AnnotationYaw& photo_yaw, const std::function<void(std::size_t total)>& on_start = {},
                                             const std::function<void()>& on_image = {});

}  // namespace facesynth::train
