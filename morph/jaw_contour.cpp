#include "morph/jaw_contour.h"

#include "morph/landmarks.h"

#include <algorithm>
#include <limits>
#include <unordered_map>

namespace facesynth {

JawBand jaw_band(const MorphableModel& model) {
    JawBand band;
    const auto mean = as_points(model.shape.mean);
    const int v = static_cast<int>(mean.cols());
    if (v == 0) return band;
    std::vector<Eigen::Vector3f> anchors;
    for (const auto* chain : {&model.contour.right, &model.contour.left})
        for (int id : *chain)
            if (id >= 0 && id < v) anchors.push_back(mean.col(id));
    for (int j = 0; j < kNumJawLandmarks && j < static_cast<int>(model.landmarks.size()); ++j) {
        bool ok = true;
        for (int id : model.landmarks[static_cast<std::size_t>(j)].vertices) ok = ok && id >= 0 && id < v;
        if (ok) anchors.push_back(model.landmarks[static_cast<std::size_t>(j)].position(mean));
    }
    const Eigen::Vector3f extent = mean.rowwise().maxCoeff() - mean.rowwise().minCoeff();
    band.midline = 0.01f * extent.x();
    if (anchors.empty()) return band;
    band.empty = false;
    band.margin = 0.05f * extent.maxCoeff();
    band.y_low = band.z_low = std::numeric_limits<float>::max();
    band.y_high = -band.y_low;
    for (const auto& p : anchors) {
        band.y_low = std::min(band.y_low, p.y());
        band.y_high = std::max(band.y_high, p.y());
        band.z_low = std::min(band.z_low, p.z());
    }
    return band;
}

JawContourRegion jaw_contour_region(const MorphableModel& model) {
    JawContourRegion region;
    if (model.contour.right.empty() || model.contour.left.empty()) return region;
    const auto mean = as_points(model.shape.mean);
    const int v = static_cast<int>(mean.cols());
    const JawBand band = jaw_band(model);
    if (band.empty) return region;
    const Eigen::Vector3f extent = mean.rowwise().maxCoeff() - mean.rowwise().minCoeff();
    // The fixed jaw line as x(y) on each side (mean shape): the band lies lateral of it, so the nose,
    // mouth and the front of the cheeks never take part. Without fixed jaw points, no lateral limit.
    std::vector<Eigen::Vector2f> jaw_right, jaw_left;  // (x, y), from the top down to the chin
    if (static_cast<int>(model.landmarks.size()) >= kNumJawLandmarks) {
        bool ok = true;
        for (int j = 0; j < kNumJawLandmarks; ++j)
            for (int id : model.landmarks[static_cast<std::size_t>(j)].vertices) ok = ok && id >= 0 && id < v;
        if (ok)
            for (int j = 0; j <= kChinLandmark; ++j) {
                const Eigen::Vector3f r = model.landmarks[static_cast<std::size_t>(j)].position(mean);
                const Eigen::Vector3f l = model.landmarks[static_cast<std::size_t>(kNumJawLandmarks - 1 - j)].position(mean);
                jaw_right.emplace_back(r.x(), r.y());
                jaw_left.emplace_back(l.x(), l.y());
            }
    }
    auto jaw_x_at = [](const std::vector<Eigen::Vector2f>& line, float y) {
        if (y >= line.front().y()) return line.front().x();
        for (std::size_t k = 0; k + 1 < line.size(); ++k) {
            const Eigen::Vector2f a = line[k], b = line[k + 1];
            if ((y <= a.y() && y >= b.y()) || (y >= a.y() && y <= b.y())) {
                const float t = a.y() == b.y() ? 0.0f : (y - a.y()) / (b.y() - a.y());
                return a.x() + t * (b.x() - a.x());
            }
        }
        return line.back().x();
    };
    const float tolerance = 0.02f * extent.maxCoeff();
    std::vector<int> local(static_cast<std::size_t>(v), -1);
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = mean.col(i);
        if (!band.contains(p)) continue;
        if (!jaw_right.empty()) {
            const bool right_ok = p.x() <= jaw_x_at(jaw_right, p.y()) + tolerance;
            const bool left_ok = p.x() >= jaw_x_at(jaw_left, p.y()) - tolerance;
            if (!right_ok && !left_ok) continue;
        }
        local[static_cast<std::size_t>(i)] = static_cast<int>(region.vertices.size());
        region.vertices.push_back(i);
        region.side.push_back(band.side(p));
    }
    std::unordered_map<long long, char> seen;
    for (const auto& t : model.triangles) {
        bool inside = true;
        for (int id : t) inside = inside && id >= 0 && id < v && local[static_cast<std::size_t>(id)] >= 0;
        if (!inside) continue;
        for (int k = 0; k < 3; ++k) {
            int a = local[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])];
            int b = local[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 1) % 3)])];
            if (a == b) continue;
            if (a > b) std::swap(a, b);
            if (seen.emplace(static_cast<long long>(a) * v + b, 1).second) region.edges.push_back({a, b});
        }
    }
    return region;
}

int far_side(const Eigen::Matrix3d& rotation) {
    // The model x axis after rotation: its z (toward the viewer) is R(2, 0); yaw > 0 gives -sin(yaw).
    const double z = rotation(2, 0);
    return z < 0 ? 1 : (z > 0 ? -1 : 0);
}

std::optional<JawContourHit> jaw_contour_point(const JawContourRegion& region, const Eigen::Matrix2Xd& projected, int side,
                                               const Eigen::Vector2d& fixed_pixel, const Eigen::Vector2d& outward) {
    const Eigen::Vector2d u = outward.normalized();
    const Eigen::Vector2d w(-u.y(), u.x());  // across the line
    std::optional<JawContourHit> best;
    double best_out = -std::numeric_limits<double>::max();
    for (const auto& e : region.edges) {
        const int sa = region.side[static_cast<std::size_t>(e[0])], sb = region.side[static_cast<std::size_t>(e[1])];
        if (sa == -side || sb == -side) continue;  // the other half of the face
        const Eigen::Vector2d pa = projected.col(e[0]), pb = projected.col(e[1]);
        const double da = (pa - fixed_pixel).dot(w), db = (pb - fixed_pixel).dot(w);
        if ((da > 0 && db > 0) || (da < 0 && db < 0) || da == db) continue;
        const double t = da / (da - db);
        const Eigen::Vector2d p = pa + t * (pb - pa);
        const double out = (p - fixed_pixel).dot(u);
        if (out <= best_out) continue;
        best_out = out;
        const int a = region.vertices[static_cast<std::size_t>(e[0])], b = region.vertices[static_cast<std::size_t>(e[1])];
        best = JawContourHit{{{a, b, b}, {static_cast<float>(1.0 - t), static_cast<float>(t), 0.0f}}, p};
    }
    return best;
}

}  // namespace facesynth
