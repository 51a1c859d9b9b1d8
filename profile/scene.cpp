#include "profile/scene.h"

#include "core/error.h"
#include "core/srgb.h"
#include "frontal/isomap.h"
#include "frontal/photo_texture.h"
#include "morph/jaw_contour.h"
#include "morph/landmarks.h"
#include "morph/polygon.h"
#include "morph/pose.h"
#include "morph/regions.h"
#include "render/zbuffer.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

namespace facesynth::profile {
namespace {

// Camera-space depth is stored with this added, so that every surface has a positive depth (the CPU
// z-buffer marks "no surface" with 0); the renderer's orthographic camera stands as far away.
constexpr double kCameraDistanceMm = 1000;
// A grid triangle shown at more than this many times its area in the photograph is "stretched".
constexpr double kStretchedArea = 2;

bool is_face_region(std::uint8_t label) {
    const auto r = static_cast<morph::Region>(label);
    return r == morph::Region::kSkin || r == morph::Region::kBrows || r == morph::Region::kEyes || r == morph::Region::kLips ||
           r == morph::Region::kNose || r == morph::Region::kMouthInterior;
}

double smoothstep(double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

cv::Mat as_bgr(const cv::Mat& photo) {
    if (photo.empty()) throw core::Error("profile: the photograph is empty");
    if (photo.depth() != CV_8U) throw core::Error("profile: the photograph must be 8-bit");
    cv::Mat bgr;
    switch (photo.channels()) {
        case 1: cv::cvtColor(photo, bgr, cv::COLOR_GRAY2BGR); break;
        case 3: bgr = photo; break;
        case 4: cv::cvtColor(photo, bgr, cv::COLOR_BGRA2BGR); break;
        default: throw core::Error("profile: the photograph has " + std::to_string(photo.channels()) + " channels (1, 3 or 4 expected)");
    }
    return bgr;
}

// Pixels (working) and depth (+ kCameraDistanceMm) of model points seen by `camera`.
void project_source(const fit::ScaledOrthographic& camera, const Eigen::Matrix3Xf& points, Eigen::Matrix2Xf& pixels, std::vector<float>& depth) {
    const Eigen::Matrix3d to_camera = morph::model_to_camera_flip() * camera.rotation;
    pixels.resize(2, points.cols());
    depth.resize(static_cast<std::size_t>(points.cols()));
    for (Eigen::Index v = 0; v < points.cols(); ++v) {
        const Eigen::Vector3d c = to_camera * points.col(v).cast<double>();
        pixels.col(v) = (camera.scale * c.head<2>() + camera.translation).cast<float>();
        depth[static_cast<std::size_t>(v)] = static_cast<float>(c.z() + kCameraDistanceMm);
    }
}

double triangle_area(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return 0.5 * std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

// The face's texture (the renderer's RGB for the model's uv): the photograph's texels seen by the fit,
// then the mirror side, then push-pull from the neighbours for the rest of the layout. `seen` gets, per
// model triangle, whether its centre's texel was seen (not filled).
cv::Mat filled_face_texture(frontal::Frontaliser& frontaliser, const cv::Mat& working, const PhotoScene& scene, int size,
                            std::vector<char>& seen) {
    const morph::MorphableModel& model = frontaliser.model();
    frontal::IsomapOptions isomap_options;
    isomap_options.size = size;
    const frontal::ImageCamera image_camera{scene.camera.to_affine(), scene.camera};
    cv::Mat isomap = frontaliser.extract_isomap(working, scene.vertices, image_camera, isomap_options);
    const frontal::UvRaster& raster = frontaliser.uv_raster(size);
    seen.assign(model.triangles.size(), 0);
    for (std::size_t t = 0; t < model.triangles.size(); ++t) {
        Eigen::Vector2f uv = Eigen::Vector2f::Zero();
        for (const int v : model.triangles[t]) uv += model.uv.col(v) / 3.0f;
        const int c = std::clamp(static_cast<int>(uv.x() * static_cast<float>(size)), 0, size - 1);
        const int r = std::clamp(static_cast<int>(uv.y() * static_cast<float>(size)), 0, size - 1);
        seen[t] = isomap.at<cv::Vec4b>(r, c)[3] > 0 ? 1 : 0;
    }
    if (!model.symmetry.empty()) frontaliser.mirror_fill(isomap);
    cv::Mat bgr, colour, weight(isomap.size(), CV_32FC1);
    cv::cvtColor(isomap, bgr, cv::COLOR_BGRA2BGR);
    bgr.convertTo(colour, CV_32FC3);
    for (int r = 0; r < size; ++r)
        for (int c = 0; c < size; ++c) weight.at<float>(r, c) = isomap.at<cv::Vec4b>(r, c)[3] > 0 ? 1.0f : 0.0f;
    if (cv::countNonZero(weight) == 0) throw core::Error("profile: no part of the fitted face is seen in the photograph");
    frontal::push_pull_fill(colour, weight);
    const cv::Mat inside = frontal::layout_mask(raster);
    for (int r = 0; r < size; ++r)
        for (int c = 0; c < size; ++c) {
            if (!inside.at<std::uint8_t>(r, c)) continue;
            const cv::Vec3f& f = colour.at<cv::Vec3f>(r, c);
            isomap.at<cv::Vec4b>(r, c) = cv::Vec4b(cv::saturate_cast<std::uint8_t>(f[0]), cv::saturate_cast<std::uint8_t>(f[1]),
                                                   cv::saturate_cast<std::uint8_t>(f[2]), 255);
        }
    return frontal::texture_for_unlit_render(isomap, raster);
}

// The picture's grid (scene.grid, grid_motion, grid_uv, grid_triangles, grid_source_area) over the
// working image: depth from the fitted head inside its outline, the outline's depth carried outward and
// fading to the far plane, and how much of the head's motion each vertex follows.
void build_picture_grid(PhotoScene& scene, const morph::MorphableModel& model, const ProfileOptions& options) {
    const int width = scene.working_size.width, height = scene.working_size.height;
    Eigen::Matrix2Xf pixels;
    std::vector<float> depth;
    project_source(scene.camera, scene.vertices, pixels, depth);
    const cv::Mat zbuffer = render::orthographic_zbuffer(pixels, depth, model.triangles, width, height);
    const int step = options.grid_step_px;
    const int columns = (width - 1 + step - 1) / step + 1, rows = (height - 1 + step - 1) / step + 1;
    const auto grid_x = [&](int i) { return std::min(i * step, width - 1); };
    const auto grid_y = [&](int j) { return std::min(j * step, height - 1); };
    cv::Mat head_depth(rows, columns, CV_32FC1), head(rows, columns, CV_8UC1);
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < columns; ++i) {
            const float z = zbuffer.at<float>(grid_y(j), grid_x(i));
            head_depth.at<float>(j, i) = z;
            head.at<std::uint8_t>(j, i) = z > 0 ? 255 : 0;
        }
    if (cv::countNonZero(head) == 0) throw core::Error("profile: the fitted head covers no grid point of the photograph");
    // The outline band's depth, extended over the whole grid.
    cv::Mat inner, outline_weight, extended;
    cv::erode(head, inner, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, 0);
    cv::Mat band = head & ~inner;
    if (cv::countNonZero(band) == 0) band = head;
    band.convertTo(outline_weight, CV_32FC1, 1.0 / 255);
    cv::merge(std::vector<cv::Mat>{head_depth, head_depth, head_depth}, extended);
    frontal::push_pull_fill(extended, outline_weight);
    cv::Mat distance;  // grid steps to the nearest head grid point
    cv::distanceTransform(255 - head, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const double mm_per_step = step / scene.camera.scale;
    const double far_depth = kCameraDistanceMm + options.far_plane_mm;
    cv::Mat depth_grid(rows, columns, CV_64FC1), motion_grid(rows, columns, CV_64FC1);
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < columns; ++i) {
            if (head.at<std::uint8_t>(j, i)) {
                depth_grid.at<double>(j, i) = head_depth.at<float>(j, i) + options.grid_behind_mm;
                motion_grid.at<double>(j, i) = 1;
                continue;
            }
            const double fade = smoothstep(distance.at<float>(j, i) * mm_per_step / std::max(1e-6, options.falloff_mm));
            // What lies just beyond the outline is at least as far as the head's centre: beyond the far
            // cheek's outline it is behind the face, not beside it.
            const double outline = std::max<double>(extended.at<cv::Vec3f>(j, i)[0], kCameraDistanceMm);
            depth_grid.at<double>(j, i) = (1 - fade) * outline + fade * far_depth;
            motion_grid.at<double>(j, i) = 1 - fade;
        }
    // Smoothed over a few grid cells: where the head's surface meets what lies beyond it the depth
    // jumps, and a turned view would show the grid's cells there as a staircase.
    const double sigma = options.smoothing_px / step;
    if (sigma > 0) {
        cv::GaussianBlur(depth_grid, depth_grid, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
        cv::GaussianBlur(motion_grid, motion_grid, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
    }
    const Eigen::Index count = static_cast<Eigen::Index>(rows) * columns;
    scene.grid.resize(3, count);
    scene.grid_uv.resize(2, count);
    scene.grid_motion.resize(static_cast<std::size_t>(count));
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < columns; ++i) {
            const Eigen::Index v = static_cast<Eigen::Index>(j) * columns + i;
            const double x = grid_x(i), y = grid_y(j);
            scene.grid.col(v) = Eigen::Vector3d(x, y, depth_grid.at<double>(j, i));
            scene.grid_motion[static_cast<std::size_t>(v)] = static_cast<float>(motion_grid.at<double>(j, i));
            scene.grid_uv.col(v) = Eigen::Vector2f(static_cast<float>((x + 0.5) / width), static_cast<float>((y + 0.5) / height));
        }
    scene.grid_triangles.clear();
    for (int j = 0; j + 1 < rows; ++j)
        for (int i = 0; i + 1 < columns; ++i) {
            const int a = j * columns + i, b = a + 1, c = a + columns, d = c + 1;
            scene.grid_triangles.push_back({a, c, b});
            scene.grid_triangles.push_back({b, c, d});
        }
    scene.grid_source_area.clear();
    scene.grid_source_area.reserve(scene.grid_triangles.size());
    for (const auto& t : scene.grid_triangles)
        scene.grid_source_area.push_back(triangle_area(scene.grid.col(t[0]).head<2>(), scene.grid.col(t[1]).head<2>(), scene.grid.col(t[2]).head<2>()));
}

}  // namespace

Profiler::Profiler(const morph::MorphableModel& model, const render::RendererOptions& renderer_options)
    : frontaliser_(model, renderer_options), contour_region_(morph::jaw_contour_region(model)),
      topology_(render::landmark_topology(model.triangles, model.num_vertices(), &contour_region_)) {
    if (model.uv.cols() != model.num_vertices()) throw core::Error("profile: the model '" + model.name + "' has no uv layout");
    // The face mesh is drawn where its texture can be trusted: the face regions inside the jaw line,
    // up to the forehead, in front of the jaw's ends. Beyond that (temples, the skin towards the ears)
    // a photograph often shows hair, and the mirror side's hair painted on the model's skin reads
    // worse than the picture's own surroundings turned with the head.
    const Eigen::Matrix3Xf mean = model.shape_instance({});
    std::vector<char> face_vertex(static_cast<std::size_t>(model.num_vertices()), 1);
    if (static_cast<int>(model.landmarks.size()) >= morph::kNumIbugLandmarks) {
        const Eigen::Matrix3Xf points = model.landmark_positions(mean);
        std::vector<Eigen::Vector2f> outline;
        outline.reserve(17);
        for (int k = 0; k < 17; ++k) outline.emplace_back(points(0, k), points(1, k));
        const float brow = std::max(points(1, 19), points(1, 24));
        const float top = brow + 0.6f * (brow - points(1, 8));  // the forehead, to about the hairline
        outline.emplace_back(points(0, 16), top);
        outline.emplace_back(points(0, 0), top);
        const float back = std::min(points(2, 0), points(2, 16)) - 5.0f;
        for (int v = 0; v < model.num_vertices(); ++v)
            face_vertex[static_cast<std::size_t>(v)] = mean(2, v) >= back && morph::inside_polygon(mean.col(v).head<2>(), outline);
    }
    if (!model.vertex_labels.empty())
        for (int v = 0; v < model.num_vertices(); ++v)
            if (!is_face_region(model.vertex_labels[static_cast<std::size_t>(v)])) face_vertex[static_cast<std::size_t>(v)] = 0;
    face_triangle_.resize(model.triangles.size(), 1);
    for (std::size_t t = 0; t < model.triangles.size(); ++t)
        for (const int v : model.triangles[t])
            if (!face_vertex[static_cast<std::size_t>(v)]) face_triangle_[t] = 0;
}

ViewPose Profiler::source_pose(const PhotoScene& scene) {
    return {scene.camera.angles.yaw, scene.camera.angles.pitch, scene.camera.angles.roll};
}

render::Camera Profiler::view_camera(const PhotoScene& scene, const ViewPose& pose, int size) {
    render::Camera camera;
    camera.projection = render::Projection::kOrthographic;
    const double s = scene.camera.scale;
    const Eigen::Vector2d centre = scene.camera.translation - scene.view_origin;
    camera.intrinsics = {s, s, centre.x(), centre.y(), size, size};
    camera.pose.rotation = morph::rotation_from_euler({pose.yaw, pose.pitch, pose.roll});
    camera.pose.translation = Eigen::Vector3d(0, 0, kCameraDistanceMm);
    return camera;
}

PhotoScene Profiler::prepare(const cv::Mat& photo_in, const Eigen::Matrix2Xd& landmarks, const ProfileOptions& options) {
    if (options.size < 16 || options.size > 4096) throw core::Error("profile: size " + std::to_string(options.size) + " is out of range (16..4096)");
    if (!(options.crop_margin >= 1 && options.crop_margin <= 8)) throw core::Error("profile: crop_margin must lie in [1, 8]");
    if (options.grid_step_px < 1) throw core::Error("profile: grid_step_px must be at least 1");
    if (landmarks.cols() != 68 || !landmarks.allFinite())
        throw core::Error("profile: expected 68 finite landmarks, got " + std::to_string(landmarks.cols()));
    const cv::Mat photo = as_bgr(photo_in);
    const morph::MorphableModel& model = frontaliser_.model();
    PhotoScene scene;

    // The region of interest: twice the view's square, so that what turns into view is in the texture.
    const Eigen::Vector2d low = landmarks.rowwise().minCoeff(), high = landmarks.rowwise().maxCoeff();
    const double side = options.crop_margin * (high - low).maxCoeff();
    if (side < 4) throw core::Error("profile: the landmarks span less than 2 pixels");
    const Eigen::Vector2d centre = 0.5 * (low + high);
    // Beyond the photograph's edges the region takes the nearest edge pixel's colour (replicated, never
    // reflected: a reflection next to a face cut by the edge would add a second, unlabelled face).
    const int x0 = static_cast<int>(std::floor(centre.x() - side)), y0 = static_cast<int>(std::floor(centre.y() - side));
    const int x1 = static_cast<int>(std::ceil(centre.x() + side)) + 1, y1 = static_cast<int>(std::ceil(centre.y() + side)) + 1;
    if (x1 <= 0 || y1 <= 0 || x0 >= photo.cols || y0 >= photo.rows) throw core::Error("profile: the landmarks lie outside the photograph");
    cv::Mat region;
    cv::copyMakeBorder(photo(cv::Rect(cv::Point(std::max(x0, 0), std::max(y0, 0)), cv::Point(std::min(x1, photo.cols), std::min(y1, photo.rows)))), region,
                       std::max(0, -y0), std::max(0, y1 - photo.rows), std::max(0, -x0), std::max(0, x1 - photo.cols), cv::BORDER_REPLICATE);
    const double factor = options.size / side;
    const int width = std::max(2, static_cast<int>(std::lround((x1 - x0) * factor)));
    const int height = std::max(2, static_cast<int>(std::lround((y1 - y0) * factor)));
    cv::Mat working;
    cv::resize(region, working, cv::Size(width, height), 0, 0, factor < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
    scene.working_size = working.size();
    scene.roi_origin = Eigen::Vector2d(x0, y0);
    scene.scale = Eigen::Vector2d(static_cast<double>(width) / (x1 - x0), static_cast<double>(height) / (y1 - y0));
    const auto to_working = [&](const Eigen::Vector2d& p) -> Eigen::Vector2d {
        return ((p - scene.roi_origin).array() + 0.5).matrix().cwiseProduct(scene.scale) - Eigen::Vector2d::Constant(0.5);
    };
    scene.annotated.resize(2, 68);
    for (int k = 0; k < 68; ++k) scene.annotated.col(k) = to_working(landmarks.col(k));
    scene.view_origin = to_working(centre) - Eigen::Vector2d::Constant(0.5 * (options.size - 1));

    // Fit, in working pixels.
    scene.fit = frontaliser_.fitter().fit(scene.annotated, options.fit);
    scene.vertices = fit::fitted_shape(model, scene.fit);
    scene.face.vertices = scene.vertices;
    scene.face.triangles = model.triangles;
    scene.face.uv = model.uv;
    scene.camera = scene.fit.pose;
    scene.camera.rotation = morph::rotation_from_euler(scene.camera.angles);  // exactly the views' rotation at the source pose
    scene.fit_error_iod = scene.fit.reprojection_rms_px / std::max(1e-9, morph::inter_ocular_distance(scene.annotated));

    scene.face_texture = filled_face_texture(frontaliser_, working, scene, options.isomap_size, scene.triangle_seen);
    scene.photo_texture = frontal::render_texture_from_display(working);
    build_picture_grid(scene, model, options);

    // The annotator's residual to the fitted model's landmarks at the source pose (contour mode: jaw
    // on the silhouette, as photographs are annotated), lifted into the source view's image plane.
    ProfileOptions plain = options;
    plain.apply_residual = false;
    scene.residual_px = Eigen::Matrix2Xd::Zero(2, 68);
    scene.residual_mm = Eigen::Matrix3Xd::Zero(3, 68);
    const ProfiledView source = render_view(scene, source_pose(scene), plain);
    const Eigen::Matrix3d from_camera = scene.camera.rotation.transpose() * morph::model_to_camera_flip();
    for (int k = 0; k < 68; ++k) {
        scene.residual_px.col(k) = scene.annotated.col(k) - scene.view_origin - source.landmarks_contour.col(k);
        scene.residual_mm.col(k) = from_camera * Eigen::Vector3d(scene.residual_px(0, k), scene.residual_px(1, k), 0) / scene.camera.scale;
    }
    return scene;
}

ProfiledView Profiler::render_view(const PhotoScene& scene, const ViewPose& pose, const ProfileOptions& options, const ViewLight& light) {
    if (!(light.strength >= 0 && light.strength <= 0.9) || !std::isfinite(light.azimuth) || !std::isfinite(light.elevation))
        throw core::Error("profile: a view's light strength must lie in [0, 0.9] and its angles be finite");
    const morph::MorphableModel& model = frontaliser_.model();
    const render::Camera camera = view_camera(scene, pose, options.size);
    const Eigen::Matrix3d& rotation = camera.pose.rotation;
    const Eigen::Matrix3d flip = morph::model_to_camera_flip();
    const double s = scene.camera.scale;
    const Eigen::Vector2d t = scene.camera.translation;
    render::Renderer& renderer = frontaliser_.renderer();

    // The face.
    const morph::Mesh& face = scene.face;
    render::RenderSettings face_settings;
    face_settings.antialiasing = render::Antialiasing::edges();
    face_settings.normals = light.changes();
    face_settings.lighting = frontal::unlit();
    render::MeshExtras face_extras;
    face_extras.texture = &scene.face_texture;
    renderer.render(face, camera, face_settings, face_frame_, face_extras);

    // The picture: each grid point between where the head's rotation takes it and where it was.
    const Eigen::Matrix3d source_to_model = scene.camera.rotation.transpose() * flip;
    const Eigen::Matrix3d view_from_model = flip * rotation, model_from_view = rotation.transpose() * flip;
    morph::Mesh grid;
    grid.vertices.resize(3, scene.grid.cols());
    grid.triangles = scene.grid_triangles;
    grid.uv = scene.grid_uv;
    Eigen::Matrix2Xd grid_pixels(2, scene.grid.cols());
    for (Eigen::Index v = 0; v < scene.grid.cols(); ++v) {
        const Eigen::Vector3d g = scene.grid.col(v);
        const Eigen::Vector3d source_camera((g.x() - t.x()) / s, (g.y() - t.y()) / s, g.z() - kCameraDistanceMm);
        const Eigen::Vector3d turned = view_from_model * (source_to_model * source_camera);
        const double m = scene.grid_motion[static_cast<std::size_t>(v)];
        const Eigen::Vector2d pixel = m * (s * turned.head<2>() + t) + (1 - m) * g.head<2>();
        const double z = m * turned.z() + (1 - m) * (g.z() - kCameraDistanceMm);
        grid_pixels.col(v) = pixel;
        grid.vertices.col(v) = (model_from_view * Eigen::Vector3d((pixel.x() - t.x()) / s, (pixel.y() - t.y()) / s, z)).cast<float>();
    }
    render::RenderSettings grid_settings;
    grid_settings.antialiasing = render::Antialiasing::none();
    grid_settings.normals = light.changes();
    grid_settings.cull_back_faces = false;
    grid_settings.lighting = frontal::unlit();
    render::MeshExtras grid_extras;
    grid_extras.texture = &scene.photo_texture;
    renderer.render(grid, camera, grid_settings, grid_frame_, grid_extras);

    std::vector<char> stretched(scene.grid_triangles.size(), 0);
    std::vector<float> grid_weight(light.changes() ? scene.grid_triangles.size() : 0);
    for (std::size_t k = 0; k < scene.grid_triangles.size(); ++k) {
        const auto& tri = scene.grid_triangles[k];
        if (light.changes()) {
            const auto motion = [&](int corner) { return scene.grid_motion[static_cast<std::size_t>(tri[static_cast<std::size_t>(corner)])]; };
            grid_weight[k] = (motion(0) + motion(1) + motion(2)) / 3;
        }
        const double area = triangle_area(grid_pixels.col(tri[0]), grid_pixels.col(tri[1]), grid_pixels.col(tri[2]));
        stretched[k] = area > kStretchedArea * scene.grid_source_area[k] + 1e-9 ? 1 : 0;
    }

    // Composite: the face wherever its face regions are the face mesh's nearest surface, the picture
    // elsewhere. The picture never covers the face: outside the face's outline it shows what lay beyond
    // it in the photograph (hair, background, the far side's surroundings), whose depth is a guess, and
    // inside it the face itself, a little behind.
    ProfiledView view;
    view.pose = pose;
    view.image = grid_frame_.rgb.clone();
    view.face_mask = cv::Mat::zeros(options.size, options.size, CV_8UC1);
    const int size = options.size;
    std::int64_t face_pixels = 0, filled_pixels = 0, stretched_pixels = 0;
    // Camera axes: x right, y down, z forward; a surface facing the camera has normal (0, 0, −1).
    const double azimuth = light.azimuth * std::numbers::pi / 180, elevation = light.elevation * std::numbers::pi / 180;
    const Eigen::Vector3d toward_light(std::sin(azimuth) * std::cos(elevation), -std::sin(elevation), -std::cos(azimuth) * std::cos(elevation));
    const double camera_facing_shading = (1 - light.strength) + light.strength * std::max(0.0, -toward_light.z());
    std::array<double, 256> decoded{};
    for (int v = 0; v < 256; ++v) decoded[static_cast<std::size_t>(v)] = core::srgb_decode(v / 255.0);
    const auto face_at = [&](int x, int y) {
        if (x < 0 || y < 0 || x >= size || y >= size) return false;
        const int id = face_frame_.triangle_ids.at<int>(y, x);
        return id >= 0 && face_triangle_[static_cast<std::size_t>(id)];
    };
    for (int y = 0; y < size; ++y) {
        auto* out = view.image.ptr<cv::Vec3b>(y);
        auto* shown = view.face_mask.ptr<std::uint8_t>(y);
        const auto* face_rgb = face_frame_.rgb.ptr<cv::Vec3b>(y);
        const auto* coverage = face_frame_.mask.ptr<std::uint8_t>(y);
        const auto* grid_ids = grid_frame_.triangle_ids.ptr<int>(y);
        for (int x = 0; x < size; ++x) {
            const int id = face_frame_.triangle_ids.at<int>(y, x);
            bool use_face = false;
            if (coverage[x] > 0) {
                if (id >= 0) use_face = face_triangle_[static_cast<std::size_t>(id)] != 0;
                else  // an outline pixel: the face's when a neighbour is
                    use_face = face_at(x - 1, y) || face_at(x + 1, y) || face_at(x, y - 1) || face_at(x, y + 1);
            }
            if (use_face) {
                shown[x] = coverage[x];
                const int a = 255 - coverage[x];
                for (int c = 0; c < 3; ++c) out[x][c] = cv::saturate_cast<std::uint8_t>(face_rgb[x][c] + (a * out[x][c] + 127) / 255);
                if (id >= 0) {
                    ++face_pixels;
                    if (!scene.triangle_seen[static_cast<std::size_t>(id)]) ++filled_pixels;
                }
            } else if (grid_ids[x] >= 0 && stretched[static_cast<std::size_t>(grid_ids[x])]) {
                ++stretched_pixels;
            }
            const bool face_surface = use_face && id >= 0;
            if (light.changes() && (face_surface || grid_ids[x] >= 0)) {
                const cv::Vec3f& n = face_surface ? face_frame_.normals.at<cv::Vec3f>(y, x) : grid_frame_.normals.at<cv::Vec3f>(y, x);
                // The grid is drawn from both sides: its normal is the one facing the camera.
                const double facing = n[2] > 0 ? -1.0 : 1.0;
                const double lit = std::max(0.0, facing * (n[0] * toward_light.x() + n[1] * toward_light.y() + n[2] * toward_light.z()));
                const double change = ((1 - light.strength) + light.strength * lit) / camera_facing_shading - 1;
                // The picture's depth is a guess away from the head: the light fades with the head's motion.
                const double factor = 1 + (face_surface ? 1.0 : grid_weight[static_cast<std::size_t>(grid_ids[x])]) * change;
                for (int c = 0; c < 3; ++c)
                    out[x][c] = cv::saturate_cast<std::uint8_t>(255 * core::srgb_encode(factor * decoded[out[x][c]]));
            }
        }
    }
    const double total = static_cast<double>(size) * size;
    view.face_share = static_cast<double>(face_pixels) / total;
    view.filled_share = face_pixels > 0 ? static_cast<double>(filled_pixels) / static_cast<double>(face_pixels) : 0.0;
    view.stretched_share = static_cast<double>(stretched_pixels) / total;

    // Landmarks: the fitted model's, plus the residual turned with the face.
    const render::ProjectedLandmarks projected =
        render::project_landmarks(model.landmarks, face, camera, face_frame_, {}, &contour_region_, &topology_);
    view.landmarks_fixed = projected.pixels;
    view.landmarks_contour = projected.contour_pixels;
    view.visible_fixed = projected.visible;
    view.visible_contour = projected.contour_visible;
    view.residual_px = Eigen::Matrix2Xd::Zero(2, 68);
    if (options.apply_residual && scene.residual_mm.cols() == 68) {
        for (int k = 0; k < 68; ++k) view.residual_px.col(k) = s * (view_from_model * scene.residual_mm.col(k)).head<2>();
        view.landmarks_fixed += view.residual_px;
        view.landmarks_contour += view.residual_px;
    }
    return view;
}

}  // namespace facesynth::profile
