#pragma once
// Frontalisation of a face photographed at any pose (docs/frontalise.md): fit the model to 68 landmarks
// (fit/fit.h, contour-aware), extract the texture into uv space (isomap, frontal/isomap.h), optionally
// fill occluded texels from the mirror side, and render the fitted face frontally with that texture.
//
// Face detection and landmarking stay with the caller (the CLI): this library takes an image and its
// 68 iBUG landmarks (0-based pixels). Images are OpenCV's 8-bit BGR (grey and BGRA are accepted).
#include "fit/fit.h"
#include "frontal/isomap.h"
#include "morph/model.h"
#include "core/srgb.h"  // srgb_encode: how the renderer's textures store albedo
#include "render/renderer.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <map>
#include <optional>

namespace facesynth::frontal {

struct FrontalRenderOptions {
    int size = 256;                         // output is size x size
    std::optional<cv::Vec3b> background;    // B G R composited behind the face; none: black
    render::Antialiasing antialiasing = render::Antialiasing::none();  // of the face outline
};

struct FrontaliseOptions {
    fit::FitOptions fit;                    // jaw follows the silhouette by default (photographs)
    IsomapOptions isomap;
    bool mirror_fill = false;               // needs the model's symmetry map
    FrontalRenderOptions frontal;
    FrontaliseOptions() { fit.jaw = fit::JawMode::kContour; }
};

// CPU time (process: includes the renderer's worker threads) and wall time of each stage, ms.
struct StageTimes {
    double fit_cpu_ms = 0, isomap_cpu_ms = 0, mirror_cpu_ms = 0, frontal_cpu_ms = 0;
    double fit_ms = 0, isomap_ms = 0, mirror_ms = 0, frontal_ms = 0;
    [[nodiscard]] double total_cpu_ms() const { return fit_cpu_ms + isomap_cpu_ms + mirror_cpu_ms + frontal_cpu_ms; }
    StageTimes& operator+=(const StageTimes& t);
    [[nodiscard]] double total_ms() const { return fit_ms + isomap_ms + mirror_ms + frontal_ms; }
    [[nodiscard]] StageTimes per(double count) const;  // every time divided by count
};
// The flat keys fit_ms, isomap_ms, mirror_ms, frontal_ms and the same with _cpu_ms.
void to_json(nlohmann::json& j, const StageTimes& t);

struct FrontalImage {
    cv::Mat image;  // CV_8UC3 B G R
    cv::Mat mask;   // CV_8UC1, 255 on the face
};

struct Frontalisation {
    fit::FitResult fit;
    Eigen::Matrix3Xf vertices;   // fitted shape (identity and expression), model space
    cv::Mat isomap;              // CV_8UC4 B G R A (isomap.h); mirror-filled when asked
    IsomapStats isomap_stats;
    int mirror_filled_texels = 0;
    FrontalImage frontal;
    StageTimes times;
};

// Holds what depends on the model only (fitter, uv rasterisations, mirror maps, frontal framing) and one
// renderer, so that frontalising many images with one model is cheap. Use from one thread at a time;
// the model must outlive it.
class Frontaliser {
public:
    explicit Frontaliser(const morph::MorphableModel& model, const render::RendererOptions& renderer_options = {});

    // The whole pipeline for one face; throws core::Error when the fit fails (bad landmarks).
    [[nodiscard]] Frontalisation frontalise(const cv::Mat& image, const Eigen::Matrix2Xd& landmarks,
                                            const FrontaliseOptions& options = {});

    // The stages, for callers that have their own fit or texture.
    [[nodiscard]] cv::Mat extract_isomap(const cv::Mat& image, const Eigen::Matrix3Xf& vertices, const ImageCamera& camera,
                                         const IsomapOptions& options = {}, IsomapStats* stats = nullptr);
    // Throws core::Error when the model has no symmetry map.
    int mirror_fill(cv::Mat& isomap);
    // `vertices` with the isomap as texture, yaw = pitch = roll = 0, framed by frontal_camera.
    [[nodiscard]] FrontalImage render_frontal(const Eigen::Matrix3Xf& vertices, const cv::Mat& isomap,
                                              const FrontalRenderOptions& options = {});

    // The fixed frontal framing: orthographic, the mean shape's 68-landmark bounding box centred and
    // spanning 1/kFrontalMargin of the image on its longer side, whatever face is rendered.
    static constexpr double kFrontalMargin = 1.5;
    [[nodiscard]] render::Camera frontal_camera(int size) const;

    [[nodiscard]] const UvRaster& uv_raster(int size);
    [[nodiscard]] const fit::Fitter& fitter() const { return fitter_; }
    [[nodiscard]] const morph::MorphableModel& model() const { return model_; }
    [[nodiscard]] render::Renderer& renderer() { return renderer_; }

private:
    const morph::MorphableModel& model_;
    fit::Fitter fitter_;
    render::Renderer renderer_;
    std::map<int, UvRaster> rasters_;
    std::map<int, Eigen::Matrix2Xf> mirrors_;
    Eigen::Vector3d frame_centre_mm_;
    double frame_side_mm_ = 0;
};

// The isomap's colours prepared as the renderer's texture so that, under unlit() lighting, the render
// shows each texel's value unchanged (the renderer decodes textures as sRGB and encodes with gamma
// 2.2): 8-bit R G B. Texels just outside the layout (raster.padding) take the mean of their visible
// neighbours, so that bilinear lookups at the layout's edges do not pull in black.
[[nodiscard]] cv::Mat texture_for_unlit_render(const cv::Mat& isomap, const UvRaster& raster);
// The same mapping for a BGR image of display values (no filling): the renderer's texture that shows
// them unchanged under unlit() (and as albedo under any other lighting).
[[nodiscard]] cv::Mat render_texture_from_display(const cv::Mat& bgr);

// Lighting that shows albedo (or a texture) unchanged: no environment, unit ambient, gamma 2.2.
[[nodiscard]] render::Lighting unlit();

}  // namespace facesynth::frontal
