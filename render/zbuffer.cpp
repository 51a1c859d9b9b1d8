#include "render/zbuffer.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace facesynth::render {

cv::Mat orthographic_zbuffer(const Eigen::Matrix2Xf& pixels, std::span<const float> depth, const std::vector<morph::Triangle>& triangles,
                             int width, int height) {
    if (width <= 0 || height <= 0 || static_cast<std::size_t>(pixels.cols()) != depth.size())
        throw core::Error("z-buffer: " + std::to_string(pixels.cols()) + " vertex positions, " + std::to_string(depth.size()) + " depths, image " +
                    std::to_string(width) + "x" + std::to_string(height));
    constexpr float kEmpty = std::numeric_limits<float>::infinity();
    cv::Mat nearest(height, width, CV_32FC1, cv::Scalar(kEmpty));
    float* buffer = nearest.ptr<float>();
    const auto n = static_cast<int>(depth.size());
    const float max_x = static_cast<float>(width - 1), max_y = static_cast<float>(height - 1);
    for (const morph::Triangle& t : triangles) {
        if (t[0] < 0 || t[1] < 0 || t[2] < 0 || t[0] >= n || t[1] >= n || t[2] >= n)
            throw core::Error("z-buffer: triangle vertex index out of range (" + std::to_string(n) + " vertices)");
        const float x0 = pixels(0, t[0]), y0 = pixels(1, t[0]), x1 = pixels(0, t[1]), y1 = pixels(1, t[1]);
        const float x2 = pixels(0, t[2]), y2 = pixels(1, t[2]);
        // Twice the signed area; image y points down, so front faces (counter-clockwise seen from the
        // front) have a negative one here. NaN corners fail the test too.
        const float area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        if (!(area < 0)) continue;
        const float low_x = std::min({x0, x1, x2}), high_x = std::max({x0, x1, x2});
        const float low_y = std::min({y0, y1, y2}), high_y = std::max({y0, y1, y2});
        if (high_x < 0 || high_y < 0 || low_x > max_x || low_y > max_y) continue;
        const int first_x = static_cast<int>(std::ceil(std::max(0.0f, low_x))), last_x = static_cast<int>(std::min(max_x, high_x));
        const int first_y = static_cast<int>(std::ceil(std::max(0.0f, low_y))), last_y = static_cast<int>(std::min(max_y, high_y));
        // Edge functions, each positive inside (the signs folded for the negative area): e_k(x, y) =
        // a_k x + b_k y + c_k is the weight of corner k times -area.
        const float a0 = y2 - y1, b0 = x1 - x2, c0 = x2 * y1 - x1 * y2;
        const float a1 = y0 - y2, b1 = x2 - x0, c1 = x0 * y2 - x2 * y0;
        const float a2 = y1 - y0, b2 = x0 - x1, c2 = x1 * y0 - x0 * y1;
        // The depth plane about corner 0, so that large coordinates do not cancel.
        const float z0 = depth[static_cast<std::size_t>(t[0])], dz1 = depth[static_cast<std::size_t>(t[1])] - z0,
                    dz2 = depth[static_cast<std::size_t>(t[2])] - z0;
        const float inverse = -1.0f / area;
        const float dz_dx = (dz1 * a1 + dz2 * a2) * inverse, dz_dy = (dz1 * b1 + dz2 * b2) * inverse;
        for (int y = first_y; y <= last_y; ++y) {
            const auto fx = static_cast<float>(first_x), fy = static_cast<float>(y);
            float e0 = a0 * fx + b0 * fy + c0, e1 = a1 * fx + b1 * fy + c1, e2 = a2 * fx + b2 * fy + c2;
            float z = z0 + dz_dx * (fx - x0) + dz_dy * (fy - y0);
            float* row = buffer + static_cast<std::ptrdiff_t>(y) * width;
            for (int x = first_x; x <= last_x; ++x) {
                if (e0 >= 0 && e1 >= 0 && e2 >= 0 && z < row[x]) row[x] = z;
                e0 += a0, e1 += a1, e2 += a2, z += dz_dx;
            }
        }
    }
    nearest.setTo(0, nearest == kEmpty);
    return nearest;
}

}  // namespace facesynth::render
