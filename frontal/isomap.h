#pragma once
// Texture extraction into the model's uv space (the "isomap" of Huber et al., 2016) with per-texel
// visibility from a z-buffer pass (rasterised on the CPU; the renderer's depth-only pass is its test
// reference), and filling of occluded texels from the mirror side through the model's symmetry map
// (docs/frontalise.md).
//
// Layout: texel (row r, column c) of an S x S isomap shows the surface point with uv
// ((c + 0.5) / S, (r + 0.5) / S), the model's uv with v = 0 on the top row. Images are OpenCV's:
// the isomap is CV_8UC4 in B G R A order; colours are the photograph's own (display-encoded) values.
// Alpha = round(255 · cos θ) on visible texels, θ the angle between the surface normal and the
// direction to the camera (0 at grazing view); 0 on texels that are occluded, turned away or seen at
// grazing angles (IsomapOptions), next to the fitted outline, outside the photograph, or outside every
// uv triangle (their colour is black).
#include "fit/affine_camera.h"
#include "morph/model.h"
#include "render/renderer.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <span>
#include <vector>

namespace facesynth::frontal {

// Which surface point each isomap texel shows: one rasterisation of the model's uv layout per size
// (it depends on the topology and uv only, never on the fitted shape).
struct UvRaster {
    struct Texel {
        int index = 0;                         // r · size + c
        std::array<float, 3> weights{};        // barycentric weights of its triangle's corners at the texel centre
    };
    // A texel just outside the layout and its covered 8-neighbours, for padding textures.
    struct Padding {
        int index = 0;
        std::array<int, 8> neighbours{};
        int count = 0;
    };
    // The texels of one uv triangle: texels[first, first + count).
    struct TriangleTexels {
        std::array<int, 3> vertices{};       // the triangle's corners
        int first = 0, count = 0;
    };
    int size = 0;
    // Covered texels, grouped by triangle (row-major within one), 16 bytes each: the texel loops stream
    // them once per face, so they carry no corners (those are in `triangles`).
    std::vector<Texel> texels;
    std::vector<TriangleTexels> triangles;   // the groups, in the model's triangle order
    std::vector<Padding> padding;            // uncovered texels next to covered ones
};

// Rasterises `model`'s uv triangles at size x size texels with `renderer` (triangle ids and
// barycentrics at texel centres). Triangles spanning more than half the map (seams that wrap round)
// are left out. Throws core::Error when the model has no uv or the size is out of range.
[[nodiscard]] UvRaster rasterise_uv(const morph::MorphableModel& model, int size, render::Renderer& renderer);

// Where the fitted mesh lies in the photograph: the fit's affine camera (which places the colour
// samples, exactly as it projects the landmarks) and its nearest scaled orthographic camera (which
// gives the rotation for depth and normals).
struct ImageCamera {
    fit::AffineCamera affine;
    fit::ScaledOrthographic pose;
};

struct IsomapOptions {
    int size = 512;
    // A texel is visible when its depth lies within this of the z-buffer's, plus one depth pixel's
    // worth of the surface's slope (tan θ, capped at 10) so that steep cheeks are not lost to aliasing.
    double depth_tolerance_mm = 2.0;
    // The z-buffer pass renders the face's bounding box, scaled down to at most this many pixels on its
    // longer side (full resolution below); the tolerance above grows with its pixel size.
    int max_depth_side = 256;
    // Texels seen more obliquely than this (cos θ below it) are left out: at grazing view a texel's
    // colour comes from a sliver of pixels that the fitted outline rarely matches.
    double min_cosine = 0.1;
    // Texels within this many z-buffer pixels of the fitted outline (background in the window) are left
    // out, so that a slightly wide fit does not paint the photograph's background onto the face.
    int outline_margin_px = 1;
};

struct IsomapStats {
    int covered_texels = 0;   // texels inside a uv triangle
    int visible_texels = 0;   // with alpha > 0
    int depth_width = 0, depth_height = 0;  // size of the z-buffer pass
};

// Extracts the isomap of a photograph (8-bit BGR or grey) given the fitted mesh `vertices` (3 x V, model
// space) and where it lies in the image. `raster` must come from the same model at options.size.
[[nodiscard]] cv::Mat extract_isomap(const cv::Mat& image, const Eigen::Matrix3Xf& vertices,
                                     const std::vector<morph::Triangle>& triangles, const ImageCamera& camera,
                                     const UvRaster& raster, const IsomapOptions& options = {}, IsomapStats* stats = nullptr);

// The model's symmetry map completed: made an involution (a pair listed one way holds the other way),
// and vertices still without a mirror get the mean-shape vertex nearest to their reflection in the
// plane of the known pairs (when vertices without a mirror x all vertices <= 1e8). Throws
// core::Error when the model has no symmetry map at all.
[[nodiscard]] std::vector<int> completed_symmetry(const morph::MorphableModel& model);

// For each covered texel, the isomap position (in texels, continuous) of its mirror surface point:
// the same barycentric weights on the mirror vertices of its triangle's corners (completed_symmetry),
// so it works for any model with a symmetry map, whatever its uv layout. NaN where a corner has none.
[[nodiscard]] Eigen::Matrix2Xf mirror_positions(const morph::MorphableModel& model, const UvRaster& raster);

// Fills texels with alpha 0 inside the uv layout from their mirror position when that is visible
// (bilinear over the visible neighbours); a filled texel takes the mirror side's colour and alpha.
// Texels seen at grazing angles (alpha < 64, cos θ < 0.25) are replaced too when the mirror point's
// alpha is at least twice theirs.
// Then closes seams along the midline (whose texels are their own mirror): two passes in which a hole
// texel with at least 3 textured 8-neighbours takes their mean. Returns the number of texels filled. `mirror` comes from mirror_positions for the same raster.
int mirror_fill(cv::Mat& isomap, const UvRaster& raster, const Eigen::Matrix2Xf& mirror);

// Per-vertex linear colours (3 x V, [0, 1]) rasterised into uv space and display-encoded with `gamma`
// exactly as the renderer shows them under unit ambient light (CV_8UC3, B G R): the true isomap of a
// face rendered with vertex colours. Texels outside the layout are black.
[[nodiscard]] cv::Mat vertex_colour_isomap(const Eigen::Matrix3Xf& colours, const UvRaster& raster, float gamma = 2.2f);

// The texels of `raster` as an 8-bit mask (255 inside the layout).
[[nodiscard]] cv::Mat layout_mask(const UvRaster& raster);

}  // namespace facesynth::frontal
