#pragma once
// A model texture (albedo in uv space) taken from one photograph with 68 landmarks, for synth's texture
// bank (docs/textures.md): fit, isomap with visibility, removal of the photograph's low-frequency
// shading, mirror fill of the hidden side, then every remaining texel (holes, hidden scalp, borders)
// filled smoothly from its neighbours. Photographs that give no usable texture are rejected with a
// reason (pose, coverage, occlusion, fit).
#include "frontal/frontalise.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <string>

namespace facesynth::frontal {

struct PhotoTextureOptions {
    int size = 512;                    // texture side, texels
    bool remove_shading = true;        // divide by the photograph's fitted shading (off: colours as photographed)
    // The shading is never taken below this share of its mean over the skin: deep shadows and the
    // texels facing away from every light keep some of their own colour instead of blowing up.
    double min_shading = 0.35;
    double max_abs_yaw_deg = 50;       // steeper faces: rejected (too little of the face is seen)
    // Share of the face's texels (skin, brows, eyes, lips, nose) seen in the photograph directly or
    // through their mirror texel; below it the texture is rejected.
    double min_face_coverage = 0.6;
    // Share of seen skin texels whose colour lies far (kOutlierDeltaE in CIELAB) from the skin's median
    // colour after shading removal: hands, glasses, microphones, hair across the face. Above it: rejected.
    double max_skin_outliers = 0.2;
    // The fit's landmark RMS over the inter-ocular distance (iBUG 37-46); above it: rejected.
    double max_fit_error = 0.08;
    // Identity prior weight of the fit (fit::FitOptions::lambda): lower lets the fitted shape follow the
    // annotated points further from the model's mean (the shape synth renders with identity.source = texture).
    double fit_lambda = fit::FitOptions{}.lambda;
    // Warp the photograph before taking the texture so that its annotated points iBUG 18-68 land where
    // the fitted model projects them: the texture's brows, eyes, nose and mouth then lie at the model's
    // landmark vertices instead of off them by the fit's residual (docs/textures.md "Features aligned").
    // Off by default: it did not make a better training set (docs/history/results-runs.md, seventh run).
    bool align_features = false;
    // Alignment as align_features (which it implies) with the jaw outline too (iBUG 1-17 onto the fitted contour's projections): the
    // photograph's chin and jaw edge then lie on the model's silhouette instead of above or beside it
    // by the fit's residual (at the default prior the fitted chin is 0.026 inter-ocular distances below
    // the annotated one: docs/results.md "Landmark conventions").
    bool align_jaw = false;
    // Beyond the face the photograph shows hair, background or clothing, whatever the fit: the model's
    // ears and neck take the face's own median skin colour (after shading removal) instead, and unseen
    // skin fades to it over `skin_fade` of the texture side away from what was seen, instead of smearing
    // the colours at the face's border outward (docs/textures.md step 8). Off by default: it made a
    // worse training set (docs/results.md, "Sim-to-real").
    bool skin_beyond_face = false;
    double skin_fade = 0.05;
    // Seen plain skin above the nose's base whose colour lies kOutlierDeltaE or more from the skin's median
    // (a fringe or strands of hair across the forehead, a hand on the cheek, spectacle frames) counts as
    // unseen: its mirror texel or its neighbours fill it. Below the nose it is kept: beards and stubble
    // are the face's own (docs/textures.md "Occluders dropped").
    bool drop_occluders = false;
    // Face texels that project within this share of the inter-ocular distance inside the annotated jaw
    // line (iBUG 1-17) count as unseen and are filled from the skin further in: annotators put the jaw
    // points on the face's edge, so the photograph's texels there carry that edge and the shadow or
    // background beside it, which renders would otherwise show as a painted line inside the model's
    // own silhouette (docs/textures.md step 3). 0: trusted up to the line.
    double jaw_margin = 0;
};

// The photograph warped smoothly so that `annotated` points (iBUG 18-68 of 2 x 68, 0-based pixels; with
// `with_jaw` 1-68) move onto `projected` (the fitted model's projections of them): out(p) = image(p + d(p)), where d is the
// Gaussian radial-basis interpolant (width 0.25 of the outer-eye-corner distance) through the residuals
// annotated - projected, fading to no displacement away from the face's features. Non-finite points are
// left out; with none left the image is returned unchanged.
[[nodiscard]] cv::Mat align_photo_to_fit(const cv::Mat& image, const Eigen::Matrix2Xd& annotated, const Eigen::Matrix2Xd& projected,
                                         bool with_jaw = false);

// Skin texels farther than this from the skin's median colour (CIE76 ΔE) count as outliers.
inline constexpr double kOutlierDeltaE = 25.0;

struct PhotoTexture {
    cv::Mat texture;        // CV_8UC3, R G B: the renderer's albedo texture (sRGB-encoded linear albedo), every texel filled
    std::string rejection;  // empty when usable; otherwise why not ("pose: ...", "coverage: ...", ...)
    double yaw_deg = 0, pitch_deg = 0, roll_deg = 0;
    double face_coverage = 0;      // see PhotoTextureOptions::min_face_coverage
    double seen_share = 0;         // share of the face's texels seen directly (before the mirror fill)
    double skin_outliers = 0;      // see PhotoTextureOptions::max_skin_outliers
    double dropped_share = 0;      // share of the face's texels dropped as occluders (PhotoTextureOptions::drop_occluders)
    double fit_error = 0;          // see PhotoTextureOptions::max_fit_error
    double shading_range = 0;      // fitted shading over the seen skin: 90th / 10th percentile (1 = flat light)
    std::array<double, 3> skin_srgb{};  // median skin colour of the texture (sRGB, 0-255, R G B)
    std::vector<float> shape;           // the fitted identity coefficients (σ units) the texture was taken with
    std::vector<float> expression;      // and the fitted expression (the texture's lips and teeth sit where it puts them)
};

// Builds the texture of the face with `landmarks` (68 iBUG points, 0-based pixels) in `image` (8-bit BGR
// or grey). Throws core::Error when the model has no uv or no symmetry map; a fit that fails
// (degenerate landmarks) gives a rejection, not an exception.
[[nodiscard]] PhotoTexture extract_photo_texture(Frontaliser& frontaliser, const cv::Mat& image, const Eigen::Matrix2Xd& landmarks,
                                                 const PhotoTextureOptions& options = {});

// Fills every texel of `colour` (CV_32FC3) whose `weight` (CV_32FC1, in [0, 1]) is below 1 from the
// weighted colours around it (push-pull over an image pyramid): weight 0 texels take the pyramid's
// colour, partial weights blend with it, weight 1 texels stay. Throws core::Error when no texel
// has weight.
void push_pull_fill(cv::Mat& colour, const cv::Mat& weight);

}  // namespace facesynth::frontal
