#pragma once
// Face-metered exposure. Cameras and photographers meter on the face, so a photograph's face lands in a
// narrow band of brightness whatever light falls on it, and brighter than its surroundings more often
// than not (helen_train: face grey level 0.49 ± 0.13, docs/synth.md "Exposure"). The renderer's light
// alone leaves faces darker and more varied (0.40 ± 0.13 in the recipe's renders).
#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace facesynth::synth {

// Mean grey level (ITU-R BT.601 weights over 8-bit RGB, in [0, 1]) of the fully covered pixels of the
// face layer `rgb` inside the convex hull of `landmarks` (0-based px); NaN when there is none.
[[nodiscard]] double face_luminance(const cv::Mat& rgb, const cv::Mat& coverage, const Eigen::Matrix2Xd& landmarks);

// Changes the exposure of the face layer `rgb` (8-bit RGB premultiplied by `coverage`, encoded as
// linear^(1/gamma)) so that face_luminance reaches `target`: its linear radiance is multiplied by one
// gain, within [1/4, 4] (two stops; beyond them an 8-bit render would band), and clipped at white as a
// sensor clips. Returns the linear gain (1 when the hull covers no face pixel).
double expose_face(cv::Mat& rgb, const cv::Mat& coverage, const Eigen::Matrix2Xd& landmarks, double target, double gamma);

}  // namespace facesynth::synth
