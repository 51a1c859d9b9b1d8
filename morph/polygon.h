#pragma once
// Plane geometry on the frontal projection (x, y) of a mesh: point-in-polygon and point-segment
// distance, shared by the jaw contour's face region and the derived region labels.
#include <Eigen/Core>

#include <algorithm>
#include <vector>

namespace facesynth::morph {

// Even-odd point-in-polygon test (the polygon is closed implicitly).
[[nodiscard]] inline bool inside_polygon(const Eigen::Vector2f& p, const std::vector<Eigen::Vector2f>& polygon) {
    bool in = false;
    for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
        const Eigen::Vector2f& a = polygon[i];
        const Eigen::Vector2f& b = polygon[j];
        if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) in = !in;
    }
    return in;
}

// Distance from p to the segment ab.
[[nodiscard]] inline float segment_distance(const Eigen::Vector2f& p, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
    const Eigen::Vector2f ab = b - a;
    const float t = ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0f, 1.0f) : 0.0f;
    return (p - (a + t * ab)).norm();
}

}  // namespace facesynth::morph
