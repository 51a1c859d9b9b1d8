#pragma once
// Histogram of oriented gradients on a small square patch, in the UoCTTI layout (Felzenszwalb et al.
// 2010, as VLFeat implements it) with 4 orientations: per cell 8 signed-orientation bins, 4
// unsigned-orientation bins and 4 texture (gradient energy) bins = 16 values. docs/train.md has the
// exact layout and normalisation.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <span>

namespace facesynth::train {

inline constexpr int kHogOrientations = 4;
inline constexpr int kHogDimsPerCell = 4 * kHogOrientations;  // 2·O signed + O unsigned + 4 texture

[[nodiscard]] constexpr int hog_dims(int cells_per_side) {
    return cells_per_side * cells_per_side * kHogDimsPerCell;
}

// HOG of an 8-bit grey patch of (cells·cell_size + 2)² pixels: the outer ring only feeds the
// gradients. Writes hog_dims(cells) floats to `out`, cells in row-major order (top row first), each
// cell [signed 0..7 | unsigned 0..3 | texture 0..3]. Signed bin k holds gradients whose direction is
// nearest to angle k·45° measured from +x toward +y (image y points down).
void compute_hog(const cv::Mat& patch, int cells, int cell_size, std::span<float> out);

// Resamples the square of side `side_px` image pixels centred on `centre` (0-based pixel coordinates)
// to a (cells·cell_size + 2)² patch with bilinear interpolation and replicated borders.
void extract_patch(const cv::Mat& gray, const Eigen::Vector2d& centre, double side_px, int cells, int cell_size,
                   cv::Mat& patch);

}  // namespace facesynth::train
