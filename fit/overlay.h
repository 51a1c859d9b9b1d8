#pragma once
// Drawing a fit over its photograph: the projected mesh (front-facing triangles as a wireframe), the
// observed landmarks and the model's projected landmarks. Reused by `facesynth fit` and `frontalise`.
#include "morph/mesh.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace facesynth::fit {

// `image` (8-bit, 1 or 3 channels) is copied to BGR and drawn on. `vertices_px`: 2 x V projected mesh
// vertices (0-based pixels). A triangle is drawn when it faces the camera (clockwise in the image,
// since the model's counter-clockwise front faces are mirrored by the y-down image axis).
// `observed` (green) and `fitted` (red) are 2 x 68 landmarks; NaN columns are skipped.
[[nodiscard]] cv::Mat draw_fit_overlay(const cv::Mat& image, const Eigen::Matrix2Xd& vertices_px,
                                       const std::vector<morph::Triangle>& triangles, const Eigen::Matrix2Xd& observed,
                                       const Eigen::Matrix2Xd& fitted);

}  // namespace facesynth::fit
