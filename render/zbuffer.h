#pragma once
// A z-buffer rasterised on the CPU, for visibility passes too small or too many for the renderer's
// context: the isomap's (frontal/isomap.h), face profiling's (profile/scene.cpp) and ambient
// occlusion's (render/ambient_occlusion.h).
#include "morph/mesh.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <span>
#include <vector>

namespace facesynth::render {

// The visibility pass: the nearest surface of a mesh seen orthographically, rasterised on the CPU.
// `pixels` (2 x V) are the vertices' positions in a width x height image (OpenCV pixels: the centre of
// the top-left pixel is (0, 0)) and `depth` (V) their camera-space z in mm. Returns CV_32FC1 with, at
// each pixel centre, the smallest z of the triangles covering it, 0 where none does. Triangles that
// wind clockwise in the image are back faces and are culled (the renderer's rule for meshes whose
// front faces wind counter-clockwise seen from the front, as every model here). A pixel centre on an
// edge counts for both triangles. Agrees with the renderer's depth-only pass (RenderSettings::depth_only)
// but for pixel centres within rounding of the outline (test): llvmpipe spends most of that pass on
// per-triangle setup, about 2.5 ms for a 7,480-vertex head at 256², this loop about 1 ms.
[[nodiscard]] cv::Mat orthographic_zbuffer(const Eigen::Matrix2Xf& pixels, std::span<const float> depth,
                                           const std::vector<morph::Triangle>& triangles, int width, int height);

}  // namespace facesynth::render
