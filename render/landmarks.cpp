#include "render/landmarks.h"

#include "morph/camera.h"
#include "core/error.h"
#include "morph/jaw_contour.h"
#include "morph/landmarks.h"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::render {
namespace {

// Camera ray through a pixel: origin and direction in camera space.
void pixel_ray(const Camera& camera, const Eigen::Vector2d& pixel, Eigen::Vector3d& origin, Eigen::Vector3d& direction) {
    const morph::Intrinsics& k = camera.intrinsics;
    const double x = (pixel.x() - k.cx) / k.fx, y = (pixel.y() - k.cy) / k.fy;
    if (camera.projection == Projection::kPerspective) {
        origin.setZero();
        direction = Eigen::Vector3d(x, y, 1.0);
    } else {
        origin = Eigen::Vector3d(x, y, 0.0);
        direction = Eigen::Vector3d(0.0, 0.0, 1.0);
    }
}

// Image pixels per mm across the view at camera depth z.
double pixels_per_mm(const Camera& camera, double z) {
    const double f = std::sqrt(camera.intrinsics.fx * camera.intrinsics.fy);
    return camera.projection == Projection::kPerspective ? f / std::max(z, 1e-6) : f;
}

bool inside_image(const cv::Mat& image, const Eigen::Vector2d& p) {
    return p.x() >= -0.5 && p.y() >= -0.5 && p.x() < image.cols - 0.5 && p.y() < image.rows - 0.5;
}

// The exact ray test behind is_unoccluded, with what it needs per mesh and camera computed once.
class RayOcclusion {
public:
    RayOcclusion(const morph::Mesh& mesh, const Camera& camera, const LandmarkTopology& topology)
        : camera_(camera), triangles_(mesh.triangles), vertices_(to_camera(camera.pose, mesh.vertices)), first_(topology.first),
          around_(topology.around) {
        seen_.assign(triangles_.size(), 0);
        tested_.assign(triangles_.size(), 0);
    }

    // Candidates: the triangles seen in the window around the point's pixel and every triangle
    // sharing a vertex with one of them. Near an outline the one that covers the point may be
    // smaller than a pixel and cover no pixel centre; its neighbours on the same surface do.
    [[nodiscard]] bool unoccluded(const Frame& frame, const Eigen::Vector2d& pixel, const Eigen::Vector3d& camera_point,
                                  const LandmarkOptions& options) {
        if (frame.triangle_ids.empty()) throw core::Error("render: landmark visibility needs the triangle-id buffer (settings.geometry)");
        if (!inside_image(frame.triangle_ids, pixel)) return false;
        // The segment from the camera (its centre, or the image plane when orthographic) to the point.
        const Eigen::Vector3d origin = camera_.projection == Projection::kPerspective
                                           ? Eigen::Vector3d::Zero()
                                           : Eigen::Vector3d(camera_point.x(), camera_point.y(), 0.0);
        const Eigen::Vector3d segment = camera_point - origin;
        const double length = segment.norm();
        if (length <= options.occlusion_margin_mm) return true;
        const Eigen::Vector3d direction = segment / length;
        const double reach = length - options.occlusion_margin_mm;
        ++query_;
        const int cx = static_cast<int>(std::lround(pixel.x())), cy = static_cast<int>(std::lround(pixel.y()));
        const int w = options.occluder_window_px;
        for (int y = std::max(0, cy - w); y <= std::min(frame.triangle_ids.rows - 1, cy + w); ++y)
            for (int x = std::max(0, cx - w); x <= std::min(frame.triangle_ids.cols - 1, cx + w); ++x) {
                const int seen = frame.triangle_ids.at<int>(y, x);
                if (seen < 0 || static_cast<std::size_t>(seen) >= triangles_.size() || !first_visit(seen, seen_)) continue;
                for (const int v : triangles_[static_cast<std::size_t>(seen)])
                    for (int k = first_[static_cast<std::size_t>(v)]; k < first_[static_cast<std::size_t>(v) + 1]; ++k) {
                        const int candidate = around_[static_cast<std::size_t>(k)];
                        if (first_visit(candidate, tested_) && crosses(candidate, origin, direction, reach)) return false;
                    }
            }
        return true;
    }

private:
    // Marks `triangle` in `marks` for this query; false when it was already marked.
    bool first_visit(int triangle, std::vector<int>& marks) const {
        int& mark = marks[static_cast<std::size_t>(triangle)];
        if (mark == query_) return false;
        mark = query_;
        return true;
    }

    // Whether the ray origin + s·direction, 0 < s < reach, crosses the front face of `triangle`
    // (Möller–Trumbore). Back faces are culled in the render, so they hide nothing in the image.
    [[nodiscard]] bool crosses(int triangle, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double reach) const {
        const morph::Triangle& t = triangles_[static_cast<std::size_t>(triangle)];
        const Eigen::Vector3d a = vertices_.col(t[0]);
        const Eigen::Vector3d e1 = vertices_.col(t[1]) - a, e2 = vertices_.col(t[2]) - a;
        const Eigen::Vector3d p = direction.cross(e2);
        const double det = e1.dot(p);  // > 0: the triangle faces the camera
        if (det <= 1e-12 * e1.norm() * e2.norm()) return false;
        const Eigen::Vector3d s = origin - a;
        const double u = s.dot(p) / det;
        if (u < 0.0 || u > 1.0) return false;
        const Eigen::Vector3d q = s.cross(e1);
        const double v = direction.dot(q) / det;
        if (v < 0.0 || u + v > 1.0) return false;
        const double distance = e2.dot(q) / det;
        return distance > 0.0 && distance < reach;
    }

    const Camera& camera_;
    const std::vector<morph::Triangle>& triangles_;
    Eigen::Matrix3Xd vertices_;  // camera space
    const std::vector<int>& first_;  // around_[first_[v] .. first_[v + 1]): the triangles around vertex v
    const std::vector<int>& around_;
    // Per triangle, the last query that took it from the window (seen_) or ray-tested it (tested_).
    std::vector<int> seen_, tested_;
    int query_ = 0;
};

}  // namespace

std::optional<Eigen::Vector3d> ray_barycentrics(const morph::Mesh& mesh, const Camera& camera, int triangle,
                                                const Eigen::Vector2d& pixel) {
    const morph::Triangle& t = mesh.triangles.at(static_cast<std::size_t>(triangle));
    const Eigen::Vector3d a = to_camera(camera.pose, Eigen::Vector3d(mesh.vertices.col(t[0]).cast<double>()));
    const Eigen::Vector3d b = to_camera(camera.pose, Eigen::Vector3d(mesh.vertices.col(t[1]).cast<double>()));
    const Eigen::Vector3d c = to_camera(camera.pose, Eigen::Vector3d(mesh.vertices.col(t[2]).cast<double>()));
    Eigen::Vector3d origin, direction;
    pixel_ray(camera, pixel, origin, direction);
    // Möller–Trumbore without the range checks.
    const Eigen::Vector3d e1 = b - a, e2 = c - a;
    const Eigen::Vector3d p = direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-12 * e1.norm() * e2.norm() * direction.norm()) return std::nullopt;
    const Eigen::Vector3d s = origin - a;
    const double u = s.dot(p) / det;
    const double v = direction.dot(s.cross(e1)) / det;
    return Eigen::Vector3d(1.0 - u - v, u, v);
}

std::optional<Eigen::Vector3d> surface_point_at(const morph::Mesh& mesh, const Camera& camera, const Frame& frame, int x, int y) {
    if (frame.triangle_ids.empty()) throw core::Error("render: surface_point_at needs the triangle-id buffer");
    if (x < 0 || y < 0 || x >= frame.triangle_ids.cols || y >= frame.triangle_ids.rows) return std::nullopt;
    const int triangle = frame.triangle_ids.at<int>(y, x);
    if (triangle < 0 || triangle >= mesh.num_triangles()) return std::nullopt;
    const auto weights = ray_barycentrics(mesh, camera, triangle, Eigen::Vector2d(x, y));
    if (!weights) return std::nullopt;
    const morph::Triangle& t = mesh.triangles[static_cast<std::size_t>(triangle)];
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) point += (*weights)[i] * mesh.vertices.col(t[static_cast<std::size_t>(i)]).cast<double>();
    return point;
}

bool is_visible(const Frame& frame, const Eigen::Vector2d& pixel, double camera_z, const LandmarkOptions& options) {
    if (frame.depth.empty()) throw core::Error("render: landmark visibility needs the depth buffer (settings.geometry)");
    if (!inside_image(frame.depth, pixel)) return false;
    const int cx = static_cast<int>(std::lround(pixel.x())), cy = static_cast<int>(std::lround(pixel.y()));
    // Background in the window: the point is on the outline, where the depth of the rim pixels
    // changes too fast across a pixel for the tolerance to decide.
    const int n = options.neighbourhood_px;
    for (int y = std::max(0, cy - n); y <= std::min(frame.depth.rows - 1, cy + n); ++y)
        for (int x = std::max(0, cx - n); x <= std::min(frame.depth.cols - 1, cx + n); ++x) {
            const float d = frame.depth.at<float>(y, x);
            if (d <= 0.0f || d >= camera_z - options.depth_tolerance_mm) return true;
        }
    return false;
}

bool is_unoccluded(const morph::Mesh& mesh, const Camera& camera, const Frame& frame, const Eigen::Vector2d& pixel,
                   const Eigen::Vector3d& camera_point, const LandmarkOptions& options) {
    const LandmarkTopology topology = landmark_topology(mesh.triangles, mesh.num_vertices());
    return RayOcclusion(mesh, camera, topology).unoccluded(frame, pixel, camera_point, options);
}

LandmarkTopology landmark_topology(const std::vector<morph::Triangle>& triangles, int num_vertices, const morph::JawContourRegion* contour_region) {
    LandmarkTopology topology;
    // Triangles around each vertex, compressed rows.
    topology.first.assign(static_cast<std::size_t>(num_vertices) + 1, 0);
    for (const morph::Triangle& t : triangles)
        for (const int v : t) {
            if (v < 0 || v >= num_vertices)
                throw core::Error("render: a triangle refers to vertex " + std::to_string(v) + " of a " + std::to_string(num_vertices) + "-vertex mesh");
            ++topology.first[static_cast<std::size_t>(v) + 1];
        }
    for (std::size_t v = 1; v < topology.first.size(); ++v) topology.first[v] += topology.first[v - 1];
    topology.around.resize(static_cast<std::size_t>(topology.first.back()));
    std::vector<int> next(topology.first.begin(), topology.first.end() - 1);
    for (std::size_t t = 0; t < triangles.size(); ++t)
        for (const int v : triangles[t]) topology.around[static_cast<std::size_t>(next[static_cast<std::size_t>(v)]++)] = static_cast<int>(t);
    if (contour_region && !contour_region->vertices.empty()) {
        // The jaw points lie on the face's outline: decided against the face region's own triangles.
        std::vector<char> in_region(static_cast<std::size_t>(num_vertices), 0);
        for (const int v : contour_region->vertices) {
            if (v < 0 || v >= num_vertices) throw core::Error("render: contour region refers to a vertex outside the mesh");
            in_region[static_cast<std::size_t>(v)] = 1;
        }
        topology.face_triangles.resize(triangles.size());
        for (std::size_t t = 0; t < triangles.size(); ++t) {
            const morph::Triangle& tri = triangles[t];
            topology.face_triangles[t] = static_cast<char>(in_region[static_cast<std::size_t>(tri[0])] || in_region[static_cast<std::size_t>(tri[1])] ||
                                                           in_region[static_cast<std::size_t>(tri[2])]);
        }
    }
    return topology;
}

bool is_outline_visible(const Frame& frame, const Eigen::Vector2d& pixel, double camera_z, double pixels_per_mm,
                        std::span<const char> face_triangles, const LandmarkOptions& options) {
    if (frame.depth.empty()) throw core::Error("render: landmark visibility needs the depth buffer (settings.geometry)");
    if (frame.triangle_ids.empty()) throw core::Error("render: outline visibility needs the triangle-id buffer (settings.geometry)");
    if (!inside_image(frame.depth, pixel)) return false;
    const int cx = static_cast<int>(std::lround(pixel.x())), cy = static_cast<int>(std::lround(pixel.y()));
    const int n = options.neighbourhood_px;
    const int m = std::max(n, static_cast<int>(std::ceil(options.outline_tolerance_mm * pixels_per_mm)));
    const double front_limit = camera_z - options.depth_tolerance_mm;
    bool on_outline = false;
    double covering_depth = 0.0;  // the depth of the surface seen least in front, in the small window
    int covering = -1;
    for (int y = std::max(0, cy - m); y <= std::min(frame.depth.rows - 1, cy + m); ++y)
        for (int x = std::max(0, cx - m); x <= std::min(frame.depth.cols - 1, cx + m); ++x) {
            const float d = frame.depth.at<float>(y, x);
            const bool close = std::abs(x - cx) <= n && std::abs(y - cy) <= n;
            if (d <= 0.0f || d >= front_limit) {
                if (close && d > 0.0f) return true;  // a surface at the point's depth next to it: seen
                on_outline = true;                   // background or a surface behind: an outline
            } else if (close && d > covering_depth) {
                covering_depth = d;
                covering = frame.triangle_ids.at<int>(y, x);
            }
        }
    return on_outline && covering >= 0 && static_cast<std::size_t>(covering) < face_triangles.size() &&
           face_triangles[static_cast<std::size_t>(covering)] != 0;
}

ProjectedLandmarks project_landmarks(std::span<const morph::SurfacePoint> landmarks, const morph::Mesh& mesh, const Camera& camera,
                                     const Frame& frame, const LandmarkOptions& options,
                                     const morph::JawContourRegion* contour_region, const LandmarkTopology* topology) {
    if (frame.mask.empty() || frame.depth.empty())
        throw core::Error("render: landmarks need a frame rendered with geometry (depth and mask)");
    const int count = static_cast<int>(landmarks.size());
    ProjectedLandmarks out;
    out.pixels.resize(2, count);
    out.model_points.resize(3, count);
    out.camera_points.resize(3, count);
    out.visible.assign(static_cast<std::size_t>(count), 0);
    const bool jaw = count == morph::kNumIbugLandmarks && contour_region && !contour_region->vertices.empty();
    std::optional<LandmarkTopology> own_topology;
    if (!topology) topology = &own_topology.emplace(landmark_topology(mesh.triangles, mesh.num_vertices(), jaw ? contour_region : nullptr));
    if (topology->first.size() != static_cast<std::size_t>(mesh.num_vertices()) + 1 ||
        (jaw && topology->face_triangles.size() != mesh.triangles.size()))
        throw core::Error("render: landmark topology of another mesh (" + std::to_string(topology->first.size() - 1) + " vertices, " +
                    std::to_string(topology->face_triangles.size()) + " face triangles) for a " + std::to_string(mesh.num_vertices()) +
                    "-vertex, " + std::to_string(mesh.triangles.size()) + "-triangle mesh");
    RayOcclusion occlusion(mesh, camera, *topology);
    for (int i = 0; i < count; ++i) {
        const morph::SurfacePoint& point = landmarks[static_cast<std::size_t>(i)];
        for (int v : point.vertices)
            if (v < 0 || v >= mesh.num_vertices())
                throw core::Error("render: landmark " + std::to_string(i) + " refers to vertex " + std::to_string(v) +
                            " of a " + std::to_string(mesh.num_vertices()) + "-vertex mesh");
        const Eigen::Vector3d x = point.position(mesh.vertices).cast<double>();
        out.model_points.col(i) = x;
        out.camera_points.col(i) = to_camera(camera.pose, x);
        out.pixels.col(i) = project_point(camera, x);
        // The jaw points lie on the face's outline, where the face's own surface may cover them by a
        // little: the depth test here, the outline rule below when there is a contour region.
        const bool jaw_point = count == morph::kNumIbugLandmarks && i < morph::kNumJawLandmarks;
        out.visible[static_cast<std::size_t>(i)] =
            jaw_point ? is_visible(frame, out.pixels.col(i), out.camera_points(2, i), options)
                      : occlusion.unoccluded(frame, out.pixels.col(i), out.camera_points.col(i), options);
    }
    const std::vector<char>& face_triangles = topology->face_triangles;
    if (jaw) {
        for (int i = 0; i < morph::kNumJawLandmarks; ++i) {
            const double z = out.camera_points(2, i);
            out.visible[static_cast<std::size_t>(i)] =
                is_outline_visible(frame, out.pixels.col(i), z, pixels_per_mm(camera, z), face_triangles, options) ? 1 : 0;
        }
    }
    out.contour_pixels = out.pixels;
    out.contour_model_points = out.model_points;
    out.contour_visible = out.visible;
    const int side = jaw ? morph::far_side(camera.pose.rotation) : 0;
    if (side == 0) return out;  // frontal: the jaw line is the outline

    // The shared definition (morph/jaw_contour.h) on the rendered shape with the render's camera.
    const auto& region = *contour_region;
    Eigen::Matrix3Xf region_points(3, static_cast<Eigen::Index>(region.vertices.size()));
    for (std::size_t r = 0; r < region.vertices.size(); ++r) region_points.col(static_cast<Eigen::Index>(r)) = mesh.vertices.col(region.vertices[r]);
    const Eigen::Matrix2Xd projected = project_points(camera, region_points);
    std::vector<int> far_points;  // near side and chin keep the fixed points
    std::vector<morph::JawContourQuery> queries;
    for (int i = 0; i < morph::kNumJawLandmarks; ++i) {
        if (!morph::jaw_on_side(i, side)) continue;
        const Eigen::Vector3d x = out.model_points.col(i);
        const Eigen::Vector2d toward_left = (project_point(camera, x + Eigen::Vector3d::UnitX()) - out.pixels.col(i)).normalized();
        // Points 0-7 are on the subject's right (model -x), 9-16 on the left.
        const Eigen::Vector2d outward = i < morph::kChinLandmark ? Eigen::Vector2d(-toward_left) : toward_left;
        far_points.push_back(i);
        queries.push_back({out.pixels.col(i), outward});
    }
    // One pass over the region's edges for all far-side points (the same hits as one search each).
    const auto hits = morph::jaw_contour_points(region, projected, queries);
    for (std::size_t q = 0; q < far_points.size(); ++q) {
        const int i = far_points[q];
        const auto& hit = hits[q];
        if (!hit) continue;
        const std::size_t s = static_cast<std::size_t>(i);
        const Eigen::Vector3d p = hit->point.position(mesh.vertices).cast<double>();
        out.contour_pixels.col(i) = project_point(camera, p);
        out.contour_model_points.col(i) = p;
        const double z = to_camera(camera.pose, p).z();
        out.contour_visible[s] =
            is_outline_visible(frame, out.contour_pixels.col(i), z, pixels_per_mm(camera, z), face_triangles, options) ? 1 : 0;
    }
    return out;
}

cv::Mat landmark_hull_mask(const cv::Mat& coverage, const Eigen::Matrix2Xd& points) {
    std::vector<cv::Point> finite, hull;
    for (Eigen::Index i = 0; i < points.cols(); ++i)
        if (points.col(i).allFinite()) finite.emplace_back(static_cast<int>(std::lround(points(0, i))), static_cast<int>(std::lround(points(1, i))));
    cv::Mat inside = cv::Mat::zeros(coverage.size(), CV_8UC1);
    if (finite.size() < 3) return inside;
    cv::convexHull(finite, hull);
    cv::fillConvexPoly(inside, hull, cv::Scalar(255));
    inside.setTo(0, coverage != 255);
    return inside;
}

namespace {

// Catmull-Rom point on the segment from jaw point i to i + 1 at t in [0, 1], its neighbours taken across
// the chin (the curve is smooth there) and the end points repeated at 1 and 17.
template <typename Points>
auto catmull_rom(const Points& p, Eigen::Index i, double t) {
    constexpr Eigen::Index kLast = morph::kNumJawLandmarks - 1;
    const auto p0 = p.col(std::max<Eigen::Index>(i - 1, 0)), p1 = p.col(i), p2 = p.col(i + 1), p3 = p.col(std::min(i + 2, kLast));
    const double t2 = t * t, t3 = t2 * t;
    return (0.5 * (2.0 * p1 + (p2 - p0) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2 + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)).eval();
}

// Points first..last (9 jaw points) respaced evenly by arc length along their Catmull-Rom curve.
void respace_half(const Eigen::Matrix2Xd& pixels, const Eigen::Matrix3Xd& model_points, std::span<const std::uint8_t> visible, Eigen::Index first,
                  Eigen::Index last, RespacedJaw& out) {
    constexpr int kSteps = 32;  // curve samples per segment for the arc length
    for (Eigen::Index i = std::max<Eigen::Index>(first - 1, 0); i <= std::min<Eigen::Index>(last + 1, morph::kNumJawLandmarks - 1); ++i)
        if (!pixels.col(i).allFinite() || (model_points.cols() > i && !model_points.col(i).allFinite())) return;
    std::vector<double> length{0.0};  // cumulative, per sample
    Eigen::Vector2d previous = pixels.col(first);
    for (Eigen::Index i = first; i < last; ++i)
        for (int s = 1; s <= kSteps; ++s) {
            const Eigen::Vector2d q = catmull_rom(pixels, i, static_cast<double>(s) / kSteps);
            length.push_back(length.back() + (q - previous).norm());
            previous = q;
        }
    const double total = length.back();
    if (!(total > 0)) return;
    std::size_t sample = 0;
    const auto segments = last - first;
    const bool with_3d = model_points.cols() >= morph::kNumJawLandmarks;
    const bool with_visibility = visible.size() >= static_cast<std::size_t>(morph::kNumJawLandmarks);
    for (Eigen::Index k = 1; k < segments; ++k) {
        const double target = total * static_cast<double>(k) / static_cast<double>(segments);
        while (length[sample + 1] < target) ++sample;
        const double within = (target - length[sample]) / std::max(length[sample + 1] - length[sample], 1e-12);
        const double u = (static_cast<double>(sample) + within) / kSteps;  // curve parameter from `first`
        const auto segment = std::min<Eigen::Index>(static_cast<Eigen::Index>(u), segments - 1);
        const double t = u - static_cast<double>(segment);
        const Eigen::Index i = first + segment, point = first + k;
        out.pixels.col(point) = catmull_rom(pixels, i, t);
        if (with_3d) out.model_points.col(point) = catmull_rom(model_points, i, t);
        if (with_visibility) out.visible[static_cast<std::size_t>(point)] = visible[static_cast<std::size_t>(t < 0.5 ? i : i + 1)];
    }
}

}  // namespace

RespacedJaw space_jaw_evenly(const Eigen::Matrix2Xd& pixels, const Eigen::Matrix3Xd& model_points, std::span<const std::uint8_t> visible) {
    RespacedJaw out{pixels, model_points, {visible.begin(), visible.end()}};
    if (pixels.cols() < morph::kNumIbugLandmarks) return out;
    respace_half(pixels, model_points, visible, 0, morph::kChinLandmark, out);
    respace_half(pixels, model_points, visible, morph::kChinLandmark, morph::kNumJawLandmarks - 1, out);
    return out;
}

}  // namespace facesynth::render
