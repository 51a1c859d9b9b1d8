#include "train/hog.h"

#include "core/error.h"


#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <vector>

namespace facesynth::train {
namespace {

constexpr float kClamp = 0.2f;
// VLFeat's texture scale (1 / sqrt(18), the same for every O): keeps texture values in the range of the others.
constexpr float kTextureScale = 0.2357f;

// The signed bin of gradient (gx, gy) among 2·O directions k·180°/O: the largest |projection| on the O
// unsigned directions, its sign picking k or k + O.
int nearest_of(float gx, float gy, int orientations, const std::array<float, kMaxHogOrientations>& cos_k,
               const std::array<float, kMaxHogOrientations>& sin_k) {
    int best = 0;
    float best_dot = 0.f;
    for (int k = 0; k < orientations; ++k) {
        const float dot = gx * cos_k[static_cast<std::size_t>(k)] + gy * sin_k[static_cast<std::size_t>(k)];
        if (std::abs(dot) > std::abs(best_dot)) {
            best = k;
            best_dot = dot;
        }
    }
    return best_dot > 0.f ? best : best + orientations;
}

// The same for O = 4 (directions k·45°) by sectors split at 22.5°: the same bins (models trained with
// either are byte-identical) and detection a few per cent faster than with the loop, so the default keeps it.
int nearest_of_eight(float gx, float gy) {
    constexpr float kTan22_5 = 0.41421356f;
    const float ax = std::abs(gx), ay = std::abs(gy);
    if (ay < kTan22_5 * ax) return gx > 0.f ? 0 : 4;
    if (ax < kTan22_5 * ay) return gy > 0.f ? 2 : 6;
    if ((gx > 0.f) == (gy > 0.f)) return gx > 0.f ? 1 : 5;
    return gy > 0.f ? 3 : 7;
}

}  // namespace

void compute_hog(const cv::Mat& patch, const HogLayout& layout, int cell_size, std::span<float> out) {
    const int cells = layout.cells;
    const int orientations = layout.orientations;
    if (orientations < 1 || orientations > kMaxHogOrientations)
        throw core::Error("compute_hog: " + std::to_string(orientations) + " orientations (1-" + std::to_string(kMaxHogOrientations) + ")");
    const int side = cells * cell_size + 2;
    if (patch.type() != CV_8UC1 || patch.rows != side || patch.cols != side)
        throw core::Error("compute_hog: expected an 8-bit grey patch of " + std::to_string(side) + " pixels square");
    if (static_cast<int>(out.size()) != layout.dims()) throw core::Error("compute_hog: output size mismatch");

    // Unsigned direction k lies at k·180°/O; the signed bin is k where the gradient points along it
    // and k + O where it points against it: the nearest of the 2·O signed directions.
    // (O = 4 bins by its sector tests and needs no table: this runs once per landmark and stage.)
    std::array<float, kMaxHogOrientations> cos_k{}, sin_k{};
    const bool sectors = orientations == kDefaultHogOrientations;
    for (int k = 0; k < (sectors ? 0 : orientations); ++k) {
        const double angle = k * 3.14159265358979323846 / orientations;
        cos_k[static_cast<std::size_t>(k)] = static_cast<float>(std::cos(angle));
        sin_k[static_cast<std::size_t>(k)] = static_cast<float>(std::sin(angle));
    }
    const int signed_bins = 2 * orientations;
    const int dims_per_cell = layout.dims_per_cell();
    const int num_cells = cells * cells;
    std::vector<float> hist(static_cast<std::size_t>(num_cells) * signed_bins, 0.f);
    for (int y = 1; y <= side - 2; ++y) {
        const std::uint8_t* above = patch.ptr<std::uint8_t>(y - 1);
        const std::uint8_t* row = patch.ptr<std::uint8_t>(y);
        const std::uint8_t* below = patch.ptr<std::uint8_t>(y + 1);
        float* cell_row = hist.data() + static_cast<std::size_t>((y - 1) / cell_size) * cells * signed_bins;
        for (int x = 1; x <= side - 2; ++x) {
            const float gx = static_cast<float>(row[x + 1]) - static_cast<float>(row[x - 1]);
            const float gy = static_cast<float>(below[x]) - static_cast<float>(above[x]);
            if (gx == 0.f && gy == 0.f) continue;
            const int bin = sectors ? nearest_of_eight(gx, gy) : nearest_of(gx, gy, orientations, cos_k, sin_k);
            cell_row[((x - 1) / cell_size) * signed_bins + bin] += std::sqrt(gx * gx + gy * gy);
        }
    }

    // Squared norm of each cell's unsigned histogram: the block energies used for normalisation.
    std::vector<float> energy(static_cast<std::size_t>(num_cells));
    for (int c = 0; c < num_cells; ++c) {
        float e = 0.f;
        for (int k = 0; k < orientations; ++k) {
            const float u = hist[c * signed_bins + k] + hist[c * signed_bins + k + orientations];
            e += u * u;
        }
        energy[c] = e;
    }
    const auto energy_at = [&](int cy, int cx) {
        cy = std::clamp(cy, 0, cells - 1);
        cx = std::clamp(cx, 0, cells - 1);
        return energy[cy * cells + cx];
    };

    for (int cy = 0; cy < cells; ++cy) {
        for (int cx = 0; cx < cells; ++cx) {
            const int c = cy * cells + cx;
            // The four 2x2 blocks that contain this cell, in the order (-,-), (+,-), (-,+), (+,+).
            std::array<float, 4> factor{};
            int b = 0;
            for (int dy : {-1, 1}) {
                for (int dx : {-1, 1}) {
                    const float block = energy_at(cy, cx) + energy_at(cy, cx + dx) + energy_at(cy + dy, cx) +
                                        energy_at(cy + dy, cx + dx);
                    factor[b++] = 1.f / std::sqrt(block + 1e-4f);
                }
            }
            const float* h = hist.data() + static_cast<std::size_t>(c) * signed_bins;
            float* f = out.data() + static_cast<std::size_t>(c) * dims_per_cell;
            std::fill(f, f + dims_per_cell, 0.f);
            for (int k = 0; k < signed_bins; ++k)
                for (int n = 0; n < 4; ++n) f[k] += 0.5f * std::min(h[k] * factor[n], kClamp);
            for (int k = 0; k < orientations; ++k) {
                const float u = h[k] + h[k + orientations];
                for (int n = 0; n < 4; ++n) {
                    const float clamped = std::min(u * factor[n], kClamp);
                    f[signed_bins + k] += 0.5f * clamped;
                    f[signed_bins + orientations + n] += kTextureScale * clamped;
                }
            }
        }
    }
}

void extract_patch(const cv::Mat& gray, const Eigen::Vector2d& centre, double side_px, int cells, int cell_size,
                   cv::Mat& patch) {
    if (gray.type() != CV_8UC1 || gray.empty()) throw core::Error("extract_patch: expected a non-empty 8-bit grey image");
    const int inner = cells * cell_size;
    const int side = inner + 2;
    patch.create(side, side, CV_8UC1);
    // Output pixel (u, v) samples centre + step·(u - mid, v - mid), bilinear, borders replicated.
    // (Written out rather than cv::warpAffine: per-call overhead dominates for patches this small.)
    const float step = static_cast<float>(side_px / inner);
    const float mid = (side - 1) / 2.0f;
    const float x_start = static_cast<float>(centre.x()) - step * mid;
    const float y_start = static_cast<float>(centre.y()) - step * mid;
    const int max_x = gray.cols - 1, max_y = gray.rows - 1;
    // Column offsets and weights are the same for every output row.
    int x_low[64 * 8 + 2], x_high[64 * 8 + 2];
    float x_weight[64 * 8 + 2];
    if (side > static_cast<int>(std::size(x_low))) throw core::Error("extract_patch: patch too large");
    for (int u = 0; u < side; ++u) {
        const float x = std::clamp(x_start + step * static_cast<float>(u), 0.f, static_cast<float>(max_x));
        const int x0 = std::min(static_cast<int>(x), max_x);
        x_low[u] = x0;
        x_high[u] = std::min(x0 + 1, max_x);
        x_weight[u] = x - static_cast<float>(x0);
    }
    for (int v = 0; v < side; ++v) {
        const float y = std::clamp(y_start + step * static_cast<float>(v), 0.f, static_cast<float>(max_y));
        const int y0 = std::min(static_cast<int>(y), max_y);
        const float wy = y - static_cast<float>(y0);
        const std::uint8_t* top = gray.ptr<std::uint8_t>(y0);
        const std::uint8_t* bottom = gray.ptr<std::uint8_t>(std::min(y0 + 1, max_y));
        std::uint8_t* out = patch.ptr<std::uint8_t>(v);
        for (int u = 0; u < side; ++u) {
            const float wx = x_weight[u];
            const float upper = top[x_low[u]] + wx * static_cast<float>(top[x_high[u]] - top[x_low[u]]);
            const float lower = bottom[x_low[u]] + wx * static_cast<float>(bottom[x_high[u]] - bottom[x_low[u]]);
            out[u] = static_cast<std::uint8_t>(upper + wy * (lower - upper) + 0.5f);  // NOLINT(bugprone-incorrect-roundings): a mix of bytes, never negative
        }
    }
}

}  // namespace facesynth::train
