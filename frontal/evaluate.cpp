#include "frontal/evaluate.h"

#include "core/error.h"
#include "core/random.h"
#include "morph/sampling.h"
#include "render/landmarks.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>
#include <vector>

namespace facesynth::frontal {
namespace {

constexpr double kCoefficientTruncation = 3.0;

// Smooth colour variation plus a fine dot grid, mirror-symmetric in u, in display values (B G R).
cv::Mat procedural_texture(core::Rng& rng, int size) {
    const double base_r = rng.uniform(0.55, 0.85), base_g = base_r * rng.uniform(0.70, 0.80), base_b = base_g * rng.uniform(0.80, 0.95);
    struct Wave {
        double fu, fv, phase, amplitude;
    };
    std::vector<Wave> waves;
    waves.reserve(6);
    for (int k = 0; k < 6; ++k) waves.push_back({rng.uniform(1, 8), rng.uniform(1, 8), rng.uniform(0, 2 * std::numbers::pi), rng.uniform(0.02, 0.06)});
    const double dot_spacing = rng.uniform(0.03, 0.05);
    cv::Mat texture(size, size, CV_8UC3);
    for (int r = 0; r < size; ++r)
        for (int c = 0; c < size; ++c) {
            const double u = std::abs((c + 0.5) / size - 0.5), v = (r + 0.5) / size;
            double shade = 1;
            for (const Wave& w : waves) shade += w.amplitude * std::sin(2 * std::numbers::pi * (w.fu * u + w.fv * v) + w.phase);
            const double du = std::remainder(u, dot_spacing) / dot_spacing, dv = std::remainder(v, dot_spacing) / dot_spacing;
            if (du * du + dv * dv < 0.06) shade *= 0.6;
            auto level = [&](double x) { return cv::saturate_cast<std::uint8_t>(255 * std::clamp(x * shade, 0.0, 1.0)); };
            texture.at<cv::Vec3b>(r, c) = cv::Vec3b(level(base_b), level(base_g), level(base_r));
        }
    return texture;
}

Eigen::Matrix2Xd project(const render::Camera& camera, const Eigen::Matrix3Xd& points) {
    Eigen::Matrix2Xd out(2, points.cols());
    for (Eigen::Index i = 0; i < points.cols(); ++i) out.col(i) = render::project_point(camera, points.col(i));
    return out;
}

render::MeshExtras extras_for(const TexturedFace& face, cv::Mat& storage) {
    render::MeshExtras extras;
    if (!face.texture.empty()) {
        storage = render_texture_from_display(face.texture);
        extras.texture = &storage;
    }
    return extras;
}

}  // namespace

ViewOptions::ViewOptions() : lighting(unlit()) {}

TexturedFace make_textured_face(const morph::MorphableModel& model, Frontaliser& frontaliser, std::uint64_t seed, std::uint64_t index,
                                int isomap_size) {
    core::Rng identity_rng = core::make_rng(seed, index, core::RandomStream::kIdentity);
    const std::vector<float> alpha = morph::sample_coefficients(identity_rng, model.num_shape_components(), kCoefficientTruncation);
    TexturedFace face;
    const UvRaster& raster = frontaliser.uv_raster(isomap_size);
    if (model.albedo && !model.albedo->empty()) {
        core::Rng albedo_rng = core::make_rng(seed, index, core::RandomStream::kAlbedo);
        const std::vector<float> beta = morph::sample_coefficients(albedo_rng, model.num_albedo_components(), kCoefficientTruncation);
        face.mesh = model.instance(alpha, {}, beta);
        face.true_isomap = vertex_colour_isomap(face.mesh.colours, raster);
    } else {
        face.mesh = model.instance(alpha);
        face.mesh.colours.resize(3, 0);
        core::Rng texture_rng = core::make_rng(seed, index, core::RandomStream::kTexture);
        face.texture = procedural_texture(texture_rng, isomap_size);
        face.true_isomap = cv::Mat(isomap_size, isomap_size, CV_8UC3, cv::Scalar::all(0));
        face.texture.copyTo(face.true_isomap, layout_mask(raster));
    }
    return face;
}

ViewOptions with_context(const ViewOptions& options, double framing) {
    if (!(framing >= options.framing) || !std::isfinite(framing))
        throw core::Error("frontal benchmark: a view with context needs a framing of at least " + std::to_string(options.framing));
    ViewOptions wide = options;
    const double grow = options.size * (framing / options.framing - 1);
    wide.size = options.size + 2 * static_cast<int>(std::lround(0.5 * grow));
    const double ratio = static_cast<double>(wide.size) / options.size;
    wide.framing = options.framing * ratio;
    wide.fov_deg = 2 * std::atan(ratio * std::tan(0.5 * options.fov_deg * std::numbers::pi / 180)) * 180 / std::numbers::pi;
    return wide;
}

SyntheticView render_view(render::Renderer& renderer, const morph::MorphableModel& model, const TexturedFace& face, double yaw_deg,
                          const ViewOptions& options, const morph::JawContourRegion* contour_region) {
    // Frame the mean face's landmarks (the same box as the frontal framing) at 1 / framing of the image.
    const Eigen::Matrix3Xf mean_landmarks = model.landmark_positions(morph::as_points(model.shape.mean));
    Eigen::Vector3d low = Eigen::Vector3d::Constant(1e30), high = -low;
    for (Eigen::Index i = 0; i < mean_landmarks.cols(); ++i)
        if (mean_landmarks.col(i).allFinite()) {
            low = low.cwiseMin(mean_landmarks.col(i).cast<double>());
            high = high.cwiseMax(mean_landmarks.col(i).cast<double>());
        }
    const Eigen::Vector3d centre = 0.5 * (low + high);
    const double extent = options.framing * std::max(high.x() - low.x(), high.y() - low.y());
    render::Camera camera;
    camera.intrinsics = morph::intrinsics_from_fov(options.fov_deg, options.size, options.size);
    const double distance = extent / (2 * std::tan(0.5 * options.fov_deg * std::numbers::pi / 180));
    camera.pose.rotation = morph::rotation_from_euler({yaw_deg, 0, 0});
    const Eigen::Vector3d rotated_centre = morph::model_to_camera_flip() * camera.pose.rotation * centre;
    camera.pose.translation = Eigen::Vector3d(-rotated_centre.x(), -rotated_centre.y(), distance);

    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::msaa(4);
    settings.geometry = true;
    settings.lighting = options.lighting;
    cv::Mat texture;
    const render::Frame frame = renderer.render(face.mesh, camera, settings, extras_for(face, texture));
    const render::ProjectedLandmarks landmarks = render::project_landmarks(model.landmarks, face.mesh, camera, frame, {}, contour_region);

    SyntheticView view;
    view.yaw_deg = yaw_deg;
    cv::cvtColor(frame.rgb, view.image, cv::COLOR_RGB2BGR);
    view.mask = frame.mask.clone();
    for (int r = 0; r < view.image.rows; ++r)
        for (int c = 0; c < view.image.cols; ++c) {
            const int m = view.mask.at<std::uint8_t>(r, c);
            cv::Vec3b& p = view.image.at<cv::Vec3b>(r, c);
            for (int ch = 0; ch < 3; ++ch) p[ch] = static_cast<std::uint8_t>(std::min(255, p[ch] + (options.background[ch] * (255 - m) + 127) / 255));
        }
    view.fixed_landmarks = landmarks.pixels;
    view.landmarks = landmarks.contour_pixels.cols() == landmarks.pixels.cols() ? landmarks.contour_pixels : landmarks.pixels;
    return view;
}

TrueFrontal render_true_frontal(Frontaliser& frontaliser, const TexturedFace& face, int size, const render::Lighting& lighting) {
    const render::Camera camera = frontaliser.frontal_camera(size);
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    settings.geometry = false;
    settings.lighting = lighting;
    cv::Mat texture;
    const render::Frame frame = frontaliser.renderer().render(face.mesh, camera, settings, extras_for(face, texture));
    TrueFrontal truth;
    cv::cvtColor(frame.rgb, truth.render.image, cv::COLOR_RGB2BGR);
    truth.render.mask = frame.mask.clone();
    const Eigen::Matrix2Xd points = project(camera, frontaliser.model().landmark_positions(face.mesh.vertices).cast<double>());
    if (points.array().isFinite().colwise().all().count() < 3) throw core::Error("frontal benchmark: the model has too few landmarks for a face mask");
    truth.face_mask = render::landmark_hull_mask(truth.render.mask, points);
    return truth;
}

IsomapComparison compare_isomap(const cv::Mat& isomap, const cv::Mat& true_isomap, const cv::Mat& layout, int min_alpha) {
    if (isomap.type() != CV_8UC4 || true_isomap.type() != CV_8UC3 || isomap.size() != true_isomap.size() || layout.size() != isomap.size())
        throw core::Error("isomap comparison: expected a BGRA isomap, a BGR truth and a mask of one size");
    IsomapComparison out;
    double abs_sum = 0, sq_sum = 0;
    long visible = 0, compared = 0;
    for (int r = 0; r < isomap.rows; ++r)
        for (int c = 0; c < isomap.cols; ++c) {
            const cv::Vec4b& a = isomap.at<cv::Vec4b>(r, c);
            if (a[3] == 0 || layout.at<std::uint8_t>(r, c) == 0) continue;
            ++visible;
            if (a[3] < min_alpha) continue;
            const cv::Vec3b& b = true_isomap.at<cv::Vec3b>(r, c);
            for (int ch = 0; ch < 3; ++ch) {
                const double d = static_cast<double>(a[ch]) - b[ch];
                abs_sum += std::abs(d);
                sq_sum += d * d;
            }
            ++compared;
        }
    const int layout_texels = cv::countNonZero(layout);
    out.coverage = layout_texels > 0 ? static_cast<double>(visible) / layout_texels : 0;
    out.compared = static_cast<int>(compared);
    if (compared > 0) {
        out.l1 = abs_sum / (3.0 * static_cast<double>(compared));
        const double mse = sq_sum / (3.0 * static_cast<double>(compared));
        out.psnr_db = mse > 0 ? std::min(100.0, 10 * std::log10(255.0 * 255.0 / mse)) : 100.0;
    }
    return out;
}

}  // namespace facesynth::frontal
