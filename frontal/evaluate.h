#pragma once
// The ground-truth frontalisation benchmark (docs/frontalise.md): a face with a known texture is
// rendered at yaw 0 and at other yaws under the same lighting, the posed renders are frontalised from
// their landmarks, and the output is compared with the true frontal render inside the face mask; the
// isomap is compared with the true texture in uv space. `facesynth eval frontalise` loops over this.
#include "frontal/frontalise.h"
#include "frontal/image_metrics.h"
#include "morph/jaw_contour.h"
#include "render/lighting.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <optional>

namespace facesynth::frontal {

// A face with a known appearance: shape and either per-vertex colours (mesh.colours) or a uv texture.
struct TexturedFace {
    morph::Mesh mesh;                 // model instance; colours used when texture is empty
    cv::Mat texture;           // optional 8-bit BGR uv texture (display values), size = the isomap size
    cv::Mat true_isomap;       // 8-bit BGR: the appearance in uv space as the renderer shows it unlit
};

// Identity `index` of the set `seed`: random identity (σ-unit normal), neutral expression, and the
// model's random albedo; a model without an albedo model gets a procedural texture instead (smooth
// colour noise plus a fine grid of dots, mirror-symmetric in u), drawn per identity.
[[nodiscard]] TexturedFace make_textured_face(const morph::MorphableModel& model, Frontaliser& frontaliser, std::uint64_t seed,
                                              std::uint64_t index, int isomap_size);

struct SyntheticView {
    cv::Mat image;                 // 8-bit BGR, face over `background`
    cv::Mat mask;                  // 8-bit, 255 on the face
    Eigen::Matrix2Xd landmarks;    // 68, contour jaw mode (as 300-W annotators mark them)
    Eigen::Matrix2Xd fixed_landmarks;
    double yaw_deg = 0;
};

struct ViewOptions {
    int size = 384;
    double fov_deg = 8;  // a long lens (about 1.4 m away): the affine fit has little perspective to absorb
    // The image side over the mean face's landmark box side: 1.5 fills the image with the face (the
    // benchmark's framing); larger values show the whole head, as face detectors expect.
    double framing = 1.5;
    render::Lighting lighting;        // the same for every yaw; default unlit()
    cv::Vec3b background{70, 70, 70};
    ViewOptions();
};

// The same camera (position, and focal length in pixels) with a larger image that shows more around
// the face: the mean landmark box spans about 1 / `framing` of it instead of 1 / options.framing, and
// the view at `options` is this one's centre crop. The face keeps its pixels; face detectors get the
// context they need (the profile cascade looks for the back of the head). The size grows by an even
// number of pixels, so the principal point stays on the same pixel grid; framing and fov are set
// from it so that the camera is unchanged.
[[nodiscard]] ViewOptions with_context(const ViewOptions& options, double framing);

// `face` rendered with a perspective camera at yaw `yaw_deg` (pitch = roll = 0), the mean face's
// landmark box filling 1 / options.framing of the image.
[[nodiscard]] SyntheticView render_view(render::Renderer& renderer, const morph::MorphableModel& model, const TexturedFace& face,
                                        double yaw_deg, const ViewOptions& options = {},
                                        const morph::JawContourRegion* contour_region = nullptr);

// The true frontal render: `face` with the frontaliser's frontal camera under `lighting`, and the face
// mask (render coverage inside the convex hull of the projected 68 landmarks).
struct TrueFrontal {
    FrontalImage render;
    cv::Mat face_mask;
};
[[nodiscard]] TrueFrontal render_true_frontal(Frontaliser& frontaliser, const TexturedFace& face, int size,
                                              const render::Lighting& lighting);

// The isomap's error against the truth over its texels with alpha >= min_alpha (default: seen within
// 60° of the surface normal, where the colour does not hinge on the fitted silhouette): mean absolute
// difference in 8-bit levels and PSNR; and the fraction of the layout's texels with alpha > 0.
struct IsomapComparison {
    double l1 = 0, psnr_db = 0, coverage = 0;
    int compared = 0;
};
[[nodiscard]] IsomapComparison compare_isomap(const cv::Mat& isomap, const cv::Mat& true_isomap, const cv::Mat& layout,
                                              int min_alpha = 128);

}  // namespace facesynth::frontal
