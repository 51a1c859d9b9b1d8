#include "frontal/isomap.h"

#include "core/error.h"
#include "morph/pose.h"
#include "render/zbuffer.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>

namespace facesynth::frontal {

UvRaster rasterise_uv(const morph::MorphableModel& model, int size, render::Renderer& renderer) {
    if (model.uv.cols() != model.num_vertices() || model.num_vertices() == 0)
        throw core::Error("isomap: model '" + model.name + "' has no per-vertex uv coordinates");
    if (size < 8 || size > 8192) throw core::Error("isomap: size " + std::to_string(size) + " is out of range (8..8192)");
    // The uv layout as a flat mesh: vertex (u, -v, 0) lands on pixel (u·S - 0.5, v·S - 0.5) under an
    // orthographic camera with focal S and principal point -0.5, so pixel centres are texel centres.
    morph::Mesh flat;
    flat.vertices.resize(3, model.num_vertices());
    flat.vertices.row(0) = model.uv.row(0);
    flat.vertices.row(1) = -model.uv.row(1);
    flat.vertices.row(2).setZero();
    for (std::size_t t = 0; t < model.triangles.size(); ++t) {
        const morph::Triangle& tri = model.triangles[t];
        Eigen::Vector2f low = model.uv.col(tri[0]), high = low;
        for (int corner : tri) {
            low = low.cwiseMin(model.uv.col(corner));
            high = high.cwiseMax(model.uv.col(corner));
        }
        if ((high - low).maxCoeff() > 0.5f) continue;
        flat.triangles.push_back(tri);
    }
    if (flat.triangles.empty()) throw core::Error("isomap: model '" + model.name + "' has no usable uv triangles");
    render::Camera camera;
    camera.projection = render::Projection::kOrthographic;
    camera.intrinsics = {static_cast<double>(size), static_cast<double>(size), -0.5, -0.5, size, size};
    camera.pose.translation = Eigen::Vector3d(0, 0, 10);
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    settings.geometry = true;
    settings.barycentrics = true;
    settings.cull_back_faces = false;
    const render::Frame frame = renderer.render(flat, camera, settings);

    UvRaster raster;
    raster.size = size;
    // Grouped by triangle (a counting sort on the ids), so that extraction loads a triangle's corners
    // once and skips a triangle turned away from the camera as a whole.
    std::vector<int> first(flat.triangles.size() + 1, 0);
    for (int r = 0; r < size; ++r) {
        const int* ids = frame.triangle_ids.ptr<int>(r);
        for (int c = 0; c < size; ++c)
            if (ids[c] >= 0) ++first[static_cast<std::size_t>(ids[c]) + 1];
    }
    for (std::size_t t = 0; t < flat.triangles.size(); ++t) {
        if (first[t + 1] > 0) raster.triangles.push_back({flat.triangles[t], first[t], first[t + 1]});
        first[t + 1] += first[t];
    }
    raster.texels.resize(static_cast<std::size_t>(first.back()));
    std::vector<int> next(first.begin(), first.end() - 1);
    for (int r = 0; r < size; ++r) {
        const int* ids = frame.triangle_ids.ptr<int>(r);
        const cv::Vec3f* weights = frame.barycentrics.ptr<cv::Vec3f>(r);
        for (int c = 0; c < size; ++c) {
            if (ids[c] < 0) continue;
            UvRaster::Texel& texel = raster.texels[static_cast<std::size_t>(next[static_cast<std::size_t>(ids[c])]++)];
            texel.index = r * size + c;
            const float sum = weights[c][0] + weights[c][1] + weights[c][2];
            for (int k = 0; k < 3; ++k) texel.weights[static_cast<std::size_t>(k)] = weights[c][k] / (sum > 0 ? sum : 1.0f);
        }
    }
    for (int r = 0; r < size; ++r)
        for (int c = 0; c < size; ++c) {
            if (frame.triangle_ids.at<int>(r, c) >= 0) continue;
            UvRaster::Padding pad;
            pad.index = r * size + c;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int y = r + dy, x = c + dx;
                    if ((dx || dy) && y >= 0 && x >= 0 && y < size && x < size && frame.triangle_ids.at<int>(y, x) >= 0)
                        pad.neighbours[static_cast<std::size_t>(pad.count++)] = y * size + x;
                }
            if (pad.count > 0) raster.padding.push_back(pad);
        }
    return raster;
}

namespace {

// Calls visit(texel position in raster.texels, texel, its triangle's corners) for every covered texel.
template <typename Visit>
void for_each_texel(const UvRaster& raster, Visit&& visit) {
    for (const UvRaster::TriangleTexels& triangle : raster.triangles)
        for (int i = triangle.first; i < triangle.first + triangle.count; ++i)
            visit(static_cast<std::size_t>(i), raster.texels[static_cast<std::size_t>(i)], triangle.vertices);
}

cv::Mat as_bgr8(const cv::Mat& image) {
    if (image.empty()) throw core::Error("isomap: the image is empty");
    if (image.depth() != CV_8U) throw core::Error("isomap: expected an 8-bit image");
    if (image.channels() == 3) return image;
    cv::Mat bgr;
    if (image.channels() == 1) cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    else if (image.channels() == 4) cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
    else throw core::Error("isomap: expected 1, 3 or 4 channels, the image has " + std::to_string(image.channels()));
    return bgr;
}

// Bilinear BGR sample at a 0-based pixel position inside [0, cols-1] x [0, rows-1].
cv::Vec3f sample_bilinear(const cv::Mat& bgr, float x, float y) {
    const int x0 = std::min(static_cast<int>(x), bgr.cols - 2 < 0 ? 0 : bgr.cols - 2);
    const int y0 = std::min(static_cast<int>(y), bgr.rows - 2 < 0 ? 0 : bgr.rows - 2);
    const int x1 = std::min(x0 + 1, bgr.cols - 1), y1 = std::min(y0 + 1, bgr.rows - 1);
    const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
    const cv::Vec3b* row0 = bgr.ptr<cv::Vec3b>(y0);
    const cv::Vec3b* row1 = bgr.ptr<cv::Vec3b>(y1);
    cv::Vec3f out;
    for (int k = 0; k < 3; ++k) {
        const float top = (1 - fx) * row0[x0][k] + fx * row0[x1][k];
        const float bottom = (1 - fx) * row1[x0][k] + fx * row1[x1][k];
        out[k] = (1 - fy) * top + fy * bottom;
    }
    return out;
}

// Values here are never negative and stay in range: plain rounding (std::lround is slow in this loop).
std::uint8_t to_byte(float value) { return static_cast<std::uint8_t>(std::min(255.0f, std::max(0.0f, value) + 0.5f)); }

}  // namespace

cv::Mat extract_isomap(const cv::Mat& image, const Eigen::Matrix3Xf& vertices, const std::vector<morph::Triangle>& triangles,
                       const ImageCamera& camera, const UvRaster& raster, const IsomapOptions& options, IsomapStats* stats) {
    if (raster.size != options.size)
        throw core::Error("isomap: the uv raster is " + std::to_string(raster.size) + " texels, the options ask for " + std::to_string(options.size));
    if (!(camera.pose.scale > 0) || !std::isfinite(camera.pose.scale)) throw core::Error("isomap: the fitted camera has no valid scale");
    const cv::Mat bgr = as_bgr8(image);
    const int n = static_cast<int>(vertices.cols());
    const Eigen::Matrix3Xf normals = morph::vertex_normals(vertices, triangles);

    // Per vertex: image position (affine camera), position and depth in the z-buffer pass (scaled
    // orthographic camera, OpenCV camera z grows away from the viewer) and the normal in view space.
    const Eigen::Matrix3f rotation = camera.pose.rotation.cast<float>();
    const Eigen::Matrix3f to_camera = morph::model_to_camera_flip().cast<float>() * rotation;
    const Eigen::Matrix<float, 2, 3> affine = camera.affine.matrix.topLeftCorner<2, 3>().cast<float>();
    const Eigen::Vector2f affine_offset = camera.affine.matrix.block<2, 1>(0, 3).cast<float>();
    const Eigen::Matrix3Xf camera_xyz = to_camera * vertices;
    const Eigen::Matrix2Xf image_xyz = (affine * vertices).colwise() + affine_offset;  // x, y in the photograph
    const Eigen::Matrix3Xf view_normals = rotation * normals;  // +z toward the viewer

    // The z-buffer pass: the face's bounding box in the orthographic view, at most max_depth_side.
    const float scale = static_cast<float>(camera.pose.scale);
    const Eigen::Vector2f t = camera.pose.translation.cast<float>();
    const Eigen::Vector2f low = (scale * camera_xyz.topRows<2>()).rowwise().minCoeff() + t;
    const Eigen::Vector2f high = (scale * camera_xyz.topRows<2>()).rowwise().maxCoeff() + t;
    const float extent = std::max(high.x() - low.x(), high.y() - low.y());
    if (!std::isfinite(extent) || extent <= 0) throw core::Error("isomap: the fitted mesh projects to nothing");
    const float shrink = std::min(1.0f, static_cast<float>(options.max_depth_side) / extent);
    const Eigen::Vector2f origin = low.array() - 1.0f;
    constexpr float kDistanceMm = 1000;  // any positive distance: the projection is orthographic
    const float focal = scale * shrink;
    const float cx = (t.x() - origin.x()) * shrink, cy = (t.y() - origin.y()) * shrink;
    const int depth_width = static_cast<int>(std::ceil((high.x() - origin.x()) * shrink)) + 2;
    const int depth_height = static_cast<int>(std::ceil((high.y() - origin.y()) * shrink)) + 2;
    const Eigen::Matrix2Xf depth_pixels = (focal * camera_xyz.topRows<2>()).colwise() + Eigen::Vector2f(cx, cy);
    const Eigen::RowVectorXf depth_z = camera_xyz.row(2).array() + kDistanceMm;
    const cv::Mat depth = render::orthographic_zbuffer(depth_pixels, std::span(depth_z.data(), static_cast<std::size_t>(n)), triangles, depth_width, depth_height);

    const float depth_pixel_mm = 1.0f / focal;
    const float min_cosine = std::max(1e-3f, static_cast<float>(options.min_cosine));
    // The z-buffer with every pixel closer than outline_margin_px to the fitted outline (the image
    // border counts as outline) set to -inf, so that one look-up tests both depth and outline.
    cv::Mat inside = depth > 0;
    if (options.outline_margin_px > 0) {
        const int k = 2 * options.outline_margin_px + 1;
        cv::erode(inside, inside, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)), cv::Point(-1, -1), 1,
                  cv::BORDER_CONSTANT, cv::Scalar(0));
    }
    cv::Mat nearest = depth.clone();
    nearest.setTo(-std::numeric_limits<float>::infinity(), inside == 0);

    // What the texel loop interpolates, one 32-byte record per vertex (one cache line per corner).
    struct VertexSample {
        float x, y, z;     // pixel in the z-buffer pass and camera depth there (mm)
        float nx, ny, nz;  // view-space normal (not unit)
        float u, v;        // position in the photograph
    };
    std::vector<VertexSample> samples(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const auto normal = view_normals.col(i);
        samples[static_cast<std::size_t>(i)] = {depth_pixels(0, i), depth_pixels(1, i), depth_z[i],
                                                normal.x(), normal.y(), normal.z(), image_xyz(0, i), image_xyz(1, i)};
    }

    const float tolerance = static_cast<float>(options.depth_tolerance_mm);
    const float min_cosine_squared = min_cosine * min_cosine;
    const float max_x = static_cast<float>(bgr.cols - 1), max_y = static_cast<float>(bgr.rows - 1);
    const int depth_cols = nearest.cols, depth_rows = nearest.rows;
    const float* buffer = nearest.ptr<float>();
    cv::Mat isomap(raster.size, raster.size, CV_8UC4, cv::Scalar::all(0));
    auto* out = isomap.ptr<cv::Vec4b>();
    int visible = 0;
    constexpr float kMaxSlope = 10;
    for (const UvRaster::TriangleTexels& triangle : raster.triangles) {
        const VertexSample& a = samples[static_cast<std::size_t>(triangle.vertices[0])];
        const VertexSample& b = samples[static_cast<std::size_t>(triangle.vertices[1])];
        const VertexSample& c = samples[static_cast<std::size_t>(triangle.vertices[2])];
        // Weights are never negative: no texel of a triangle whose corners all face away is seen.
        if (!(a.nz > 0) && !(b.nz > 0) && !(c.nz > 0)) continue;
        const auto texels = std::span(raster.texels).subspan(static_cast<std::size_t>(triangle.first), static_cast<std::size_t>(triangle.count));
        for (const UvRaster::Texel& texel : texels) {
            const float wa = texel.weights[0], wb = texel.weights[1], wc = texel.weights[2];
            // cos θ = nz / |n| >= min_cosine, tested without a square root.
            const float nz = wa * a.nz + wb * b.nz + wc * c.nz;
            if (!(nz > 0)) continue;
            const float nx = wa * a.nx + wb * b.nx + wc * c.nx, ny = wa * a.ny + wb * b.ny + wc * c.ny;
            const float norm_squared = nx * nx + ny * ny + nz * nz;
            if (nz * nz < min_cosine_squared * norm_squared) continue;
            // +1 before truncating: rounds correctly for coordinates down to -1 (outside anyway).
            const int px = static_cast<int>(wa * a.x + wb * b.x + wc * c.x + 1.5f) - 1;
            const int py = static_cast<int>(wa * a.y + wb * b.y + wc * c.y + 1.5f) - 1;
            if (px < 0 || py < 0 || px >= depth_cols || py >= depth_rows) continue;
            // Hidden when deeper than the z-buffer + tolerance + one pixel's worth of slope (tan θ, at
            // most kMaxSlope); the slope is only worked out for texels between the two bounds.
            const float z = wa * a.z + wb * b.z + wc * c.z;
            const float allowed = buffer[py * depth_cols + px] + tolerance;
            if (z > allowed + depth_pixel_mm * kMaxSlope) continue;
            const float cosine = nz / std::sqrt(norm_squared);
            if (z > allowed && z > allowed + depth_pixel_mm * std::min(kMaxSlope, std::sqrt(1 - cosine * cosine) / cosine)) continue;
            const float u = wa * a.u + wb * b.u + wc * c.u, v = wa * a.v + wb * b.v + wc * c.v;
            if (!(u >= 0 && v >= 0 && u <= max_x && v <= max_y)) continue;
            const cv::Vec3f colour = sample_bilinear(bgr, u, v);
            out[texel.index] = cv::Vec4b(to_byte(colour[0]), to_byte(colour[1]), to_byte(colour[2]), std::max<std::uint8_t>(1, to_byte(255 * cosine)));
            ++visible;
        }
    }
    if (stats) {
        stats->covered_texels = static_cast<int>(raster.texels.size());
        stats->visible_texels = visible;
        stats->depth_width = depth.cols;
        stats->depth_height = depth.rows;
    }
    return isomap;
}

std::vector<int> completed_symmetry(const morph::MorphableModel& model) {
    const int n = model.num_vertices();
    if (model.symmetry.size() != static_cast<std::size_t>(n))
        throw core::Error("mirror fill: model '" + model.name + "' has no symmetry map (a mirror vertex per vertex)");
    std::vector<int> mirror = model.symmetry;
    // A symmetry map is an involution: a pair listed one way holds the other way too.
    for (int v = 0; v < n; ++v) {
        const int m = mirror[static_cast<std::size_t>(v)];
        if (m >= 0 && m < n && mirror[static_cast<std::size_t>(m)] < 0) mirror[static_cast<std::size_t>(m)] = v;
    }
    std::vector<int> missing;
    double plane = 0;
    int on_plane = 0;
    const Eigen::Map<const Eigen::Matrix3Xf> mean(model.shape.mean.data(), 3, n);
    for (int v = 0; v < n; ++v) {
        const int m = mirror[static_cast<std::size_t>(v)];
        if (m < 0 || m >= n) missing.push_back(v);
        else if (m != v) plane += 0.5 * (mean(0, v) + mean(0, m)), ++on_plane;
    }
    plane = on_plane > 0 ? plane / on_plane : 0.0;
    // The rest (Surrey lists mirrors for its first 845 vertices only): the mean-shape vertex nearest to
    // the vertex mirrored in the plane of the known pairs. Brute force, bounded so that a huge model
    // with a sparse map does not stall; beyond the bound those vertices stay without a mirror.
    constexpr double kMaxPairTests = 1e8;
    if (!missing.empty() && static_cast<double>(missing.size()) * n <= kMaxPairTests) {
        for (int v : missing) {
            const Eigen::Vector3f target(static_cast<float>(2 * plane) - mean(0, v), mean(1, v), mean(2, v));
            int best = -1;
            float best_distance = std::numeric_limits<float>::max();
            for (int u = 0; u < n; ++u) {
                const float d = (mean.col(u) - target).squaredNorm();
                if (d < best_distance) best_distance = d, best = u;
            }
            mirror[static_cast<std::size_t>(v)] = best;
        }
    }
    return mirror;
}

Eigen::Matrix2Xf mirror_positions(const morph::MorphableModel& model, const UvRaster& raster) {
    const std::vector<int> symmetry = completed_symmetry(model);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    Eigen::Matrix2Xf positions(2, static_cast<Eigen::Index>(raster.texels.size()));
    const float size = static_cast<float>(raster.size);
    for_each_texel(raster, [&](std::size_t i, const UvRaster::Texel& texel, const std::array<int, 3>& corners) {
        Eigen::Vector2f uv = Eigen::Vector2f::Zero();
        bool known = true;
        for (std::size_t k = 0; k < 3; ++k) {
            const int mirror = symmetry[static_cast<std::size_t>(corners[k])];
            if (mirror < 0 || mirror >= model.num_vertices()) {
                known = false;
                break;
            }
            uv += texel.weights[k] * model.uv.col(mirror);
        }
        positions.col(static_cast<Eigen::Index>(i)) = known ? Eigen::Vector2f(uv.x() * size - 0.5f, uv.y() * size - 0.5f)
                                                            : Eigen::Vector2f(nan, nan);
    });
    return positions;
}

int mirror_fill(cv::Mat& isomap, const UvRaster& raster, const Eigen::Matrix2Xf& mirror) {
    // Texels seen at grazing angles (cos θ < 0.25) often carry the photograph's background where the
    // fitted outline is a pixel off: a mirror point seen at least twice as squarely replaces them.
    constexpr int kMirrorReplacesBelowAlpha = 64;
    if (isomap.type() != CV_8UC4 || isomap.rows != raster.size || isomap.cols != raster.size)
        throw core::Error("mirror fill: the isomap is not a " + std::to_string(raster.size) + "² BGRA image");
    if (mirror.cols() != static_cast<Eigen::Index>(raster.texels.size()))
        throw core::Error("mirror fill: the mirror positions belong to another uv raster");
    const cv::Mat source = isomap.clone();
    auto* out = isomap.ptr<cv::Vec4b>();
    const int size = raster.size;
    int filled = 0;
    for (std::size_t i = 0; i < raster.texels.size(); ++i) {
        const UvRaster::Texel& texel = raster.texels[i];
        const int own_alpha = out[texel.index][3];
        if (own_alpha >= kMirrorReplacesBelowAlpha) continue;
        const float x = mirror(0, static_cast<Eigen::Index>(i)), y = mirror(1, static_cast<Eigen::Index>(i));
        if (!std::isfinite(x) || !std::isfinite(y)) continue;
        const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
        const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
        cv::Vec4f sum(0, 0, 0, 0);
        float weight = 0;
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const int cx = x0 + dx, cy = y0 + dy;
                if (cx < 0 || cy < 0 || cx >= size || cy >= size) continue;
                const cv::Vec4b& s = source.at<cv::Vec4b>(cy, cx);
                if (s[3] == 0) continue;
                const float w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
                for (int k = 0; k < 4; ++k) sum[k] += w * s[k];
                weight += w;
            }
        if (weight <= 1e-3f || sum[3] / weight < 2.0f * static_cast<float>(own_alpha)) continue;
        out[texel.index] = cv::Vec4b(to_byte(sum[0] / weight), to_byte(sum[1] / weight), to_byte(sum[2] / weight),
                                     std::max<std::uint8_t>(1, to_byte(sum[3] / weight)));
        ++filled;
    }
    // Texels on the midline are their own mirror: close the seams a texel or two wide that the fitted
    // outline leaves there (a hole texel with at least 3 textured 8-neighbours takes their mean).
    for (int pass = 0; pass < 2; ++pass) {
        const cv::Mat before = isomap.clone();
        const auto* in = before.ptr<cv::Vec4b>();
        for (const UvRaster::Texel& texel : raster.texels) {
            if (in[texel.index][3] != 0) continue;
            const int r = texel.index / size, c = texel.index % size;
            if (r == 0 || c == 0 || r == size - 1 || c == size - 1) continue;
            int sum[4] = {0, 0, 0, 0}, count = 0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const cv::Vec4b& n = in[texel.index + dy * size + dx];
                    if (n[3] == 0) continue;
                    for (int k = 0; k < 4; ++k) sum[k] += n[k];
                    ++count;
                }
            if (count < 3) continue;
            out[texel.index] = cv::Vec4b(static_cast<std::uint8_t>(sum[0] / count), static_cast<std::uint8_t>(sum[1] / count),
                                         static_cast<std::uint8_t>(sum[2] / count), static_cast<std::uint8_t>(std::max(1, sum[3] / count)));
            ++filled;
        }
    }
    return filled;
}

cv::Mat vertex_colour_isomap(const Eigen::Matrix3Xf& colours, const UvRaster& raster, float gamma) {
    cv::Mat out(raster.size, raster.size, CV_8UC3, cv::Scalar::all(0));
    auto* pixels = out.ptr<cv::Vec3b>();
    const float inverse_gamma = 1.0f / gamma;
    for_each_texel(raster, [&](std::size_t, const UvRaster::Texel& texel, const std::array<int, 3>& corners) {
        const Eigen::Vector3f rgb = (texel.weights[0] * colours.col(corners[0]) + texel.weights[1] * colours.col(corners[1]) +
                                     texel.weights[2] * colours.col(corners[2]))
                                        .cwiseMax(0.0f)
                                        .cwiseMin(1.0f);
        pixels[texel.index] = cv::Vec3b(to_byte(255 * std::pow(rgb.z(), inverse_gamma)), to_byte(255 * std::pow(rgb.y(), inverse_gamma)),
                                        to_byte(255 * std::pow(rgb.x(), inverse_gamma)));
    });
    return out;
}

cv::Mat layout_mask(const UvRaster& raster) {
    cv::Mat mask(raster.size, raster.size, CV_8UC1, cv::Scalar::all(0));
    for (const UvRaster::Texel& texel : raster.texels) mask.ptr<std::uint8_t>()[texel.index] = 255;
    return mask;
}

}  // namespace facesynth::frontal
