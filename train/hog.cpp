#include "train/hog.h"

#include "morph/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace facesynth::train {
namespace {

constexpr int kSignedBins = 2 * kHogOrientations;
constexpr float kClamp = 0.2f;
// VLFeat's texture scale: 1 / sqrt(2 · O) · ... keeps texture values in the range of the others.
constexpr float kTextureScale = 0.2357f;

}  // namespace

void compute_hog(const cv::Mat& patch, int cells, int cell_size, std::span<float> out) {
    const int side = cells * cell_size + 2;
    if (patch.type() != CV_8UC1 || patch.rows != side || patch.cols != side)
        throw Error("compute_hog: expected an 8-bit grey patch of " + std::to_string(side) + " pixels square");
    if (static_cast<int>(out.size()) != hog_dims(cells)) throw Error("compute_hog: output size mismatch");

    // Unit vectors of the unsigned orientations 0°, 45°, 90°, 135°.
    static constexpr float kInvSqrt2 = 0.70710678f;
    static constexpr std::array<float, kHogOrientations> kCos = {1.f, kInvSqrt2, 0.f, -kInvSqrt2};
    static constexpr std::array<float, kHogOrientations> kSin = {0.f, kInvSqrt2, 1.f, kInvSqrt2};

    const int num_cells = cells * cells;
    std::vector<float> hist(static_cast<std::size_t>(num_cells) * kSignedBins, 0.f);
    for (int y = 1; y <= side - 2; ++y) {
        const std::uint8_t* above = patch.ptr<std::uint8_t>(y - 1);
        const std::uint8_t* row = patch.ptr<std::uint8_t>(y);
        const std::uint8_t* below = patch.ptr<std::uint8_t>(y + 1);
        float* cell_row = hist.data() + static_cast<std::size_t>((y - 1) / cell_size) * cells * kSignedBins;
        for (int x = 1; x <= side - 2; ++x) {
            const float gx = static_cast<float>(row[x + 1]) - static_cast<float>(row[x - 1]);
            const float gy = static_cast<float>(below[x]) - static_cast<float>(above[x]);
            int best = 0;
            float best_dot = 0.f;
            for (int k = 0; k < kHogOrientations; ++k) {
                const float dot = gx * kCos[k] + gy * kSin[k];
                if (std::abs(dot) > std::abs(best_dot)) {
                    best_dot = dot;
                    best = k;
                }
            }
            if (best_dot == 0.f) continue;
            const int bin = best_dot > 0.f ? best : best + kHogOrientations;
            cell_row[((x - 1) / cell_size) * kSignedBins + bin] += std::sqrt(gx * gx + gy * gy);
        }
    }

    // Squared norm of each cell's unsigned histogram: the block energies used for normalisation.
    std::vector<float> energy(static_cast<std::size_t>(num_cells));
    for (int c = 0; c < num_cells; ++c) {
        float e = 0.f;
        for (int k = 0; k < kHogOrientations; ++k) {
            const float u = hist[c * kSignedBins + k] + hist[c * kSignedBins + k + kHogOrientations];
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
            const float* h = hist.data() + static_cast<std::size_t>(c) * kSignedBins;
            float* f = out.data() + static_cast<std::size_t>(c) * kHogDimsPerCell;
            std::fill(f, f + kHogDimsPerCell, 0.f);
            for (int k = 0; k < kSignedBins; ++k)
                for (int n = 0; n < 4; ++n) f[k] += 0.5f * std::min(h[k] * factor[n], kClamp);
            for (int k = 0; k < kHogOrientations; ++k) {
                const float u = h[k] + h[k + kHogOrientations];
                for (int n = 0; n < 4; ++n) {
                    const float clamped = std::min(u * factor[n], kClamp);
                    f[kSignedBins + k] += 0.5f * clamped;
                    f[kSignedBins + kHogOrientations + n] += kTextureScale * clamped;
                }
            }
        }
    }
}

void extract_patch(const cv::Mat& gray, const Eigen::Vector2d& centre, double side_px, int cells, int cell_size,
                   cv::Mat& patch) {
    const int inner = cells * cell_size;
    const int side = inner + 2;
    // One output pixel spans `step` input pixels; output pixel (u, v) samples centre + step·(u - mid, v - mid).
    const double step = side_px / inner;
    const double mid = (side - 1) / 2.0;
    const cv::Matx23d output_to_input(step, 0, centre.x() - step * mid, 0, step, centre.y() - step * mid);
    cv::warpAffine(gray, patch, output_to_input, cv::Size(side, side), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                   cv::BORDER_REPLICATE);
}

}  // namespace facesynth::train
