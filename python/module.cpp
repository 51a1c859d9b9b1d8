// The compiled part of the `facesynth` Python package (python/facesynth/__init__.py wraps it): a
// generator that renders synthetic samples on C++ threads, with the GIL released, straight into
// numpy arrays.
#include "core/error.h"
#include "fit/dataset_eval.h"
#include "fit/fit_record.h"
#include "frontal/benchmark.h"
#include "frontal/frontalise.h"
#include "morph/camera.h"
#include "morph/jaw_contour.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "morph/pose.h"
#include "morph/sampling.h"
#include "render/framing.h"
#include "render/landmarks.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/stream.h"
#include "train/face_box.h"
#include "train/metrics.h"
#include "train/realism.h"
#include "train/regressor.h"
#include "train/sdm.h"
#include "track/session.h"
#include "track/tracker.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace py = pybind11;

namespace facesynth::python {
namespace {

// Config errors are the caller's values: ValueError, with synth's message (it names the key).
synth::SynthConfig resolve_config(const std::string& config_file, const std::string& settings_json, const std::optional<std::string>& model,
                                  const std::optional<std::int64_t>& seed, const std::optional<std::pair<int, int>>& size) {
    synth::SynthConfig config;
    try {
        if (!config_file.empty()) synth::apply_toml_file(config, config_file);
        if (!settings_json.empty()) synth::apply_settings(config, nlohmann::json::parse(settings_json), "config");
        if (model) config.model = *model;
        if (seed) {
            if (*seed < 0) throw core::Error("seed must not be negative (got " + std::to_string(*seed) + ")");
            config.seed = static_cast<std::uint64_t>(*seed);
        }
        if (size) {
            config.camera.width = size->first;
            config.camera.height = size->second;
        }
        synth::validate(config);
    } catch (const core::Error& e) {
        throw py::value_error(e.what());
    }
    return config;
}

// Where one sample's values go in the arrays of a batch: row `slot` of each.
struct BatchArrays {
    py::array_t<std::uint8_t> image;
    py::array_t<float> landmarks, landmarks_3d;
    py::array_t<bool> visible;
    py::array_t<float> pose, alpha, expression;
    py::array_t<double> camera;
    py::array_t<float> fov;
    std::optional<py::array_t<std::uint8_t>> mask, labels;
    std::optional<py::array_t<float>> depth, normals;
};

// The rows of an array whose first dimension is the sample, as a raw pointer taken while the GIL is
// held, so that worker threads write through it without touching Python objects.
template <typename T>
struct Rows {
    T* data = nullptr;
    std::size_t per_row = 0;
    Rows() = default;
    explicit Rows(py::array_t<T>& array) : data(array.mutable_data()), per_row(static_cast<std::size_t>(array.size() / array.shape(0))) {}
    [[nodiscard]] T* at(std::int64_t slot) const { return data + static_cast<std::size_t>(slot) * per_row; }
};

// Copies a CV_8UC3 / CV_8UC1 / CV_32FC1 / CV_32FC3 image, row by row (its rows may be padded).
template <typename T>
void copy_image(const cv::Mat& image, T* out, const std::string& what) {
    if (image.empty()) throw core::Error(what + " is missing");
    const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * image.elemSize();
    auto* bytes = reinterpret_cast<std::uint8_t*>(out);
    for (int y = 0; y < image.rows; ++y) std::memcpy(bytes + static_cast<std::size_t>(y) * row_bytes, image.ptr(y), row_bytes);
}

// An empty vector (a neutral face's expression) is all zeros.
void copy_coefficients(const std::vector<float>& values, float* out, py::ssize_t width, const char* what) {
    if (values.empty()) {
        std::fill(out, out + width, 0.0f);
        return;
    }
    if (static_cast<py::ssize_t>(values.size()) != width)
        throw core::Error(std::string(what) + " has " + std::to_string(values.size()) + " coefficients, expected " + std::to_string(width));
    std::copy(values.begin(), values.end(), out);
}

// Model space to homogeneous pixels: [u v w]^T = P [X Y Z 1]^T, pixel = (u / w, v / w) (w = 1 for
// an orthographic camera).
Eigen::Matrix<double, 3, 4, Eigen::RowMajor> projection_matrix(const morph::Intrinsics& k, const morph::CameraPose& pose, bool orthographic) {
    Eigen::Matrix<double, 4, 4> extrinsics = Eigen::Matrix4d::Identity();
    extrinsics.topLeftCorner<3, 3>() = morph::model_to_camera_flip() * pose.rotation;
    extrinsics.topRightCorner<3, 1>() = pose.translation;
    Eigen::Matrix<double, 3, 4> intrinsics;
    if (orthographic) intrinsics << k.fx, 0, 0, k.cx, 0, k.fy, 0, k.cy, 0, 0, 0, 1;
    else intrinsics << k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0;
    return intrinsics * extrinsics;
}

class Generator {
public:
    Generator(const std::string& config_file, const std::string& settings_json, const std::optional<std::string>& model,
              const std::optional<std::int64_t>& seed, const std::optional<std::pair<int, int>>& size, int workers)
        : stream_(resolve_config(config_file, settings_json, model, seed, size), workers) {}

    py::dict batch(std::int64_t start, std::int64_t count) {
        if (start < 0) throw py::value_error("start must not be negative (got " + std::to_string(start) + ")");
        if (count < 1) throw py::value_error("count must be at least 1 (got " + std::to_string(count) + ")");
        const synth::SynthConfig& config = stream_.config();
        const morph::MorphableModel& model = stream_.model();
        const py::ssize_t n = count, h = config.camera.height, w = config.camera.width;
        const py::ssize_t landmarks = static_cast<py::ssize_t>(model.landmarks.size());
        BatchArrays a{py::array_t<std::uint8_t>({n, h, w, py::ssize_t{3}}),
                      py::array_t<float>({n, landmarks, py::ssize_t{2}}),
                      py::array_t<float>({n, landmarks, py::ssize_t{3}}),
                      py::array_t<bool>({n, landmarks}),
                      py::array_t<float>({n, py::ssize_t{3}}),
                      py::array_t<float>({n, py::ssize_t{model.num_shape_components()}}),
                      py::array_t<float>({n, py::ssize_t{model.num_expression_components()}}),
                      py::array_t<double>({n, py::ssize_t{3}, py::ssize_t{4}}),
                      py::array_t<float>({n}),
                      {}, {}, {}, {}};
        if (config.output.mask) a.mask = py::array_t<std::uint8_t>({n, h, w});
        if (config.output.labels) a.labels = py::array_t<std::uint8_t>({n, h, w});
        if (config.output.depth) a.depth = py::array_t<float>({n, h, w});
        if (config.output.normals) a.normals = py::array_t<float>({n, h, w, py::ssize_t{3}});
        const Rows<std::uint8_t> image(a.image), mask = a.mask ? Rows<std::uint8_t>(*a.mask) : Rows<std::uint8_t>(),
                                                 labels = a.labels ? Rows<std::uint8_t>(*a.labels) : Rows<std::uint8_t>();
        const Rows<float> points_2d(a.landmarks), points_3d_rows(a.landmarks_3d), pose_rows(a.pose), alpha(a.alpha), expression(a.expression),
            fov(a.fov), depth = a.depth ? Rows<float>(*a.depth) : Rows<float>(), normals = a.normals ? Rows<float>(*a.normals) : Rows<float>();
        const Rows<bool> visible_rows(a.visible);
        const Rows<double> camera(a.camera);
        const auto alpha_width = static_cast<py::ssize_t>(alpha.per_row), expression_width = static_cast<py::ssize_t>(expression.per_row);
        const auto consume = [&](int /*worker*/, std::int64_t slot, synth::Sample& s) {
            if (s.image.rows != h || s.image.cols != w)
                throw core::Error("image is " + std::to_string(s.image.cols) + "x" + std::to_string(s.image.rows) + ", expected " + std::to_string(w) + "x" +
                                  std::to_string(h));
            copy_image(s.image, image.at(slot), "image");
            const Eigen::Matrix2Xd& points = synth::chosen_landmarks(s.labels, config.landmarks.mode);
            const Eigen::Matrix3Xd& points_3d = synth::chosen_landmarks_3d(s.labels, config.landmarks.mode);
            const std::vector<int>& visible = synth::chosen_visibility(s.labels, config.landmarks.mode);
            if (points.cols() != landmarks) throw core::Error("sample has " + std::to_string(points.cols()) + " landmarks, expected " + std::to_string(landmarks));
            float* p = points_2d.at(slot);
            float* p3 = points_3d_rows.at(slot);
            bool* v = visible_rows.at(slot);
            for (py::ssize_t i = 0; i < landmarks; ++i) {
                p[2 * i] = static_cast<float>(points(0, i));
                p[2 * i + 1] = static_cast<float>(points(1, i));
                for (int c = 0; c < 3; ++c) p3[3 * i + c] = static_cast<float>(points_3d(c, i));
                v[i] = visible[static_cast<std::size_t>(i)] != 0;
            }
            float* pose = pose_rows.at(slot);
            pose[0] = static_cast<float>(s.spec.angles.yaw);
            pose[1] = static_cast<float>(s.spec.angles.pitch);
            pose[2] = static_cast<float>(s.spec.angles.roll);
            copy_coefficients(s.spec.alpha, alpha.at(slot), alpha_width, "alpha");
            copy_coefficients(s.spec.psi, expression.at(slot), expression_width, "expression");
            const Eigen::Matrix<double, 3, 4, Eigen::RowMajor> projection = projection_matrix(s.spec.intrinsics, s.spec.pose, false);
            std::copy(projection.data(), projection.data() + 12, camera.at(slot));
            *fov.at(slot) = static_cast<float>(s.spec.fov);
            if (mask.data) copy_image(s.mask, mask.at(slot), "mask");
            if (labels.data) copy_image(s.regions, labels.at(slot), "labels");
            if (depth.data) copy_image(s.depth, depth.at(slot), "depth");
            if (normals.data) copy_image(s.normals, normals.at(slot), "normals");
        };
        {
            const py::gil_scoped_release released;
            stream_.generate(start, count, consume);
        }
        py::dict out;
        out["image"] = a.image;
        out["landmarks"] = a.landmarks;
        out["landmarks_3d"] = a.landmarks_3d;
        out["visible"] = a.visible;
        out["pose"] = a.pose;
        out["alpha"] = a.alpha;
        out["expression"] = a.expression;
        out["camera"] = a.camera;
        out["fov"] = a.fov;
        if (a.mask) out["mask"] = *a.mask;
        if (a.labels) out["labels"] = *a.labels;
        if (a.depth) out["depth"] = *a.depth;
        if (a.normals) out["normals"] = *a.normals;
        return out;
    }

    [[nodiscard]] std::string config_json() const { return synth::to_json(stream_.config()).dump(); }
    [[nodiscard]] std::string config_toml() const { return synth::to_commented_toml(stream_.config()); }
    [[nodiscard]] const synth::SampleStream& stream() const { return stream_; }

private:
    synth::SampleStream stream_;
};

// ---- arrays in and out ----

std::string shape_text(const py::array& a) {
    std::string text = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) text += (d ? ", " : "") + std::to_string(a.shape(d));
    return text + (a.ndim() == 1 ? ",)" : ")") + " " + std::string(py::str(a.dtype()));
}

// A (68, 2) array of pixel positions (any real dtype) as 2 x 68.
Eigen::Matrix2Xd landmarks_from(const py::array& array, const char* name) {
    if (array.ndim() != 2 || array.shape(0) != morph::kNumIbugLandmarks || array.shape(1) != 2 || array.dtype().kind() != 'f')
        throw py::value_error(std::string(name) + " must be a (68, 2) float array of 0-based pixels, got " + shape_text(array));
    const auto values = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
    Eigen::Matrix2Xd points(2, morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) points.col(i) = Eigen::Vector2d(values.at(i, 0), values.at(i, 1));
    return points;
}

// An RGB (H, W, 3) or grey (H, W) uint8 array as an 8-bit B G R image (a copy).
cv::Mat bgr_from(const py::array& array, const char* name) {
    const bool rgb = array.ndim() == 3 && array.shape(2) == 3, grey = array.ndim() == 2;
    if (!(rgb || grey) || !py::isinstance<py::array_t<std::uint8_t>>(array) || array.shape(0) < 1 || array.shape(1) < 1)
        throw py::value_error(std::string(name) + " must be an (H, W, 3) RGB or (H, W) grey uint8 array, got " + shape_text(array));
    const auto pixels = py::array_t<std::uint8_t, py::array::c_style>::ensure(array);
    const cv::Mat view(static_cast<int>(array.shape(0)), static_cast<int>(array.shape(1)), rgb ? CV_8UC3 : CV_8UC1,
                       const_cast<std::uint8_t*>(pixels.data()));
    cv::Mat bgr;
    cv::cvtColor(view, bgr, rgb ? cv::COLOR_RGB2BGR : cv::COLOR_GRAY2BGR);
    return bgr;
}

// An 8-bit image (B G R, B G R A or grey) as a numpy array, channels in R G B (A) order.
py::array_t<std::uint8_t> array_from(const cv::Mat& image) {
    cv::Mat converted;
    if (image.channels() == 3) cv::cvtColor(image, converted, cv::COLOR_BGR2RGB);
    else if (image.channels() == 4) cv::cvtColor(image, converted, cv::COLOR_BGRA2RGBA);
    else converted = image.isContinuous() ? image : image.clone();
    std::vector<py::ssize_t> shape{converted.rows, converted.cols};
    if (converted.channels() > 1) shape.push_back(converted.channels());
    py::array_t<std::uint8_t> out(shape);
    std::memcpy(out.mutable_data(), converted.data, converted.total() * converted.elemSize());
    return out;
}

py::array_t<float> array_from(const std::vector<float>& values) {
    py::array_t<float> out(static_cast<py::ssize_t>(values.size()));
    std::copy(values.begin(), values.end(), out.mutable_data());
    return out;
}

// A 2 x N or 3 x N matrix as an (N, 2) / (N, 3) array.
template <typename Matrix>
py::array_t<double> points_array(const Matrix& m) {
    py::array_t<double> out({static_cast<py::ssize_t>(m.cols()), static_cast<py::ssize_t>(m.rows())});
    for (Eigen::Index i = 0; i < m.cols(); ++i)
        for (Eigen::Index r = 0; r < m.rows(); ++r) out.mutable_at(i, r) = static_cast<double>(m(r, i));
    return out;
}

std::vector<float> coefficients_from(const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& values,
                                     int available, const char* name) {
    if (!values) return {};
    if (values->ndim() != 1 || values->shape(0) > available)
        throw py::value_error(std::string(name) + " must be a 1-d array of at most " + std::to_string(available) + " coefficients, got " +
                              shape_text(*values));
    return {values->data(), values->data() + values->shape(0)};
}

// A JSON record (fit.json's keys) as the Python values json.loads makes of it.
py::dict dict_from_json(const nlohmann::json& record) { return py::module_::import("json").attr("loads")(record.dump()); }

// ---- models ----

class Model {
public:
    explicit Model(const std::string& spec) : model_(std::make_shared<const morph::MorphableModel>(morph::load_model(spec))) {}
    [[nodiscard]] const morph::MorphableModel& get() const { return *model_; }
    [[nodiscard]] std::shared_ptr<const morph::MorphableModel> shared() const { return model_; }
    // Built on the first fit and kept: its precomputed bases are most of a single fit's time.
    // Fitter::fit is const and may run on several threads at once.
    [[nodiscard]] const fit::Fitter& fitter() const {
        std::call_once(fitter_once_, [this] { fitter_ = std::make_unique<const fit::Fitter>(*model_); });
        return *fitter_;
    }

    [[nodiscard]] py::array_t<float> vertices(const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& alpha,
                                              const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& expression) const {
        const std::vector<float> a = coefficients_from(alpha, model_->num_shape_components(), "alpha");
        const std::vector<float> e = coefficients_from(expression, model_->num_expression_components(), "expression");
        const Eigen::Matrix3Xf v = model_->shape_instance(a, e);
        py::array_t<float> out({static_cast<py::ssize_t>(v.cols()), py::ssize_t{3}});
        std::memcpy(out.mutable_data(), v.data(), sizeof(float) * static_cast<std::size_t>(v.size()));  // column-major 3 x V = row-major V x 3
        return out;
    }

    [[nodiscard]] py::array_t<std::int32_t> triangles() const {
        py::array_t<std::int32_t> out({static_cast<py::ssize_t>(model_->triangles.size()), py::ssize_t{3}});
        for (std::size_t t = 0; t < model_->triangles.size(); ++t)
            for (int c = 0; c < 3; ++c) out.mutable_at(static_cast<py::ssize_t>(t), c) = model_->triangles[t][static_cast<std::size_t>(c)];
        return out;
    }

    [[nodiscard]] py::array_t<double> landmarks(const py::array_t<float, py::array::c_style | py::array::forcecast>& vertices) const {
        if (vertices.ndim() != 2 || vertices.shape(0) != model_->num_vertices() || vertices.shape(1) != 3)
            throw py::value_error("vertices must be a (" + std::to_string(model_->num_vertices()) + ", 3) array, got " + shape_text(vertices));
        const Eigen::Map<const Eigen::Matrix3Xf> v(vertices.data(), 3, model_->num_vertices());
        return points_array(model_->landmark_positions(v));
    }

private:
    std::shared_ptr<const morph::MorphableModel> model_;
    mutable std::once_flag fitter_once_;
    mutable std::unique_ptr<const fit::Fitter> fitter_;
};

py::array_t<double> matrix_array(const Eigen::Matrix<double, 3, 4, Eigen::RowMajor>& m) {
    py::array_t<double> out({py::ssize_t{3}, py::ssize_t{4}});
    std::copy(m.data(), m.data() + 12, out.mutable_data());
    return out;
}

template <typename T>
py::array_t<T> map_array(const cv::Mat& image, int channels) {
    std::vector<py::ssize_t> shape{image.rows, image.cols};
    if (channels > 1) shape.push_back(channels);
    py::array_t<T> out(shape);
    copy_image(image, out.mutable_data(), "map");
    return out;
}

py::array_t<bool> flags_array(const std::vector<std::uint8_t>& flags) {
    py::array_t<bool> out(static_cast<py::ssize_t>(flags.size()));
    for (std::size_t i = 0; i < flags.size(); ++i) out.mutable_at(static_cast<py::ssize_t>(i)) = flags[i] != 0;
    return out;
}

// One instance of a model rendered as `facesynth render` renders it: framed by render::frame_mesh,
// the renderer's default lighting. One GL context, used by one thread at a time.
class Renderer {
public:
    Renderer(const Model& model, const std::string& antialiasing, int samples)
        : model_(model.shared()), contour_region_(morph::jaw_contour_region(*model_)), renderer_(render::RendererOptions{}) {
        try {
            settings_.antialiasing = render::antialiasing_from(antialiasing, samples);
        } catch (const core::Error& e) {
            throw py::value_error(e.what());
        }
        settings_.barycentrics = false;
        extras_.vertex_labels = model_->vertex_labels;
    }

    py::dict render(const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& alpha,
                    const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& expression,
                    const std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>& colour, const render::Framing& framing) {
        const morph::MorphableModel& m = *model_;
        const std::vector<float> a = coefficients_from(alpha, m.num_shape_components(), "alpha");
        const std::vector<float> e = coefficients_from(expression, m.num_expression_components(), "expression");
        const std::vector<float> b = coefficients_from(colour, m.num_albedo_components(), "colour");
        if (framing.width < 1 || framing.height < 1 || framing.width > 16384 || framing.height > 16384)
            throw py::value_error("size must be 1 to 16384 pixels per side");
        if (!(framing.fov >= 1 && framing.fov <= 170)) throw py::value_error("fov must be 1 to 170 degrees");
        render::Frame frame;
        render::Camera camera;
        render::ProjectedLandmarks landmarks;
        {
            const py::gil_scoped_release released;
            const std::lock_guard lock(mutex_);
            const morph::Mesh mesh = m.instance(a, e, b);
            camera = render::frame_mesh(mesh, framing);
            renderer_.render(mesh, camera, settings_, frame, extras_);
            landmarks = render::project_landmarks(m.landmarks, mesh, camera, frame, {}, &contour_region_);
        }
        py::dict out;
        out["image"] = map_array<std::uint8_t>(frame.rgb, 3);
        out["mask"] = map_array<std::uint8_t>(frame.mask, 1);
        out["depth"] = map_array<float>(frame.depth, 1);
        out["normals"] = map_array<float>(frame.normals, 3);
        out["labels"] = map_array<std::uint8_t>(frame.labels, 1);
        out["landmarks_fixed"] = points_array(landmarks.pixels);
        out["landmarks_contour"] = points_array(landmarks.contour_pixels);
        out["visible_fixed"] = flags_array(landmarks.visible);
        out["visible_contour"] = flags_array(landmarks.contour_visible);
        out["camera"] = matrix_array(projection_matrix(camera.intrinsics, camera.pose, framing.orthographic));
        return out;
    }

private:
    std::shared_ptr<const morph::MorphableModel> model_;
    morph::JawContourRegion contour_region_;
    render::Renderer renderer_;
    render::RenderSettings settings_;
    render::MeshExtras extras_;
    std::mutex mutex_;
};

// ---- fitting ----

py::dict fit_landmarks(const py::array& landmarks, const Model& model, const std::optional<std::pair<int, int>>& image_size,
                       const std::string& jaw, double lambda, bool refine, double focal, double sigma, bool fit_expression) {
    fit::FaceFitChoices choices;
    try {
        choices.jaw = fit::parse_jaw_mode(jaw);
    } catch (const core::Error& e) {
        throw py::value_error(e.what());
    }
    if (!(lambda >= 0)) throw py::value_error("lambda must be a non-negative number");
    choices.lambda = lambda;
    choices.refine = refine;
    choices.focal_px = focal;
    choices.landmark_sigma_px = sigma;
    choices.fit_expression = fit_expression;
    if (image_size) {
        if (image_size->first < 1 || image_size->second < 1) throw py::value_error("image_size must be (width, height) in pixels");
        choices.image_width = image_size->first;
        choices.image_height = image_size->second;
    }
    const Eigen::Matrix2Xd points = landmarks_from(landmarks, "landmarks");
    fit::LandmarkFit fitted;
    {
        const py::gil_scoped_release released;
        try {
            fitted = fit::fit_face(model.fitter(), points, fit::landmark_fit_options(choices));
        } catch (const core::Error& e) {
            throw py::value_error(std::string("landmarks: ") + e.what());
        }
    }
    nlohmann::json record;
    fit::write_json(record, fitted);
    py::dict out = dict_from_json(record);
    out["alpha"] = array_from(fitted.alpha());
    out["expression"] = array_from(fitted.psi());
    out["projected"] = points_array(fitted.projected());
    out["vertices_px"] = points_array(fitted.vertices_px);
    return out;
}

// ---- landmark accuracy, as `facesynth eval landmarks` reports it ----

double landmark_nme(const py::array& predicted, const py::array& truth) {
    return train::landmark_nme(landmarks_from(predicted, "predicted"), landmarks_from(truth, "truth"));
}

py::dict nme_summary(const py::array_t<double, py::array::c_style | py::array::forcecast>& nmes, double threshold) {
    if (nmes.ndim() != 1) throw py::value_error("nmes must be a 1-d array of per-face NMEs (inf for a missed face), got " + shape_text(nmes));
    if (!(threshold > 0)) throw py::value_error("threshold must be positive");
    for (py::ssize_t i = 0; i < nmes.shape(0); ++i)
        if (std::isnan(nmes.at(i)) || nmes.at(i) < 0)
            throw py::value_error("nmes[" + std::to_string(i) + "] is " + std::to_string(nmes.at(i)) + ": NMEs are non-negative (inf for a missed face)");
    const train::NmeSummary s = train::summarise_nme(std::span<const double>(nmes.data(), static_cast<std::size_t>(nmes.shape(0))), threshold);
    py::dict out;
    out["count"] = s.count;
    out["nme_mean"] = s.mean;
    out["nme_median"] = s.median;
    out["auc_008"] = s.auc_008;
    out["failure_rate_008"] = s.failure_rate_008;
    return out;
}

// `facesynth eval fit`: the same figures under the same keys as its --json.
py::dict eval_fit(const Model& model, const std::string& data, const std::string& mode, int count, std::int64_t seed, double noise,
                  const std::string& landmarks, bool refine, bool visible_only, double lambda, double sigma, std::optional<double> max_yaw) {
    fit::FitSetEvalSettings s;
    s.data = data;
    s.mode = mode;
    s.count = count;
    s.seed = seed;
    s.noise_px = noise;
    s.landmark_set = landmarks;
    s.refine = refine;
    s.visible_only = visible_only;
    s.lambda = lambda;
    s.sigma_px = sigma;
    s.max_yaw_deg = max_yaw;
    try {
        fit::check_fit_set_settings(s);
        (void)morph::parse_landmark_subset(landmarks);
    } catch (const core::Error& e) {
        throw py::value_error(e.what());
    }
    fit::FitSetEvaluation evaluation;
    {
        const py::gil_scoped_release released;
        evaluation = fit::evaluate_fit_set(model.fitter(), model.get().name, s);
    }
    if (const std::string failure = fit::fit_set_failure(s, evaluation); !failure.empty()) {
        std::string message = failure;
        for (const std::string& error : evaluation.errors) message += "\n" + error;
        throw core::Error(message);
    }
    return dict_from_json(evaluation.json);
}

// `facesynth eval realism`: the same figures under the same keys as its --json; unreadable images
// are Python warnings (the CLI's warning lines) and count as misses.
py::dict eval_realism(const std::string& data, const std::string& photos, const std::string& regressor_spec, const std::string& detector_option,
                      double max_yaw, bool match_face_size) {
    if (!(max_yaw >= 0 && max_yaw <= 90)) throw py::value_error("max_yaw must be in [0, 90] degrees, got " + std::to_string(max_yaw));
    const auto regressor = train::open_regressor(regressor_spec);
    const train::LandmarkRegressor* const regressors[] = {regressor.get()};
    train::DetectorKind detector{};
    try {
        detector = train::choose_detector(detector_option, regressors);
    } catch (const core::Error& e) {
        throw py::value_error(e.what());
    }
    train::RealismReport report;
    {
        const py::gil_scoped_release released;
        std::optional<fit::Fitter> fitter;
        std::shared_ptr<const morph::MorphableModel> builtin;
        if (!photos.empty()) {
            builtin = std::make_shared<const morph::MorphableModel>(morph::load_model("builtin"));
            fitter.emplace(*builtin);
        }
        const train::AnnotationYaw photo_yaw = [&](const Eigen::Matrix2Xd& annotation) { return fit::annotated_yaw(*fitter, annotation); };
        report = train::evaluate_realism({data, photos, max_yaw, match_face_size}, *regressor, detector, photo_yaw);
    }
    const py::object warn = py::module_::import("warnings").attr("warn");
    for (const train::RealismSide* side : {&report.renders, &report.photos})
        for (const auto& w : side->warnings) warn(w);
    return dict_from_json(report.json);
}

// `facesynth eval frontalise` from true landmarks (the CLI's --regressor is not bound): the same
// figures under the same keys as its --json.
py::dict eval_frontalise(const Model& model, int count, std::int64_t seed, int isomap_size, int size, int image_size, double fov, double framing,
                         const std::string& lighting) {
    if (count < 1) throw py::value_error("count must be positive, got " + std::to_string(count));
    if (isomap_size < 16 || size < 16 || image_size < 64) throw py::value_error("isomap_size and size must be at least 16, image_size at least 64 pixels");
    if (!(fov >= 1 && fov <= 90)) throw py::value_error("fov must be in [1, 90] degrees");
    if (!(framing > 0)) throw py::value_error("framing must be positive");
    if (lighting != "unlit" && lighting != "sky") throw py::value_error("lighting must be 'unlit' or 'sky', got '" + lighting + "'");
    frontal::BenchmarkOptions options;
    options.count = count;
    options.seed = static_cast<std::uint64_t>(seed);
    options.isomap_size = isomap_size;
    options.size = size;
    options.view.size = image_size;
    options.view.fov_deg = fov;
    options.view.framing = framing;
    if (lighting == "sky") options.view.lighting = render::Lighting{};
    nlohmann::json j;
    {
        const py::gil_scoped_release released;
        j = frontal::to_json(frontal::run_benchmark(model.get(), options), options, model.get());
    }
    j["lighting"] = lighting;
    return dict_from_json(j);
}

// ---- detection and frontalisation ----

class Detector {
public:
    Detector(const std::string& regressor, const std::string& detector) : regressor_(train::open_regressor(regressor)) {
        const train::LandmarkRegressor* const regressors[] = {regressor_.get()};
        try {
            detector_ = std::make_unique<train::FaceDetector>(train::choose_detector(detector, regressors));
        } catch (const core::Error& e) {
            throw py::value_error(e.what());
        }
    }

    // Every face found, largest first: its box and 68 landmarks.
    py::list detect(const py::array& image) {
        const cv::Mat bgr = bgr_from(image, "image");
        std::vector<train::FaceBox> boxes;
        std::vector<Eigen::Matrix2Xd> faces;
        {
            const py::gil_scoped_release released;
            const std::lock_guard lock(mutex_);
            const cv::Mat gray = train::to_gray8(bgr);
            boxes = detector_->detect(gray);
            for (const auto& box : boxes) faces.push_back(regressor_->predict(gray, box));
        }
        py::list out;
        for (std::size_t f = 0; f < boxes.size(); ++f) {
            py::dict face;
            const auto& b = boxes[f];
            face["box"] = py::make_tuple(b.centre.x() - 0.5 * b.width, b.centre.y() - 0.5 * b.width, b.width, b.width);
            face["landmarks"] = points_array(faces[f]);
            face["view"] = std::string(train::view_name(b.view));
            out.append(face);
        }
        return out;
    }
    [[nodiscard]] const std::string& label() const { return regressor_->label(); }

private:
    std::unique_ptr<train::LandmarkRegressor> regressor_;
    std::unique_ptr<train::FaceDetector> detector_;
    std::mutex mutex_;  // the detector's cascades are used by one thread at a time
};

class Frontaliser {
public:
    Frontaliser(const Model& model, int size, bool mirror_fill) : model_(model.shared()), frontaliser_(*model_) {
        if (size < 16) throw py::value_error("size must be at least 16 pixels, got " + std::to_string(size));
        options_.frontal.size = size;
        options_.mirror_fill = mirror_fill;
    }

    py::dict frontalise(const py::array& image, const py::array& landmarks) {
        const cv::Mat bgr = bgr_from(image, "image");
        const Eigen::Matrix2Xd points = landmarks_from(landmarks, "landmarks");
        frontal::Frontalisation r;
        {
            const py::gil_scoped_release released;
            const std::lock_guard lock(mutex_);
            try {
                r = frontaliser_.frontalise(bgr, points, options_);
            } catch (const core::Error& e) {
                throw py::value_error(std::string("landmarks: ") + e.what());
            }
        }
        nlohmann::json record;
        fit::write_json(record, r.fit);
        py::dict out;
        out["frontal"] = array_from(r.frontal.image);
        out["mask"] = array_from(r.frontal.mask);
        out["isomap"] = array_from(r.isomap);
        out["fit"] = dict_from_json(record);
        return out;
    }

private:
    std::shared_ptr<const morph::MorphableModel> model_;  // outlives frontaliser_
    frontal::Frontaliser frontaliser_;
    frontal::FrontaliseOptions options_;
    std::mutex mutex_;  // one renderer
};


// ---- tracking ----

// `facesynth track`'s tracker fed one frame at a time (docs/track.md): each frame's faces as the
// records of faces.jsonl (frame_record), landmarks as arrays. The model (and its fitter) is kept
// alive by the binding (keep_alive) for as long as the tracker.
class Tracker {
public:
    Tracker(const Model& model, const std::string& regressor, const std::string& detector, const track::TrackerSettings& settings)
        : regressor_(train::open_regressor(regressor)), tracker_(*regressor_, detector_for(detector, *regressor_), model.fitter(), settings) {}

    // The faces followed in `image` at `time_s` seconds (later than the previous frame's).
    py::list process(const py::array& image, double time_s) {
        if (!std::isfinite(time_s) || (frames_ > 0 && time_s <= last_time_s_))
            throw py::value_error("time_s must be finite and later than the previous frame's (" + std::to_string(last_time_s_) + "), got " +
                                  std::to_string(time_s));
        const cv::Mat bgr = bgr_from(image, "image");
        std::string record;
        {
            const py::gil_scoped_release released;
            const std::lock_guard lock(mutex_);
            record = track::frame_record(frames_, time_s, tracker_.process(bgr, time_s), tracker_, true);
        }
        ++frames_;
        last_time_s_ = time_s;
        const py::dict frame = py::module_::import("json").attr("loads")(record);  // the record as Python values, parsed once
        py::list faces = frame["faces"];
        const py::object asarray = py::module_::import("numpy").attr("asarray");
        for (py::handle face : faces) {
            const py::dict f = py::reinterpret_borrow<py::dict>(face);
            f["box"] = py::tuple(f["box"]);
            f["landmarks"] = asarray(f["landmarks"], "float64");
        }
        return faces;
    }
    [[nodiscard]] py::dict counters() const {
        py::dict out;
        out["frames"] = frames_;
        out["detector_runs"] = tracker_.detector_runs();
        out["fallback_detector_runs"] = tracker_.fallback_runs();
        out["losses"] = tracker_.losses();
        out["reacquired"] = tracker_.reacquired();
        out["cuts"] = tracker_.cuts();
        out["reidentified"] = tracker_.reidentified();
        return out;
    }

private:
    static train::DetectorKind detector_for(const std::string& option, const train::LandmarkRegressor& regressor) {
        try {
            return track::tracking_detector(option, regressor);
        } catch (const core::Error& e) {
            throw py::value_error(e.what());
        }
    }

    std::unique_ptr<train::LandmarkRegressor> regressor_;  // outlives tracker_
    track::Tracker tracker_;
    std::int64_t frames_ = 0;
    double last_time_s_ = 0;
    std::mutex mutex_;  // one detector, one set of tracks
};

}  // namespace
}  // namespace facesynth::python

PYBIND11_MODULE(_facesynth, m) {
    using facesynth::python::Detector;
    using facesynth::python::Frontaliser;
    using facesynth::python::Generator;
    using facesynth::python::Model;
    using facesynth::python::Renderer;
    using facesynth::python::Tracker;
    using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
    m.doc() = "facesynth's compiled core; use the facesynth package (docs/python.md)";
    // Every other facesynth failure (a file, the renderer, a sample) keeps its message as RuntimeError.
    // pybind11's translator type takes the exception_ptr by value.
    py::register_exception_translator([](std::exception_ptr error) {  // NOLINT(performance-unnecessary-value-param)
        try {
            if (error) std::rethrow_exception(error);
        } catch (const facesynth::core::Error& e) {
            PyErr_SetString(PyExc_RuntimeError, e.what());
        }
    });
    py::class_<Generator>(m, "Generator")
        .def(py::init<const std::string&, const std::string&, const std::optional<std::string>&, const std::optional<std::int64_t>&,
                      const std::optional<std::pair<int, int>>&, int>(),
             py::arg("config_file"), py::arg("settings_json"), py::arg("model"), py::arg("seed"), py::arg("size"), py::arg("workers"),
             py::call_guard<py::gil_scoped_release>())
        .def("batch", &Generator::batch, py::arg("start"), py::arg("count"))
        .def_property_readonly("config_json", &Generator::config_json)
        .def_property_readonly("config_toml", &Generator::config_toml)
        .def_property_readonly("count", [](const Generator& g) { return g.stream().config().count; })
        .def_property_readonly("seed", [](const Generator& g) { return g.stream().config().seed; })
        .def_property_readonly("size", [](const Generator& g) { return std::make_pair(g.stream().config().camera.width, g.stream().config().camera.height); })
        .def_property_readonly("workers", [](const Generator& g) { return g.stream().workers(); })
        .def_property_readonly("model_name", [](const Generator& g) { return g.stream().model().name; })
        .def_property_readonly("renderer", [](const Generator& g) { return g.stream().renderer_description(); });
    py::class_<Model>(m, "Model")
        .def(py::init<const std::string&>(), py::arg("spec"))
        .def("vertices", &Model::vertices, py::arg("alpha") = std::nullopt, py::arg("expression") = std::nullopt)
        .def("landmarks", &Model::landmarks, py::arg("vertices"))
        .def(
            "sample",
            [](const Model& model, std::uint64_t seed, double truncation) {
                const facesynth::morph::FaceCoefficients face = facesynth::morph::sample_face(model.get(), seed, truncation);
                py::dict out;
                out["alpha"] = facesynth::python::array_from(face.alpha);
                out["colour"] = facesynth::python::array_from(face.beta);
                return out;
            },
            py::arg("seed"), py::arg("truncation") = 3.0)
        .def_property_readonly("triangles", &Model::triangles)
        .def_property_readonly("name", [](const Model& model) { return model.get().name; })
        .def_property_readonly("checksum", [](const Model& model) { return model.get().checksum(); })
        .def_property_readonly("num_vertices", [](const Model& model) { return model.get().num_vertices(); })
        .def_property_readonly("num_shape_components", [](const Model& model) { return model.get().num_shape_components(); })
        .def_property_readonly("num_expression_components", [](const Model& model) { return model.get().num_expression_components(); });
    m.def("fit", &facesynth::python::fit_landmarks, py::arg("landmarks"), py::arg("model"), py::arg("image_size"), py::arg("jaw"), py::arg("lambda_"),
          py::arg("refine"), py::arg("focal"), py::arg("sigma"), py::arg("fit_expression"));
    py::class_<Renderer>(m, "Renderer")
        .def(py::init<const Model&, const std::string&, int>(), py::arg("model"), py::arg("antialiasing"), py::arg("samples"))
        .def(
            "render",
            [](Renderer& r, const std::optional<FloatArray>& alpha, const std::optional<FloatArray>& expression, const std::optional<FloatArray>& colour,
               double yaw, double pitch, double roll, std::pair<int, int> size, double fov, double distance, bool orthographic) {
                return r.render(alpha, expression, colour, {yaw, pitch, roll, size.first, size.second, fov, distance, orthographic});
            },
            py::arg("alpha"), py::arg("expression"), py::arg("colour"), py::arg("yaw"), py::arg("pitch"), py::arg("roll"), py::arg("size"),
            py::arg("fov"), py::arg("distance"), py::arg("orthographic"));
    m.def("nme", &facesynth::python::landmark_nme, py::arg("predicted"), py::arg("truth"));
    m.def("nme_summary", &facesynth::python::nme_summary, py::arg("nmes"), py::arg("threshold") = 0.08);
    m.def("eval_fit", &facesynth::python::eval_fit, py::arg("model"), py::arg("data"), py::arg("mode"), py::arg("count"), py::arg("seed"),
          py::arg("noise"), py::arg("landmarks"), py::arg("refine"), py::arg("visible_only"), py::arg("lambda_"), py::arg("sigma"), py::arg("max_yaw"));
    m.def("eval_frontalise", &facesynth::python::eval_frontalise, py::arg("model"), py::arg("count"), py::arg("seed"), py::arg("isomap_size"),
          py::arg("size"), py::arg("image_size"), py::arg("fov"), py::arg("framing"), py::arg("lighting"));
    m.def("eval_realism", &facesynth::python::eval_realism, py::arg("data"), py::arg("photos"), py::arg("regressor"), py::arg("detector"),
          py::arg("max_yaw"), py::arg("match_face_size"));
    py::class_<Detector>(m, "Detector")
        .def(py::init<const std::string&, const std::string&>(), py::arg("regressor"), py::arg("detector"))
        .def("detect", &Detector::detect, py::arg("image"))
        .def_property_readonly("label", &Detector::label);
    py::class_<Frontaliser>(m, "Frontaliser")
        .def(py::init<const Model&, int, bool>(), py::arg("model"), py::arg("size"), py::arg("mirror_fill"))
        .def("frontalise", &Frontaliser::frontalise, py::arg("image"), py::arg("landmarks"));
    py::class_<Tracker>(m, "Tracker")
        .def(py::init([](const facesynth::python::Model& model, const std::string& regressor, const std::string& detector, int detect_every, int max_faces,
                         bool track, bool smooth, double max_fit_error, bool multiview_fallback, double cut_threshold, double max_reid_distance) {
                 if (detect_every < 1) throw py::value_error("detect_every must be at least 1, got " + std::to_string(detect_every));
                 if (max_faces < 1 || max_faces > 64) throw py::value_error("max_faces must be in [1, 64], got " + std::to_string(max_faces));
                 if (!(max_fit_error > 0 && max_fit_error <= 10)) throw py::value_error("max_fit_error must be in (0, 10], got " + std::to_string(max_fit_error));
                 if (!(cut_threshold >= 0 && cut_threshold <= 255)) throw py::value_error("cut_threshold must be in [0, 255], got " + std::to_string(cut_threshold));
                 if (!(max_reid_distance >= 0 && std::isfinite(max_reid_distance)))
                     throw py::value_error("max_reid_distance must be finite and >= 0, got " + std::to_string(max_reid_distance));
                 facesynth::track::TrackerSettings settings;
                 settings.detect_every = detect_every;
                 settings.max_faces = max_faces;
                 settings.track = track;
                 settings.smooth = smooth;
                 settings.max_fit_error = max_fit_error;
                 settings.multiview_fallback = multiview_fallback;
                 settings.cut_threshold = cut_threshold;
                 settings.max_reid_distance = max_reid_distance;
                 return std::make_unique<Tracker>(model, regressor, detector, settings);
             }),
             py::arg("model"), py::arg("regressor"), py::arg("detector"), py::arg("detect_every"), py::arg("max_faces"), py::arg("track"),
             py::arg("smooth"), py::arg("max_fit_error"), py::arg("multiview_fallback"), py::arg("cut_threshold"), py::arg("max_reid_distance"),
             py::keep_alive<1, 2>())
        .def("process", &Tracker::process, py::arg("image"), py::arg("time_s"))
        .def_property_readonly("counters", &Tracker::counters);
}
