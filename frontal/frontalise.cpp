#include "frontal/frontalise.h"

#include "core/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <vector>

namespace facesynth::frontal {
namespace {

// Process CPU time (the renderer's llvmpipe threads included) and wall time of one stage.
class StageClock {
public:
    StageClock() : cpu_(std::clock()), wall_(std::chrono::steady_clock::now()) {}
    void stop(double& cpu_ms, double& wall_ms) const {
        cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu_) / CLOCKS_PER_SEC;
        wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall_).count();
    }

private:
    std::clock_t cpu_;
    std::chrono::steady_clock::time_point wall_;
};

// texel value -> texture value t with (srgb_decode(t))^(1/2.2) = value.
const std::array<std::uint8_t, 256>& unlit_texture_table() {
    static const std::array<std::uint8_t, 256> table = [] {
        std::array<std::uint8_t, 256> t{};
        for (int i = 0; i < 256; ++i)
            t[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(std::lround(255 * core::srgb_encode(std::pow(i / 255.0, 2.2))));
        return t;
    }();
    return table;
}

}  // namespace

StageTimes& StageTimes::operator+=(const StageTimes& t) {
    fit_cpu_ms += t.fit_cpu_ms, isomap_cpu_ms += t.isomap_cpu_ms, mirror_cpu_ms += t.mirror_cpu_ms, frontal_cpu_ms += t.frontal_cpu_ms;
    fit_ms += t.fit_ms, isomap_ms += t.isomap_ms, mirror_ms += t.mirror_ms, frontal_ms += t.frontal_ms;
    return *this;
}

StageTimes StageTimes::per(double count) const {
    return {fit_cpu_ms / count, isomap_cpu_ms / count, mirror_cpu_ms / count, frontal_cpu_ms / count,
            fit_ms / count,     isomap_ms / count,     mirror_ms / count,     frontal_ms / count};
}

void to_json(nlohmann::json& j, const StageTimes& t) {
    j = {{"fit_ms", t.fit_ms},         {"isomap_ms", t.isomap_ms},         {"mirror_ms", t.mirror_ms},         {"frontal_ms", t.frontal_ms},
         {"fit_cpu_ms", t.fit_cpu_ms}, {"isomap_cpu_ms", t.isomap_cpu_ms}, {"mirror_cpu_ms", t.mirror_cpu_ms}, {"frontal_cpu_ms", t.frontal_cpu_ms}};
}

render::Lighting unlit() {
    render::Lighting lighting;
    for (auto& coefficient : lighting.sh) coefficient = {0.0f, 0.0f, 0.0f};
    lighting.ambient = {1.0f, 1.0f, 1.0f};
    lighting.gamma = 2.2f;
    return lighting;
}

cv::Mat texture_for_unlit_render(const cv::Mat& isomap, const UvRaster& raster) {
    if (isomap.type() != CV_8UC4 || isomap.rows != raster.size || isomap.cols != raster.size)
        throw core::Error("frontal render: the isomap must be a " + std::to_string(raster.size) + "² BGRA image");
    const auto& table = unlit_texture_table();
    cv::Mat texture(isomap.size(), CV_8UC3);
    const auto* in = isomap.ptr<cv::Vec4b>();
    auto* out = texture.ptr<cv::Vec3b>();
    const std::size_t texels = isomap.total();
    for (std::size_t i = 0; i < texels; ++i) out[i] = cv::Vec3b(table[in[i][2]], table[in[i][1]], table[in[i][0]]);
    for (const UvRaster::Padding& pad : raster.padding) {
        int sum[3] = {0, 0, 0}, count = 0;
        for (int k = 0; k < pad.count; ++k) {
            const cv::Vec4b& n = in[pad.neighbours[static_cast<std::size_t>(k)]];
            if (n[3] == 0) continue;
            for (int ch = 0; ch < 3; ++ch) sum[ch] += n[ch];
            ++count;
        }
        if (count == 0) continue;
        out[pad.index] = cv::Vec3b(table[static_cast<std::size_t>((sum[2] + count / 2) / count)],
                                   table[static_cast<std::size_t>((sum[1] + count / 2) / count)],
                                   table[static_cast<std::size_t>((sum[0] + count / 2) / count)]);
    }
    return texture;
}

cv::Mat render_texture_from_display(const cv::Mat& bgr) {
    if (bgr.type() != CV_8UC3 || bgr.empty()) throw core::Error("texture: expected a non-empty 8-bit BGR image");
    const auto& table = unlit_texture_table();
    cv::Mat texture(bgr.size(), CV_8UC3);
    for (int r = 0; r < bgr.rows; ++r) {
        const cv::Vec3b* in = bgr.ptr<cv::Vec3b>(r);
        cv::Vec3b* out = texture.ptr<cv::Vec3b>(r);
        for (int c = 0; c < bgr.cols; ++c)
            out[c] = cv::Vec3b(table[in[c][2]], table[in[c][1]], table[in[c][0]]);
    }
    return texture;
}

Frontaliser::Frontaliser(const morph::MorphableModel& model, const render::RendererOptions& renderer_options)
    : model_(model), fitter_(model), renderer_(renderer_options) {
    const Eigen::Matrix3Xf mean = morph::as_points(model.shape.mean);
    const Eigen::Matrix3Xf landmarks = model.landmark_positions(mean);
    Eigen::Vector3d low = Eigen::Vector3d::Constant(1e30), high = -low;
    for (Eigen::Index i = 0; i < landmarks.cols(); ++i) {
        const Eigen::Vector3d p = landmarks.col(i).cast<double>();
        if (!p.allFinite()) continue;
        low = low.cwiseMin(p);
        high = high.cwiseMax(p);
    }
    if (!(high.x() > low.x()) || !(high.y() > low.y()))
        throw core::Error("frontalise: model '" + model.name + "' has no landmarks to frame the frontal view with");
    frame_centre_mm_ = 0.5 * (low + high);
    frame_side_mm_ = kFrontalMargin * std::max(high.x() - low.x(), high.y() - low.y());
}

const UvRaster& Frontaliser::uv_raster(int size) {
    auto it = rasters_.find(size);
    if (it == rasters_.end()) it = rasters_.emplace(size, rasterise_uv(model_, size, renderer_)).first;
    return it->second;
}

render::Camera Frontaliser::frontal_camera(int size) const {
    if (size < 8 || size > 8192) throw core::Error("frontal render: size " + std::to_string(size) + " is out of range (8..8192)");
    render::Camera camera;
    camera.projection = render::Projection::kOrthographic;
    const double focal = size / frame_side_mm_;
    camera.intrinsics = {focal, focal, 0.5 * (size - 1), 0.5 * (size - 1), size, size};
    constexpr double kDistanceMm = 1000;  // any: orthographic
    camera.pose.translation = Eigen::Vector3d(-frame_centre_mm_.x(), frame_centre_mm_.y(), kDistanceMm);
    return camera;
}

cv::Mat Frontaliser::extract_isomap(const cv::Mat& image, const Eigen::Matrix3Xf& vertices, const ImageCamera& camera,
                                    const IsomapOptions& options, IsomapStats* stats) {
    return frontal::extract_isomap(image, vertices, model_.triangles, camera, uv_raster(options.size), options, stats);
}

int Frontaliser::mirror_fill(cv::Mat& isomap) {
    if (isomap.rows != isomap.cols) throw core::Error("mirror fill: the isomap is not square");
    const int size = isomap.rows;
    const UvRaster& raster = uv_raster(size);
    auto it = mirrors_.find(size);
    if (it == mirrors_.end()) it = mirrors_.emplace(size, mirror_positions(model_, raster)).first;
    return frontal::mirror_fill(isomap, raster, it->second);
}

FrontalImage Frontaliser::render_frontal(const Eigen::Matrix3Xf& vertices, const cv::Mat& isomap,
                                         const FrontalRenderOptions& options) {
    if (vertices.cols() != model_.num_vertices())
        throw core::Error("frontal render: " + std::to_string(vertices.cols()) + " vertices for a model with " +
                    std::to_string(model_.num_vertices()));
    if (isomap.rows != isomap.cols) throw core::Error("frontal render: the isomap is not square");
    const cv::Mat texture = texture_for_unlit_render(isomap, uv_raster(isomap.rows));
    morph::Mesh mesh;
    mesh.vertices = vertices;
    mesh.triangles = model_.triangles;
    mesh.uv = model_.uv;
    render::RenderSettings settings;
    settings.antialiasing = options.antialiasing;
    settings.geometry = false;
    settings.lighting = unlit();
    render::MeshExtras extras;
    extras.texture = &texture;
    const render::Frame frame = renderer_.render(mesh, frontal_camera(options.size), settings, extras);
    FrontalImage out;
    cv::cvtColor(frame.rgb, out.image, cv::COLOR_RGB2BGR);
    out.mask = frame.mask.clone();
    if (options.background) {
        const cv::Vec3b bg = *options.background;
        for (int r = 0; r < out.image.rows; ++r) {
            cv::Vec3b* p = out.image.ptr<cv::Vec3b>(r);
            const std::uint8_t* m = out.mask.ptr<std::uint8_t>(r);
            for (int c = 0; c < out.image.cols; ++c)
                for (int ch = 0; ch < 3; ++ch)  // the render is premultiplied by its coverage
                    p[c][ch] = static_cast<std::uint8_t>(std::min(255, p[c][ch] + (bg[ch] * (255 - m[c]) + 127) / 255));
        }
    }
    return out;
}

Frontalisation Frontaliser::frontalise(const cv::Mat& image, const Eigen::Matrix2Xd& landmarks, const FrontaliseOptions& options) {
    Frontalisation result;
    {
        const StageClock clock;
        result.fit = fitter_.fit(landmarks, options.fit);
        result.vertices = fit::fitted_shape(model_, result.fit);
        clock.stop(result.times.fit_cpu_ms, result.times.fit_ms);
    }
    {
        const StageClock clock;
        result.isomap = extract_isomap(image, result.vertices, {result.fit.camera, result.fit.pose}, options.isomap, &result.isomap_stats);
        clock.stop(result.times.isomap_cpu_ms, result.times.isomap_ms);
    }
    if (options.mirror_fill) {
        const StageClock clock;
        result.mirror_filled_texels = mirror_fill(result.isomap);
        clock.stop(result.times.mirror_cpu_ms, result.times.mirror_ms);
    }
    {
        const StageClock clock;
        result.frontal = render_frontal(result.vertices, result.isomap, options.frontal);
        clock.stop(result.times.frontal_cpu_ms, result.times.frontal_ms);
    }
    return result;
}

}  // namespace facesynth::frontal
