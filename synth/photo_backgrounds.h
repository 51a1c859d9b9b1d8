#pragma once
// Backgrounds from annotated photographs with the annotated face cut away (docs/synth.md, "Backgrounds
// from photographs"): the strips of the photograph beside, above and below the face's extended box
// (the landmarks' box grown to take in the forehead, hair, ears and chin), so that no part of the
// labelled face can appear behind a rendered one. Faces nobody annotated are the caller's to reject
// (the CLI runs a face detector on every strip).
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace facesynth::synth {

// The landmarks' box grown by these shares of its width (each side) and height (above, below).
struct FaceExclusion {
    double side = 0.35;
    double above = 0.8;
    double below = 0.3;
};

// The face's extended box in an image (clipped to it).
[[nodiscard]] cv::Rect face_exclusion_box(const cv::Size& image, const Eigen::Matrix2Xd& landmarks, const FaceExclusion& grow = {});

// The strips of `image` outside face_exclusion_box (left, right, above, below), each at least
// `min_side` pixels on its shorter side; none of them meets the box. Throws core::Error when the
// landmarks are empty or not finite.
[[nodiscard]] std::vector<cv::Rect> background_regions(const cv::Size& image, const Eigen::Matrix2Xd& landmarks, int min_side,
                                                       const FaceExclusion& grow = {});

}  // namespace facesynth::synth
