#include "morph/jaw_contour.h"

#include "morph/landmarks.h"
#include "morph/polygon.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <initializer_list>
#include <unordered_map>

namespace facesynth::morph {

JawBand jaw_band(const MorphableModel& model) {
    JawBand band;
    const auto mean = as_points(model.shape.mean);
    const int v = static_cast<int>(mean.cols());
    if (v == 0) return band;
    std::vector<Eigen::Vector3f> anchors;
    for (const auto* chain : {&model.contour.right, &model.contour.left})
        for (int id : *chain)
            if (id >= 0 && id < v) anchors.emplace_back(mean.col(id));
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

namespace {

// The fixed jaw line of one side as (x, y, z) of the mean shape, from iBUG 1 (or 17) down to the chin.
std::vector<Eigen::Vector3f> fixed_jaw_line(const MorphableModel& model, const Eigen::Matrix3Xf& mean, int side) {
    std::vector<Eigen::Vector3f> line;
    for (int k = 0; k <= kChinLandmark; ++k) {
        const int j = side < 0 ? k : kNumJawLandmarks - 1 - k;
        line.push_back(model.landmarks[static_cast<std::size_t>(j)].position(mean));
    }
    return line;
}

// The jaw line's point at height y: linear between the two fixed points that bracket y, searched
// from the top; above the top point its x and z; nullopt below the chin.
std::optional<Eigen::Vector3f> jaw_line_at(const std::vector<Eigen::Vector3f>& line, float y) {
    if (y >= line.front().y()) return line.front();
    for (std::size_t k = 0; k + 1 < line.size(); ++k) {
        const Eigen::Vector3f& a = line[k];
        const Eigen::Vector3f& b = line[k + 1];
        if ((y <= a.y() && y >= b.y()) || (y >= a.y() && y <= b.y())) {
            const float t = a.y() == b.y() ? 0.0f : (y - a.y()) / (b.y() - a.y());
            return a + t * (b - a);
        }
    }
    return std::nullopt;
}

bool has_fixed_jaw_points(const MorphableModel& model) {
    if (static_cast<int>(model.landmarks.size()) < kNumJawLandmarks) return false;
    for (int j = 0; j < kNumJawLandmarks; ++j) {
        const SurfacePoint& p = model.landmarks[static_cast<std::size_t>(j)];
        for (int id : p.vertices)
            if (id < 0 || id >= model.num_vertices()) return false;
        if (p.weights[0] + p.weights[1] + p.weights[2] < 0.5f) return false;
    }
    return true;
}

// A polygon through the given landmarks of the mean shape (frontal x, y), scaled about its centroid.
std::vector<Eigen::Vector2f> landmark_polygon(const MorphableModel& model, const Eigen::Matrix3Xf& mean,
                                              std::initializer_list<int> ids, float scale_x, float scale_y) {
    std::vector<Eigen::Vector2f> polygon;
    Eigen::Vector2f centroid = Eigen::Vector2f::Zero();
    for (int id : ids) {
        polygon.emplace_back(model.landmarks[static_cast<std::size_t>(id)].position(mean).head<2>());
        centroid += polygon.back();
    }
    centroid /= static_cast<float>(polygon.size());
    for (auto& p : polygon) p = centroid + Eigen::Vector2f(scale_x * (p.x() - centroid.x()), scale_y * (p.y() - centroid.y()));
    return polygon;
}

}  // namespace

JawContourRegion jaw_contour_region(const MorphableModel& model) {
    JawContourRegion region;
    if (!has_fixed_jaw_points(model)) return region;
    const auto mean = as_points(model.shape.mean);
    const int v = static_cast<int>(mean.cols());
    const Eigen::Matrix3Xf mean_points = mean;
    const auto right = fixed_jaw_line(model, mean_points, -1), left = fixed_jaw_line(model, mean_points, 1);
    const JawBand band = jaw_band(model);
    const Eigen::Vector3f extent = mean.rowwise().maxCoeff() - mean.rowwise().minCoeff();
    // The outline seen from the front: up the right jaw line from the chin, across at the region's
    // top, down the left one. Vertices within `tolerance` of a jaw segment count as inside, so the
    // fixed points and the mesh edges through them belong to the region.
    const float top = std::max({band.y_high + band.margin, right.front().y(), left.front().y()});
    std::vector<Eigen::Vector2f> outline;
    for (auto it = right.rbegin(); it != right.rend(); ++it) outline.emplace_back(it->x(), it->y());
    outline.emplace_back(right.front().x(), top);
    outline.emplace_back(left.front().x(), top);
    for (const auto& p : left) outline.emplace_back(p.x(), p.y());
    const float tolerance = 0.006f * extent.maxCoeff();
    // Behind the jaw line at the same height lie the ears, the neck and the underside of the chin.
    const float depth_tolerance = 0.01f * extent.maxCoeff();
    // The vertices the fixed jaw points are made of belong to the region, so that its border passes
    // through the fixed points where the jaw line bulges past the polygon between them.
    std::vector<char> on_jaw(static_cast<std::size_t>(v), 0);
    for (int j = 0; j < kNumJawLandmarks; ++j)
        for (int k = 0; k < 3; ++k) {
            const SurfacePoint& point = model.landmarks[static_cast<std::size_t>(j)];
            if (point.weights[static_cast<std::size_t>(k)] != 0.0f) on_jaw[static_cast<std::size_t>(point.vertices[static_cast<std::size_t>(k)])] = 1;
        }
    // The nose and the lips stand out of the face, but an annotator never puts the jaw outline on
    // them: their vertices (inside the landmark polygons, widened to the alae and the lip borders)
    // are left out. 0-based iBUG ids: nose 27 (bridge top), 31-35 (base); outer lips 48-59.
    std::vector<std::vector<Eigen::Vector2f>> features;
    if (static_cast<int>(model.landmarks.size()) >= kNumIbugLandmarks) {
        features.push_back(landmark_polygon(model, mean_points, {27, 31, 32, 33, 34, 35}, 1.5f, 1.15f));
        features.push_back(landmark_polygon(model, mean_points, {48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59}, 1.1f, 1.25f));
    }
    std::vector<int> local(static_cast<std::size_t>(v), -1);
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = mean.col(i);
        if (p.y() > top && !on_jaw[static_cast<std::size_t>(i)]) continue;
        const Eigen::Vector2f q(p.x(), p.y());
        bool in = on_jaw[static_cast<std::size_t>(i)] || inside_polygon(q, outline);
        for (const auto* line : {&right, &left})
            for (std::size_t k = 0; !in && k + 1 < line->size(); ++k)
                in = segment_distance(q, (*line)[k].head<2>(), (*line)[k + 1].head<2>()) <= tolerance;
        for (const auto& feature : features) in = in && !inside_polygon(q, feature);
        if (!in) continue;
        const auto r = jaw_line_at(right, p.y()), l = jaw_line_at(left, p.y());
        const float jaw_z = std::min(r ? r->z() : right.back().z(), l ? l->z() : left.back().z());
        if (p.z() < jaw_z - depth_tolerance && !on_jaw[static_cast<std::size_t>(i)]) continue;
        local[static_cast<std::size_t>(i)] = static_cast<int>(region.vertices.size());
        region.vertices.push_back(i);
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

namespace {

// One query's line test on one edge, exactly as the single-point search does it: updates `best`
// when the edge crosses the line further out than every earlier edge.
struct ContourLine {
    Eigen::Vector2d fixed, u, w;  // the fixed point, outward, across
    double best_out = -std::numeric_limits<double>::max();
    std::optional<JawContourHit> best;

    void test(const JawContourRegion& region, const Eigen::Matrix2Xd& projected, const std::array<int, 2>& e) {
        const Eigen::Vector2d pa = projected.col(e[0]), pb = projected.col(e[1]);
        const double da = (pa - fixed).dot(w), db = (pb - fixed).dot(w);
        if ((da > 0 && db > 0) || (da < 0 && db < 0) || da == db) return;
        const double t = da / (da - db);
        const Eigen::Vector2d p = pa + t * (pb - pa);
        const double out = (p - fixed).dot(u);
        if (out <= best_out) return;
        best_out = out;
        const int a = region.vertices[static_cast<std::size_t>(e[0])], b = region.vertices[static_cast<std::size_t>(e[1])];
        best = JawContourHit{{{a, b, b}, {static_cast<float>(1.0 - t), static_cast<float>(t), 0.0f}}, p};
    }
};

}  // namespace

std::optional<JawContourHit> jaw_contour_point(const JawContourRegion& region, const Eigen::Matrix2Xd& projected,
                                               const Eigen::Vector2d& fixed_pixel, const Eigen::Vector2d& outward) {
    ContourLine line;
    line.fixed = fixed_pixel;
    line.u = outward.normalized();
    line.w = Eigen::Vector2d(-line.u.y(), line.u.x());
    for (const auto& e : region.edges) line.test(region, projected, e);
    return line.best;
}

std::vector<std::optional<JawContourHit>> jaw_contour_points(const JawContourRegion& region, const Eigen::Matrix2Xd& projected,
                                                             const std::vector<JawContourQuery>& queries) {
    std::vector<std::optional<JawContourHit>> hits(queries.size());
    if (queries.empty() || projected.cols() == 0) return hits;
    std::vector<ContourLine> lines(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) {
        lines[q].fixed = queries[q].fixed_pixel;
        lines[q].u = queries[q].outward.normalized();
        lines[q].w = Eigen::Vector2d(-lines[q].u.y(), lines[q].u.x());
    }
    // The bound: every vertex's offset along the first query's across direction w0, s_v = p_v · w0.
    // Query q's exact offset (p_v − f_q) · w_q differs from s_v − f_q · w0 by at most
    // |p_v − f_q| |w_q − w0| plus rounding, so an edge whose bounds keep clear of the line by more
    // than that margin cannot cross it; every other edge gets the exact test, in edge order.
    const Eigen::Vector2d w0 = lines.front().w;
    const Eigen::VectorXd s = projected.transpose() * w0;
    const Eigen::Vector2d low = projected.rowwise().minCoeff(), high = projected.rowwise().maxCoeff();
    struct Threshold {
        double c, margin;
        std::size_t query;
    };
    std::vector<Threshold> thresholds;
    double largest_margin = 0;
    for (std::size_t q = 0; q < lines.size(); ++q) {
        const Eigen::Vector2d f = lines[q].fixed;
        const double reach = (f - low).cwiseAbs().cwiseMax((f - high).cwiseAbs()).norm();
        const double margin = reach * (lines[q].w - w0).norm() + 1e-9 * (reach + f.norm() + high.cwiseAbs().maxCoeff() + low.cwiseAbs().maxCoeff());
        thresholds.push_back({f.dot(w0), margin, q});
        largest_margin = std::max(largest_margin, margin);
    }
    if (!std::isfinite(largest_margin)) {  // non-finite input: the plain search per query
        for (std::size_t q = 0; q < queries.size(); ++q) hits[q] = jaw_contour_point(region, projected, queries[q].fixed_pixel, queries[q].outward);
        return hits;
    }
    std::sort(thresholds.begin(), thresholds.end(), [](const Threshold& a, const Threshold& b) { return a.c < b.c; });
    for (const auto& e : region.edges) {
        const double sa = s[e[0]], sb = s[e[1]];
        const double lo = std::min(sa, sb) - largest_margin, hi = std::max(sa, sb) + largest_margin;
        // The first threshold at or above lo, then every one up to hi.
        auto it = std::lower_bound(thresholds.begin(), thresholds.end(), lo, [](const Threshold& t, double v) { return t.c < v; });
        for (; it != thresholds.end() && it->c <= hi; ++it)
            if (std::min(sa, sb) - it->margin <= it->c && it->c <= std::max(sa, sb) + it->margin) lines[it->query].test(region, projected, e);
    }
    for (std::size_t q = 0; q < lines.size(); ++q) hits[q] = std::move(lines[q].best);
    return hits;
}

}  // namespace facesynth::morph
