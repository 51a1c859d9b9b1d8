#include "render/edge_antialiasing.h"

#include "core/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace facesynth::render {

void EdgeTopology::build(const morph::Mesh& mesh) {
    source.assign(mesh);
    struct HalfEdge {
        int low, high, triangle, opposite;
    };
    std::vector<HalfEdge> half_edges;
    half_edges.reserve(3 * mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const morph::Triangle& tri = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) {
            const int a = tri[static_cast<std::size_t>(k)], b = tri[static_cast<std::size_t>((k + 1) % 3)];
            half_edges.push_back({std::min(a, b), std::max(a, b), static_cast<int>(t), tri[static_cast<std::size_t>((k + 2) % 3)]});
        }
    }
    std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& l, const HalfEdge& r) {
        return l.low != r.low ? l.low < r.low : (l.high != r.high ? l.high < r.high : l.triangle < r.triangle);
    });
    edges.clear();
    for (std::size_t i = 0; i < half_edges.size();) {
        std::size_t end = i + 1;
        while (end < half_edges.size() && half_edges[end].low == half_edges[i].low && half_edges[end].high == half_edges[i].high)
            ++end;
        if (end - i <= 2 && half_edges[i].low != half_edges[i].high) {
            Edge edge;
            edge.a = half_edges[i].low;
            edge.b = half_edges[i].high;
            for (std::size_t k = i; k < end; ++k) {
                edge.triangle[k - i] = half_edges[k].triangle;
                edge.opposite[k - i] = half_edges[k].opposite;
            }
            edges.push_back(edge);
        }
        i = end;
    }
    sides.clear();
    sides.reserve(edges.size());
    for (const Edge& edge : edges) sides.push_back({edge.triangle[0] + 1, edge.triangle[1] + 1});
}

namespace {

// One silhouette edge in pixels, walked along its major axis `u` (x or y) with the minor axis `v`.
struct ScreenEdge {
    double u0, v0, z0, u1, v1, z1;  // endpoints (u0 < u1) and their camera z
    int inner_side;                 // +1 / -1: the drawn triangle lies toward +v / -v of the edge
};

}  // namespace

EdgeAntialiasingStats EdgeAntialiasing::apply(const morph::Mesh& mesh, const Camera& camera, bool cull_back_faces,
                                              const cv::Mat& depth, cv::Mat& rgb, cv::Mat& mask) {
    const int width = camera.intrinsics.width, height = camera.intrinsics.height;
    if (rgb.type() != CV_8UC3 || mask.type() != CV_8UC1 || depth.type() != CV_32FC1 || rgb.cols != width ||
        rgb.rows != height || mask.size() != rgb.size() || depth.size() != rgb.size() || !rgb.isContinuous() ||
        !mask.isContinuous() || !depth.isContinuous())
        throw core::Error("render: edge anti-aliasing needs continuous rgb, mask and depth images of the camera's size");
    if (!topology_.matches(mesh)) topology_.build(mesh);

    // Vertices in pixels and camera z, exactly as project_point() maps them (the renderer's camera).
    const morph::Intrinsics& k = camera.intrinsics;
    const bool perspective = camera.projection == Projection::kPerspective;
    const Eigen::Matrix3d rotation = morph::model_to_camera_flip() * camera.pose.rotation;
    const Eigen::Vector3d& translation = camera.pose.translation;
    const auto vertex_count = static_cast<std::size_t>(mesh.num_vertices());
    screen_x_.resize(vertex_count);
    screen_y_.resize(vertex_count);
    camera_z_.resize(vertex_count);
    bool any_behind = false;
    const float* model = mesh.vertices.data();
    for (std::size_t i = 0; i < vertex_count; ++i) {
        const double x = model[3 * i], y = model[3 * i + 1], z = model[3 * i + 2];
        const double cx = rotation(0, 0) * x + rotation(0, 1) * y + rotation(0, 2) * z + translation.x();
        const double cy = rotation(1, 0) * x + rotation(1, 1) * y + rotation(1, 2) * z + translation.y();
        const double cz = rotation(2, 0) * x + rotation(2, 1) * y + rotation(2, 2) * z + translation.z();
        camera_z_[i] = cz;
        any_behind = any_behind || cz <= 0;
        if (perspective) {
            screen_x_[i] = k.fx * cx / cz + k.cx;
            screen_y_[i] = k.fy * cy / cz + k.cy;
        } else {
            screen_x_[i] = k.fx * cx + k.cx;
            screen_y_[i] = k.fy * cy + k.cy;
        }
    }
    any_behind = any_behind && perspective;
    // Facing as the GL culls: image y runs down, so counter-clockwise (outside) triangles have a
    // negative signed area in pixel coordinates (glFrontFace(GL_CW) in the renderer). Entry t + 1 holds
    // triangle t; entry 0 (no triangle, an open border) is never drawn.
    facing_.resize(mesh.triangles.size() + 1);
    facing_[0] = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto [a, b, c] = mesh.triangles[t];
        const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b), uc = static_cast<std::size_t>(c);
        const double area = (screen_x_[ub] - screen_x_[ua]) * (screen_y_[uc] - screen_y_[ua]) -
                            (screen_y_[ub] - screen_y_[ua]) * (screen_x_[uc] - screen_x_[ua]);
        facing_[t + 1] = static_cast<std::int8_t>(static_cast<int>(area < 0) - static_cast<int>(area > 0 && !cull_back_faces));
    }
    if (any_behind)  // a triangle reaching behind the camera is clipped by the GL: not a surface to outline
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
            for (int v : mesh.triangles[t])
                if (camera_z_[static_cast<std::size_t>(v)] <= 0) facing_[t + 1] = 0;

    EdgeAntialiasingStats stats;
    blends_.clear();
    const auto* depth_at = depth.ptr<float>();
    // One pixel footprint in mm at camera depth z (the larger of the two axes).
    const double footprint_per_z = perspective ? 1.0 / std::min(k.fx, k.fy) : 0.0;
    const double footprint_orthographic = perspective ? 0.0 : 1.0 / std::min(k.fx, k.fy);

    // Walks one edge along u; `x_major`: u = x, v = y (else u = y, v = x).
    auto walk = [&](const ScreenEdge& e, bool x_major) {
        const int u_size = x_major ? width : height, v_size = x_major ? height : width;
        const int u_stride = x_major ? 1 : width, v_stride = x_major ? width : 1;
        const double length = e.u1 - e.u0;
        const int first = std::max(0, static_cast<int>(std::ceil(e.u0)));
        const int last = std::min(u_size - 1, static_cast<int>(std::ceil(e.u1)) - 1);
        for (int u = first; u <= last; ++u) {
            const double t = (u - e.u0) / length;
            const double v = e.v0 + t * (e.v1 - e.v0);
            const double pixel_v = std::floor(v + 0.5);
            if (pixel_v < 0 || pixel_v >= v_size) continue;
            const double d = v - pixel_v;  // edge offset from the centre of the pixel it cuts, [-0.5, 0.5)
            const float weight = static_cast<float>(0.5 - std::abs(d));
            if (weight <= 0) continue;
            const int centre_side = d < 0 ? 1 : d > 0 ? -1 : e.inner_side;  // side of the pixel centre
            const bool centre_inside = centre_side == e.inner_side;
            const int across = static_cast<int>(pixel_v) - centre_side;  // neighbour beyond the edge
            if (across < 0 || across >= v_size) continue;
            const int pixel = u * u_stride + static_cast<int>(pixel_v) * v_stride;
            const int neighbour = u * u_stride + across * v_stride;
            const int inner = centre_inside ? pixel : neighbour, outer = centre_inside ? neighbour : pixel;
            // The drawn surface must reach the pixel on its side, and nothing nearer may cover the far
            // side: a surface seen there that does not hide the edge lies behind it, or in front by at
            // most its depth slope over the ≤ 1 px between the edge and that pixel centre.
            if (depth_at[inner] == 0) continue;
            const double z = perspective ? 1.0 / ((1.0 - t) / e.z0 + t / e.z1) : e.z0 + t * (e.z1 - e.z0);
            const double margin = kHiddenMarginPixels * (perspective ? z * footprint_per_z : footprint_orthographic);
            const double far_z = depth_at[outer];
            if (far_z != 0 && far_z < z - margin) {
                ++stats.hidden_steps;
                continue;
            }
            blends_.push_back({pixel, neighbour, weight, static_cast<float>(z)});
        }
    };

    for (std::size_t i = 0; i < topology_.sides.size(); ++i) {
        // Drawn on one side only, or (back faces drawn) a fold between opposite facings, whose two
        // triangles lie on the same side of the edge.
        const std::int8_t f0 = facing_[static_cast<std::size_t>(topology_.sides[i][0])];
        const std::int8_t f1 = facing_[static_cast<std::size_t>(topology_.sides[i][1])];
        if (f0 == f1) continue;
        const EdgeTopology::Edge& edge = topology_.edges[i];
        ++stats.silhouette_edges;
        const int opposite = f0 != 0 ? edge.opposite[0] : edge.opposite[1];
        const auto a = static_cast<std::size_t>(edge.a), b = static_cast<std::size_t>(edge.b),
                   c = static_cast<std::size_t>(opposite);
        const double dx = screen_x_[b] - screen_x_[a], dy = screen_y_[b] - screen_y_[a];
        const bool x_major = std::abs(dx) >= std::abs(dy);
        const double ua = x_major ? screen_x_[a] : screen_y_[a], va = x_major ? screen_y_[a] : screen_x_[a];
        const double ub = x_major ? screen_x_[b] : screen_y_[b], vb = x_major ? screen_y_[b] : screen_x_[b];
        if (ua == ub) continue;  // shorter than any pixel step
        ScreenEdge e = ua < ub ? ScreenEdge{ua, va, camera_z_[a], ub, vb, camera_z_[b], 0}
                               : ScreenEdge{ub, vb, camera_z_[b], ua, va, camera_z_[a], 0};
        const double uc = x_major ? screen_x_[c] : screen_y_[c], vc = x_major ? screen_y_[c] : screen_x_[c];
        const double offset = vc - (e.v0 + (uc - e.u0) / (e.u1 - e.u0) * (e.v1 - e.v0));
        if (offset == 0) continue;
        e.inner_side = offset > 0 ? 1 : -1;
        walk(e, x_major);
    }

    // Where several silhouette edges cut one pixel (folds of the surface behind its outline, as at the
    // Surrey mesh's border), the nearest one is the outline seen there, as a depth test among the edges
    // would choose; the others lie behind the surface. Every blend reads the image as rendered.
    std::sort(blends_.begin(), blends_.end(),
              [](const Blend& l, const Blend& r) { return l.pixel != r.pixel ? l.pixel < r.pixel : l.z < r.z; });
    blends_.erase(std::unique(blends_.begin(), blends_.end(), [](const Blend& l, const Blend& r) { return l.pixel == r.pixel; }),
                  blends_.end());
    auto* colour = rgb.ptr<std::uint8_t>();
    auto* coverage = mask.ptr<std::uint8_t>();
    deltas_.resize(4 * blends_.size());
    for (std::size_t i = 0; i < blends_.size(); ++i) {
        const auto p = static_cast<std::size_t>(blends_[i].pixel), n = static_cast<std::size_t>(blends_[i].neighbour);
        const float w = blends_[i].weight;
        for (std::size_t c = 0; c < 3; ++c)
            deltas_[4 * i + c] = w * (static_cast<float>(colour[3 * n + c]) - static_cast<float>(colour[3 * p + c]));
        deltas_[4 * i + 3] = w * (static_cast<float>(coverage[n]) - static_cast<float>(coverage[p]));
    }
    auto add = [](std::uint8_t& value, float delta) {
        value = static_cast<std::uint8_t>(std::lround(std::clamp(static_cast<float>(value) + delta, 0.0f, 255.0f)));
    };
    for (std::size_t i = 0; i < blends_.size(); ++i) {
        const auto p = static_cast<std::size_t>(blends_[i].pixel);
        for (std::size_t c = 0; c < 3; ++c) add(colour[3 * p + c], deltas_[4 * i + c]);
        add(coverage[p], deltas_[4 * i + 3]);
    }
    stats.blended_pixels = static_cast<int>(blends_.size());
    return stats;
}

}  // namespace facesynth::render
