#include "synth/sample.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "core/random.h"
#include "core/srgb.h"
#include "degrade/degrade.h"
#include "render/landmarks.h"
#include "synth/exposure.h"
#include "synth/texture_mix.h"
#include "synth/neck.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace facesynth::synth {
namespace {

double thread_cpu_seconds() {
    timespec t{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Where the head parts lie in `labels` (hair, ears, neck, clothing), `rgb` takes `parts_rgb`, their
// render under their own light; the face keeps the render under its light (lighting.face_light = "even").
void take_head_parts(cv::Mat& rgb, const cv::Mat& parts_rgb, const cv::Mat& labels) {
    const auto is_part = [](std::uint8_t label) {
        const auto region = static_cast<morph::Region>(label);
        return region == morph::Region::kHair || region == morph::Region::kEars || region == morph::Region::kNeck || region == morph::Region::kClothing;
    };
    for (int y = 0; y < rgb.rows; ++y) {
        auto* out = rgb.ptr<cv::Vec3b>(y);
        const auto* lit = parts_rgb.ptr<cv::Vec3b>(y);
        const auto* label = labels.ptr<std::uint8_t>(y);
        for (int x = 0; x < rgb.cols; ++x)
            if (is_part(label[x])) out[x] = lit[x];
    }
}

cv::Scalar to_scalar(const Eigen::Vector3d& rgb01) { return {rgb01.x() * 255.0, rgb01.y() * 255.0, rgb01.z() * 255.0}; }

void gradient(cv::Mat& out, const BackgroundSpec& b) {
    const double angle = b.gradient_angle * 3.14159265358979323846 / 180.0;
    const double dx = std::cos(angle), dy = std::sin(angle);
    const double half_extent = 0.5 * (std::abs(dx) * out.cols + std::abs(dy) * out.rows);
    const double cx = 0.5 * out.cols, cy = 0.5 * out.rows;
    for (int y = 0; y < out.rows; ++y) {
        auto* row = out.ptr<cv::Vec3b>(y);
        for (int x = 0; x < out.cols; ++x) {
            const double t = std::clamp(0.5 + ((x - cx) * dx + (y - cy) * dy) / (2.0 * half_extent), 0.0, 1.0);
            const Eigen::Vector3d c = ((1 - t) * b.colour + t * b.colour2) * 255.0;
            row[x] = cv::Vec3b(cv::saturate_cast<uchar>(c.x()), cv::saturate_cast<uchar>(c.y()), cv::saturate_cast<uchar>(c.z()));
        }
    }
}

// A colour gradient with random soft shapes over it: clutter without meaning. Drawn and blurred at
// half the size (a quarter of the pixels), then scaled up to `out`: the same gradient, shapes and
// blur, for about a third of the CPU (docs/synth.md, "Speed"). The draws are those of full-size
// coordinates, so the pattern does not depend on the canvas.
void procedural(cv::Mat& out, const BackgroundSpec& b, cv::Mat& canvas) {
    canvas.create((out.rows + 1) / 2, (out.cols + 1) / 2, CV_8UC3);
    gradient(canvas, b);
    constexpr int kHalf = 1;  // OpenCV drawing's fractional bits: full-size coordinates land at half
    core::Rng rng(b.pattern_seed, 0, 0);
    const int shapes = rng.uniform_int(3, 12);
    const int side = std::max(out.cols, out.rows);
    for (int i = 0; i < shapes; ++i) {
        // One draw per statement (the order of draws within one expression is the compiler's choice),
        // in the order GCC drew them when they were one expression: GCC builds keep their backgrounds.
        const int centre_y = rng.uniform_int(0, out.rows - 1);
        const int centre_x = rng.uniform_int(0, out.cols - 1);
        const cv::Point centre(centre_x, centre_y);
        const double third = rng.uniform(0, 255);
        const double second = rng.uniform(0, 255);
        const double first = rng.uniform(0, 255);
        const cv::Scalar colour(first, second, third);
        const int size = std::max(2, static_cast<int>(rng.uniform(0.03, 0.3) * side));
        switch (rng.uniform_int(0, 2)) {
            case 0: cv::circle(canvas, centre, size, colour, cv::FILLED, cv::LINE_AA, kHalf); break;
            case 1: {
                const cv::Point corner(centre.x - size / 2, centre.y - size / 3);
                const cv::Point opposite(corner.x + size - 1, corner.y + std::max(1, 2 * size / 3) - 1);
                cv::rectangle(canvas, corner, opposite, colour, cv::FILLED, cv::LINE_AA, kHalf);
                break;
            }
            default: {
                const int end_y = rng.uniform_int(0, out.rows - 1);
                const int end_x = rng.uniform_int(0, out.cols - 1);
                cv::line(canvas, centre, cv::Point(end_x, end_y), colour, std::max(1, size / 12), cv::LINE_AA, kHalf);
            }
        }
    }
    const double sigma = 0.5 * rng.uniform(0.5, 4.0) * side / 256.0;
    cv::GaussianBlur(canvas, canvas, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT);
    cv::resize(canvas, out, out.size(), 0, 0, cv::INTER_LINEAR);
}

void image_crop(cv::Mat& out, const BackgroundSpec& b, const ImageLibrary& library) {
    core::Rng rng(b.pattern_seed, 0, 0);
    const cv::Mat& source = library.image(rng.next_u64());
    // A random crop of the output's aspect ratio covering 30-100% of the image's shorter side.
    const double aspect = static_cast<double>(out.cols) / out.rows;
    const double share = rng.uniform(0.3, 1.0);
    int crop_h = std::max(1, static_cast<int>(share * std::min<double>(source.rows, source.cols / aspect)));
    int crop_w = std::max(1, std::min(source.cols, static_cast<int>(crop_h * aspect)));
    crop_h = std::min(crop_h, source.rows);
    const int x = rng.uniform_int(0, source.cols - crop_w);
    const int y = rng.uniform_int(0, source.rows - crop_h);
    // Area averaging when shrinking; bilinear when enlarging (area averaging would repeat pixels in blocks).
    const int interpolation = crop_w >= out.cols ? cv::INTER_AREA : cv::INTER_LINEAR;
    cv::resize(source(cv::Rect(x, y, crop_w, crop_h)), out, out.size(), 0, 0, interpolation);
    if (rng.uniform() < 0.5) cv::flip(out, out, 1);
}

// Into `out`, whose buffer (and the procedural background's `canvas`) is reused when it has the size.
void make_background(const cv::Size& size, const BackgroundSpec& b, const ImageLibrary& library, cv::Mat& out, cv::Mat& canvas) {
    out.create(size, CV_8UC3);
    if (b.type == "solid") out.setTo(to_scalar(b.colour));
    else if (b.type == "images" || b.type == "wallpapers") image_crop(out, b, library);
    else procedural(out, b, canvas);
}

// face (premultiplied by coverage) + background · (1 - coverage), over runs of equal coverage: a
// covered run is the face's, an uncovered one face + background, the same values as the blend.
void composite(const cv::Mat& face, const cv::Mat& mask, const cv::Mat& background, cv::Mat& out) {
    out.create(face.size(), CV_8UC3);
    const auto saturated = [](int value) { return static_cast<uchar>(std::min(value, 255)); };
    for (int y = 0; y < face.rows; ++y) {
        const uchar* f = face.ptr<uchar>(y);
        const uchar* m = mask.ptr<uchar>(y);
        const uchar* b = background.ptr<uchar>(y);
        uchar* o = out.ptr<uchar>(y);
        for (int x = 0, end = 0; x < face.cols; x = end) {
            for (end = x + 1; end < face.cols && m[end] == m[x];) ++end;
            const int first = 3 * x, last = 3 * end;
            const int keep = 255 - m[x];
            if (keep == 0) {
                std::copy(f + first, f + last, o + first);
            } else if (keep == 255) {
                for (int i = first; i < last; ++i) o[i] = saturated(f[i] + b[i]);
            } else {
                for (int i = first; i < last; ++i) o[i] = saturated(f[i] + (b[i] * keep + 127) / 255);
            }
        }
    }
}

// Fills occluder `o`'s shape in `target` with `value` (anti-aliased or not).
void fill_occluder_shape(const OccluderSpec& o, cv::Mat& target, const cv::Scalar& value, int line_type) {
    const cv::RotatedRect box(cv::Point2f(static_cast<float>(o.centre.x()), static_cast<float>(o.centre.y())),
                              cv::Size2f(static_cast<float>(2 * o.half_size.x()), static_cast<float>(2 * o.half_size.y())),
                              static_cast<float>(o.angle));
    if (o.shape == "ellipse") {
        cv::ellipse(target, box, value, cv::FILLED, line_type);
        return;
    }
    cv::Point2f corners[4];
    box.points(corners);
    std::vector<cv::Point> polygon;
    for (const auto& p : corners) polygon.emplace_back(cvRound(p.x), cvRound(p.y));
    cv::fillConvexPoly(target, polygon, value, line_type);
}

// The median colour of the pixels labelled skin (R G B, 0-255); mid grey when none are.
cv::Scalar median_skin_colour(const cv::Mat& image, const cv::Mat& labels) {
    std::array<std::vector<uchar>, 3> channels;
    if (labels.size() != image.size() || labels.type() != CV_8UC1) return cv::Scalar::all(128);
    for (int y = 0; y < image.rows; ++y) {
        const auto* px = image.ptr<cv::Vec3b>(y);
        const auto* label = labels.ptr<std::uint8_t>(y);
        for (int x = 0; x < image.cols; ++x)
            if (label[x] == static_cast<std::uint8_t>(morph::Region::kSkin))
                for (std::size_t c = 0; c < 3; ++c) channels[c].push_back(px[x][static_cast<int>(c)]);
    }
    cv::Scalar median = cv::Scalar::all(128);
    for (std::size_t c = 0; c < 3; ++c) {
        auto& v = channels[c];
        if (v.empty()) continue;
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        median[static_cast<int>(c)] = v[v.size() / 2];
    }
    return median;
}

// `coverage` stays empty when there are no occluders (most samples by default). Image-filled
// occluders take a crop of one of `library`'s images (as an image background does), blended in
// through the shape's anti-aliased alpha; skin-filled ones the face's median skin colour in `image`
// (`labels`: the render's regions), taken before any occluder is drawn.
void draw_occluders(const std::vector<OccluderSpec>& occluders, const ImageLibrary& library, const cv::Mat& labels, cv::Mat& image,
                    cv::Mat& coverage) {
    coverage.release();
    if (occluders.empty()) return;
    coverage = cv::Mat::zeros(image.size(), CV_8UC1);
    const bool skin_filled = std::any_of(occluders.begin(), occluders.end(), [](const OccluderSpec& o) { return o.skin_shade > 0; });
    const cv::Scalar skin = skin_filled ? median_skin_colour(image, labels) : cv::Scalar();
    cv::Mat fill, alpha, alpha3;
    for (const auto& o : occluders) {
        fill_occluder_shape(o, coverage, cv::Scalar(255), cv::LINE_8);
        if (o.skin_shade > 0) {
            fill_occluder_shape(o, image, skin * o.skin_shade, cv::LINE_AA);
            continue;
        }
        if (o.image_seed == 0) {
            fill_occluder_shape(o, image, to_scalar(o.colour), cv::LINE_AA);
            continue;
        }
        fill.create(image.size(), CV_8UC3);
        BackgroundSpec crop;
        crop.type = "images";
        crop.pattern_seed = o.image_seed;
        image_crop(fill, crop, library);
        alpha = cv::Mat::zeros(image.size(), CV_8UC1);
        fill_occluder_shape(o, alpha, cv::Scalar(255), cv::LINE_AA);
        cv::cvtColor(alpha, alpha3, cv::COLOR_GRAY2RGB);
        const cv::Mat blended = fill.mul(alpha3, 1.0 / 255) + image.mul(cv::Scalar::all(255) - alpha3, 1.0 / 255);
        blended.copyTo(image);
    }
}

// sRGB texture values whose linear albedo is multiplied by `gain` per channel (R G B).
void tone_texture(const cv::Mat& rgb, const Eigen::Vector3d& gain, cv::Mat& out) {
    cv::Mat lut(1, 256, CV_8UC3);
    for (int v = 0; v < 256; ++v) {
        const double linear = core::srgb_decode(v / 255.0);
        for (int c = 0; c < 3; ++c) lut.at<cv::Vec3b>(v)[c] = cv::saturate_cast<uchar>(255.0 * core::srgb_encode(linear * gain[c]));
    }
    cv::LUT(rgb, lut, out);
}

std::vector<int> occluded_by(const Eigen::Matrix2Xd& pixels, const cv::Mat& coverage) {
    std::vector<int> occluded(static_cast<std::size_t>(pixels.cols()), 0);
    for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
        const int u = static_cast<int>(std::lround(pixels(0, i)));
        const int v = static_cast<int>(std::lround(pixels(1, i)));
        if (u >= 0 && v >= 0 && u < coverage.cols && v < coverage.rows) occluded[static_cast<std::size_t>(i)] = coverage.at<uchar>(v, u) > 127;
    }
    return occluded;
}

}  // namespace

StageTimes::Stage& StageTimes::Stage::operator+=(const Stage& o) {
    wall += o.wall;
    cpu += o.cpu;
    return *this;
}

StageTimes& StageTimes::operator+=(const StageTimes& o) {
    sample += o.sample;
    render += o.render;
    composite += o.composite;
    encode += o.encode;
    write += o.write;
    return *this;
}

StageClock::StageClock() : wall_(std::chrono::steady_clock::now()), cpu_(thread_cpu_seconds()) {}

void StageClock::lap(StageTimes::Stage& stage) {
    const auto wall = std::chrono::steady_clock::now();
    const double cpu = thread_cpu_seconds();
    stage.wall += std::chrono::duration<double>(wall - wall_).count();
    stage.cpu += cpu - cpu_;
    wall_ = wall;
    cpu_ = cpu;
}

ImageLibrary::ImageLibrary(const std::filesystem::path& folder, const std::string& kind) {
    std::error_code error;
    if (!std::filesystem::is_directory(folder, error)) throw core::file_error(folder.string(), kind + " folder not found");
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        if (entry.is_regular_file()) files.push_back(entry.path());
    std::sort(files.begin(), files.end());  // the choice of image must not depend on directory order
    for (const auto& file : files) {
        cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
        if (bgr.empty() || bgr.cols < 8 || bgr.rows < 8) {
            std::fprintf(stderr, "facesynth: warning: %s: not a readable image, skipped\n", file.string().c_str());
            continue;
        }
        cv::Mat rgb;
        cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
        images_.push_back(std::move(rgb));
        names_.push_back(file.filename().string());
    }
    if (images_.empty()) throw core::file_error(folder.string(), "no readable " + kind + " images");
}

ImageLibrary::ImageLibrary(std::vector<cv::Mat> images, std::vector<std::string> names, std::vector<TextureFit> fits)
    : images_(std::move(images)), names_(std::move(names)), fits_(std::move(fits)) {
    for (const cv::Mat& image : images_) greyscale_.push_back(is_greyscale(image));
}

bool is_greyscale(const cv::Mat& rgb) {
    if (rgb.type() != CV_8UC3) return rgb.channels() == 1;
    std::size_t coloured = 0;
    for (int r = 0; r < rgb.rows; ++r) {
        const auto* p = rgb.ptr<cv::Vec3b>(r);
        for (int c = 0; c < rgb.cols; ++c) {
            const int lo = std::min({p[c][0], p[c][1], p[c][2]}), hi = std::max({p[c][0], p[c][1], p[c][2]});
            coloured += hi - lo > 2 ? 1 : 0;
        }
    }
    return coloured * 100 <= rgb.total();
}

SampleGenerator::SampleGenerator(const SynthConfig& config, const morph::MorphableModel& model, const ImageLibrary& backgrounds,
                                 const ImageLibrary& textures, const render::RendererOptions& renderer_options)
    : config_(config), model_(model), backgrounds_(backgrounds), textures_(textures),
      contour_region_(morph::jaw_contour_region(model)),
      albedo_check_(make_albedo_check(config, model)),
      antialiasing_(render::antialiasing_from(config.render.antialiasing, config.render.antialiasing_samples)), renderer_(renderer_options) {
    mesh_.triangles = model.triangles;
    mesh_.uv = model.uv;
    vertex_labels_ = model.vertex_labels;
    if (config.head.neck) {
        neck_ = make_neck_template(model);
        if (!neck_) throw core::Error("head.neck: model '" + model.name + "' has no 68 landmarks to place a neck by");
        mesh_.triangles = mesh_triangles_with_neck(model, *neck_);
        mesh_.uv = uv_with_neck(model, *neck_);
        vertex_labels_ = labels_with_neck(model, *neck_);
    }
    if (config.head.body) {
        head_parts_ = read_head_parts(config.head.parts_file.empty() ? default_head_parts_file() : std::filesystem::path(config.head.parts_file));
        if (!config.head.hair_styles.empty()) head_parts_->hair = hair_parts_named(*head_parts_, config.head.hair_styles);
        head_placement_.emplace(model, *head_parts_);
        if (config.head.ambient_occlusion > 0) skin_visibility_ = skin_ambient_visibility(*head_parts_, *head_placement_);
    }
    const int vertex_count = model.num_vertices() + (neck_ ? static_cast<int>(neck_->source.size()) : 0);
    landmark_topology_ = render::landmark_topology(mesh_.triangles, vertex_count, &contour_region_);
    // The jaw outline is the face's: neck triangles never count as face triangles.
    if (!landmark_topology_.face_triangles.empty())
        std::fill(landmark_topology_.face_triangles.begin() + static_cast<std::ptrdiff_t>(model.triangles.size()), landmark_topology_.face_triangles.end(), 0);
    if ((config.background.type == "images" || config.background.type == "wallpapers") && backgrounds.empty())
        throw core::Error("background.type = \"" + config.background.type + "\" needs readable background images");
    if (!config.albedo.texture_folder.empty() && textures.empty())
        throw core::Error("albedo.texture_folder needs a folder with readable texture images");
    if (!config.albedo.texture_bank.empty() && textures.empty())
        throw core::Error("albedo.texture_bank: the bank " + config.albedo.texture_bank + " was not loaded");
    // Checked here, before any sample is written, rather than at the first sample that draws such a texture.
    const auto fits = textures.fits();
    if (config.identity.source == "texture")
        for (std::size_t t = 0; t < textures.size(); ++t)
            if (t >= fits.size() || static_cast<int>(fits[t].shape.size()) != model.num_shape_components())
                throw core::Error("identity.source = \"texture\": texture " + textures.name(t) + " of the bank " + config.albedo.texture_bank +
                            " has no stored shape for model '" + model.name + "' (a bank made before shapes were stored: rebuild it)");
    if (config.expression.source == "texture")
        for (std::size_t t = 0; t < textures.size(); ++t)
            if (t >= fits.size() || !fits[t].expression || static_cast<int>(fits[t].expression->size()) != model.num_expression_components())
                throw core::Error("expression.source = \"texture\": texture " + textures.name(t) + " of the bank " + config.albedo.texture_bank +
                            " has no stored expression for model '" + model.name + "' (a bank made before expressions were stored: rebuild it)");
}

std::string SampleGenerator::renderer_description() const { return renderer_.backend() + " | " + renderer_.renderer_string(); }

Sample SampleGenerator::generate(std::int64_t index, StageTimes* times) {
    StageClock clock;
    StageTimes local;
    Sample s;
    s.spec = sample_scene(config_, model_, index, albedo_check_ ? &*albedo_check_ : nullptr, &mesh_.vertices, textures_.fits());
    morph::Mesh& mesh = mesh_;
    if (s.spec.skin_tone) mesh.colours = s.spec.skin_tone->cast<float>().replicate(1, model_.num_vertices());
    else mesh.colours = model_.albedo_instance(s.spec.beta);
    if (neck_) {
        append_neck_vertices(*neck_, model_, mesh);
        mesh.colours = colours_with_neck(mesh.colours, *neck_);
    }
    const cv::Mat* texture = nullptr;
    if (s.spec.texture_choice) {
        texture = &textures_.image(*s.spec.texture_choice);
        s.texture = textures_.name(*s.spec.texture_choice);
        if (s.spec.texture_gain != Eigen::Vector3d::Ones()) {
            tone_texture(*texture, s.spec.texture_gain, toned_texture_);
            texture = &toned_texture_;
        }
        // A bank's texture from a greyscale photograph makes a greyscale picture, as the photograph was;
        // its coarse colour never greys a coloured face. (A plain uv texture folder is taken as it is.)
        if (!config_.albedo.texture_bank.empty()) {
            s.spec.degradation.greyscale = textures_.greyscale(*s.spec.texture_choice);
            if (s.spec.texture_mix_choice && textures_.greyscale(*s.spec.texture_mix_choice) && !s.spec.degradation.greyscale)
                s.spec.texture_mix_choice.reset();
        }
        if (s.spec.texture_mix_choice) {
            s.texture_mix = textures_.name(*s.spec.texture_mix_choice);
            mix_coarse_colour(*texture, textures_.image(*s.spec.texture_mix_choice), s.spec.texture_mix_weight, mixed_texture_);
            texture = &mixed_texture_;
        }
    }
    const render::LandmarkTopology* topology = &landmark_topology_;
    if (s.spec.head_parts) {
        texture = dress(s, texture);
        topology = dressed_topology_;
    }
    clock.lap(local.sample);

    render::Camera camera{s.spec.intrinsics, s.spec.pose, render::Projection::kPerspective};
    render::RenderSettings settings;
    settings.lighting = s.spec.lighting.lighting;
    settings.geometry = true;  // depth for landmark visibility
    settings.normals = config_.output.normals;  // an extra float target: only when written
    settings.antialiasing = antialiasing_;
    settings.shadow_map_size = config_.render.shadow_map_size;
    settings.lights_per_vertex = config_.render.lights_per_vertex;
    render::MeshExtras extras;
    extras.vertex_labels = s.spec.head_parts ? std::span<const std::uint8_t>(dressed_labels_) : std::span<const std::uint8_t>(vertex_labels_);
    extras.texture = texture;
    renderer_.render(mesh, camera, settings, frame_, extras);
    if (s.spec.lighting.head_parts && s.spec.head_parts) {
        render::RenderSettings parts = settings;
        parts.lighting = *s.spec.lighting.head_parts;
        parts.geometry = false;
        renderer_.render(mesh, camera, parts, head_parts_frame_, extras);
        take_head_parts(frame_.rgb, head_parts_frame_.rgb, frame_.labels);
    }
    clock.lap(local.render);

    // Landmarks in both jaw modes with self-occlusion from the depth buffer (render/landmarks.h).
    const auto projected = render::project_landmarks(model_.landmarks, mesh, camera, frame_, {}, &contour_region_, topology);
    auto& labels = s.labels;
    labels.landmarks_fixed = projected.pixels;
    labels.landmarks_3d_fixed = projected.model_points;
    labels.visible_fixed.assign(projected.visible.begin(), projected.visible.end());
    labels.landmarks_contour = projected.contour_pixels;
    labels.landmarks_3d_contour = projected.contour_model_points;
    labels.visible_contour.assign(projected.contour_visible.begin(), projected.contour_visible.end());
    if (config_.landmarks.mode == "even") {
        const render::RespacedJaw even = render::space_jaw_evenly(projected.contour_pixels, projected.contour_model_points, projected.contour_visible);
        labels.landmarks_even = even.pixels;
        labels.landmarks_3d_even = even.model_points;
        labels.visible_even.assign(even.visible.begin(), even.visible.end());
    }

    if (s.spec.lighting.face_luminance > 0)
        s.exposure_gain = expose_face(frame_.rgb, frame_.mask, chosen_landmarks(labels, config_.landmarks.mode), s.spec.lighting.face_luminance,
                                      s.spec.lighting.lighting.gamma);
    make_background(frame_.rgb.size(), s.spec.background, backgrounds_, background_, background_canvas_);
    composite(frame_.rgb, frame_.mask, background_, s.image);
    s.mask = frame_.mask.clone();
    cv::Mat occluder_coverage;
    draw_occluders(s.spec.occluders, backgrounds_, frame_.labels, s.image, occluder_coverage);
    if (!occluder_coverage.empty()) s.mask.setTo(0, occluder_coverage);  // an empty mask would clear it all
    labels.occluded = occluded_by(chosen_landmarks(labels, config_.landmarks.mode), occluder_coverage);
    core::Rng noise = core::make_rng(s.spec.seed, static_cast<std::uint64_t>(index), core::RandomStream::kNoise);
    degrade::apply(s.image, s.spec.degradation, noise);
    if (config_.output.depth) s.depth = frame_.depth.clone();
    if (config_.output.normals) s.normals = frame_.normals.clone();
    if (config_.output.labels) {
        s.regions = frame_.labels.clone();
        if (!occluder_coverage.empty()) s.regions.setTo(0, occluder_coverage);
    }
    clock.lap(local.composite);
    if (times) *times += local;
    return s;
}

const cv::Mat* SampleGenerator::dress(Sample& s, const cv::Mat* texture) {
    const HeadPartsSpec& spec = *s.spec.head_parts;
    const int model_vertices = model_.num_vertices();
    const auto model_shape = mesh_.vertices.leftCols(model_vertices);
    // The body's skin and (by choice) the hair take the face's own colours.
    Eigen::Vector3d skin = Eigen::Vector3d::Constant(0.5), hair = spec.hair_colour;
    if (texture) {
        skin = texture_colour_of(*texture, model_, morph::Region::kSkin);
        // The scalp of a texture shows hair only when the photograph's hairline came into it: a
        // scalp no darker than the skin is skin or background, and the drawn colour is used.
        const Eigen::Vector3d scalp = texture_colour_of(*texture, model_, morph::Region::kHair);
        if (spec.hair_colour_from_texture && scalp.sum() < 0.8 * skin.sum()) hair = scalp;
    } else {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int n = 0;
        for (int v = 0; v < model_vertices; ++v)
            if (model_.vertex_labels.empty() || model_.vertex_labels[static_cast<std::size_t>(v)] == static_cast<std::uint8_t>(morph::Region::kSkin))
                sum += mesh_.colours.col(v).cast<double>(), ++n;
        if (n > 0) skin = sum / n;
    }
    dress_head(*head_parts_, spec, head_placement_->transform(model_shape), s.spec.pose.rotation, skin, hair, head_placement_->face_only(), dressed_,
               {skin_visibility_, config_.head.ambient_occlusion});
    const auto& parts = head_parts_->parts;
    s.clothing = parts[static_cast<std::size_t>(head_parts_->clothing[spec.clothing_choice % head_parts_->clothing.size()])].name;
    if (spec.hair && !head_parts_->hair.empty()) s.hair = parts[static_cast<std::size_t>(head_parts_->hair[spec.hair_choice % head_parts_->hair.size()])].name;

    const int total = model_vertices + static_cast<int>(dressed_.vertices.cols());
    mesh_.vertices.conservativeResize(3, total);
    mesh_.vertices.rightCols(dressed_.vertices.cols()) = dressed_.vertices;
    mesh_.triangles.assign(model_.triangles.begin(), model_.triangles.end());
    for (const morph::Triangle& t : dressed_.triangles) mesh_.triangles.push_back({t[0] + model_vertices, t[1] + model_vertices, t[2] + model_vertices});
    // A model without labels is skin throughout (as the renderer takes an empty label list).
    dressed_labels_.assign(vertex_labels_.begin(), vertex_labels_.begin() + std::min<std::ptrdiff_t>(std::ssize(vertex_labels_), model_vertices));
    dressed_labels_.resize(static_cast<std::size_t>(model_vertices), static_cast<std::uint8_t>(morph::Region::kSkin));
    dressed_labels_.insert(dressed_labels_.end(), dressed_.labels.begin(), dressed_.labels.end());
    mesh_.colours.conservativeResize(3, total);
    mesh_.colours.rightCols(dressed_.colours.cols()) = dressed_.colours.cast<float>();
    if (texture) {
        mesh_.uv.resize(2, total);
        mesh_.uv.leftCols(model_vertices) = model_.uv;
        mesh_.uv.block(1, 0, 1, model_vertices) *= static_cast<float>(kAtlasFaceShare);
        mesh_.uv.rightCols(dressed_.uv.cols()) = dressed_.uv;
        make_parts_atlas(*texture, spec, skin, hair, atlas_, !skin_visibility_.empty());
        texture = &atlas_;
    }
    // The topology depends only on which parts are worn: made once per hair and outfit pair.
    const int hair_index = spec.hair && !head_parts_->hair.empty() ? static_cast<int>(spec.hair_choice % head_parts_->hair.size()) : -1;
    const auto key = std::make_pair(hair_index, static_cast<int>(spec.clothing_choice % head_parts_->clothing.size()));
    auto cached = dressed_topologies_.find(key);
    if (cached == dressed_topologies_.end()) {
        render::LandmarkTopology topology = render::landmark_topology(mesh_.triangles, total, &contour_region_);
        // The jaw outline is the face's: the parts' triangles never count as face triangles.
        if (!topology.face_triangles.empty())
            std::fill(topology.face_triangles.begin() + static_cast<std::ptrdiff_t>(model_.triangles.size()), topology.face_triangles.end(), 0);
        cached = dressed_topologies_.emplace(key, std::move(topology)).first;
    }
    dressed_topology_ = &cached->second;
    return texture;
}

const Eigen::Matrix2Xd& chosen_landmarks(const SampleLabels& labels, const std::string& mode) {
    if (mode == "fixed") return labels.landmarks_fixed;
    return mode == "even" ? labels.landmarks_even : labels.landmarks_contour;
}

const Eigen::Matrix3Xd& chosen_landmarks_3d(const SampleLabels& labels, const std::string& mode) {
    if (mode == "fixed") return labels.landmarks_3d_fixed;
    return mode == "even" ? labels.landmarks_3d_even : labels.landmarks_3d_contour;
}

const std::vector<int>& chosen_visibility(const SampleLabels& labels, const std::string& mode) {
    if (mode == "fixed") return labels.visible_fixed;
    return mode == "even" ? labels.visible_even : labels.visible_contour;
}

}  // namespace facesynth::synth
