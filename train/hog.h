#pragma once
// Histogram of oriented gradients on a small square patch, in the UoCTTI layout (Felzenszwalb et al.
// 2010, as VLFeat implements it) with O orientations: per cell 2·O signed-orientation bins, O
// unsigned-orientation bins and 4 texture (gradient energy) bins. docs/train.md has the exact layout
// and normalisation.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <span>

namespace facesynth::train {

inline constexpr int kDefaultHogOrientations = 4;
inline constexpr int kMaxHogCells = 16;
inline constexpr int kMaxHogOrientations = 16;

// The feature layout of one landmark's patch: cells per side and unsigned orientations.
struct HogLayout {
    int cells = 3;
    int orientations = kDefaultHogOrientations;

    [[nodiscard]] constexpr int dims_per_cell() const { return 3 * orientations + 4; }
    [[nodiscard]] constexpr int dims() const { return cells * cells * dims_per_cell(); }
    friend bool operator==(const HogLayout&, const HogLayout&) = default;
};

// HOG of an 8-bit grey patch of (cells·cell_size + 2)² pixels: the outer ring only feeds the
// gradients. Writes layout.dims() floats to `out`, cells in row-major order (top row first), each
// cell [signed 0..2O-1 | unsigned 0..O-1 | texture 0..3]. Signed bin k holds gradients whose direction
// is nearest to angle k·180°/O measured from +x toward +y (image y points down).
void compute_hog(const cv::Mat& patch, const HogLayout& layout, int cell_size, std::span<float> out);

// Resamples the square of side `side_px` image pixels centred on `centre` (0-based pixel coordinates)
// to a (cells·cell_size + 2)² patch with bilinear interpolation and replicated borders.
void extract_patch(const cv::Mat& gray, const Eigen::Vector2d& centre, double side_px, int cells, int cell_size,
                   cv::Mat& patch);

}  // namespace facesynth::train
