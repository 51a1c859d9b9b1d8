#pragma once
// Offscreen OpenGL renderer (Mesa EGL surfaceless / EGL device / OSMesa; no display, no GPU needed).
//
// One Renderer owns one OpenGL 3.3 core context, created once and reused for every image; use it
// from one thread at a time (one Renderer per worker thread; detach() before handing it over). Geometry follows docs/conventions.md exactly:
// x_cam = flip · R · X + t, OpenCV pixels, the centre of the top-left pixel is (0, 0), so
// project_points(camera, X) lands on the rendered surface point X to a small fraction of a pixel.
#include "morph/camera.h"
#include "morph/mesh.h"
#include "morph/regions.h"
#include "render/lighting.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace facesynth::render {

enum class Backend { kAuto, kEgl, kOsmesa };
// "auto", "egl" or "osmesa"; throws core::Error otherwise.
[[nodiscard]] Backend parse_backend(std::string_view name);
[[nodiscard]] std::string to_string(Backend backend);

enum class Projection { kPerspective, kOrthographic };

// Perspective: pixel = K · x_cam / z. Orthographic (scaled orthographic / affine fits, frontal
// views): pixel = (fx · x_cam.x + cx, fy · x_cam.y + cy), fx and fy in pixels per millimetre.
struct Camera {
    morph::Intrinsics intrinsics;  // image size comes from here
    morph::CameraPose pose;
    Projection projection = Projection::kPerspective;
};

// Pixel coordinates of model points with exactly the renderer's camera (2 x N).
[[nodiscard]] Eigen::Matrix2Xd project_points(const Camera& camera, const Eigen::Matrix3Xf& model_points);
[[nodiscard]] Eigen::Vector2d project_point(const Camera& camera, const Eigen::Vector3d& model_point);

// Semantic region ids for the per-vertex label input and the label image (morph/regions.h).
using facesynth::morph::Region;

// What the mesh carries beyond morph::Mesh. Spans must outlive the render call.
struct MeshExtras {
    std::span<const std::uint8_t> vertex_labels;  // Region per vertex; empty: every vertex is skin
    const cv::Mat* texture = nullptr;              // 8-bit RGB (sRGB) albedo sampled with mesh.uv
};

// How the colour image and the mask are anti-aliased; geometry maps stay single-sampled
// (docs/render.md "Anti-aliasing").
struct Antialiasing {
    enum class Method {
        kNone,
        kMsaa,           // multisampling, `samples` per pixel (2..16)
        // The colour pass drawn `samples` times larger per side (2..4) and box-filtered: samples² per
        // pixel on an ordered grid, shading included. On llvmpipe 2 costs about 60 % of MSAA 4's colour pass.
        kSupersampling,
        // Analytic coverage of silhouette edges on the CPU after a single-sample render: outline pixels
        // get fractional coverage, pixels where the face lies over itself a blend of both surfaces
        // (render/edge_antialiasing.h).
        kEdges,
    };
    Method method = Method::kMsaa;
    int samples = 4;  // kMsaa: samples per pixel; kSupersampling: factor per side; otherwise 1

    [[nodiscard]] static Antialiasing none() { return {Method::kNone, 1}; }
    [[nodiscard]] static Antialiasing msaa(int samples_per_pixel) { return {Method::kMsaa, samples_per_pixel}; }
    [[nodiscard]] static Antialiasing supersampling(int factor) { return {Method::kSupersampling, factor}; }
    [[nodiscard]] static Antialiasing edges() { return {Method::kEdges, 1}; }
    [[nodiscard]] int msaa_samples() const { return method == Method::kMsaa ? samples : 0; }
    [[nodiscard]] int supersampling_factor() const { return method == Method::kSupersampling ? samples : 1; }
    bool operator==(const Antialiasing&) const = default;
};

// "none", "msaa", "supersampling", "edges": the names synth's config and the CLI use.
[[nodiscard]] std::string_view antialiasing_name(Antialiasing::Method method);
// The method's sample range (kMsaa 2..16, kSupersampling 2..4, otherwise 1..1); out of range is an error.
[[nodiscard]] std::pair<int, int> antialiasing_sample_range(Antialiasing::Method method);
// The method named as above with `samples` (0: the method's default, 4 for MSAA and 2 for
// supersampling); throws core::Error for an unknown name or a count out of the method's range.
[[nodiscard]] Antialiasing antialiasing_from(std::string_view name, int samples);

struct RenderSettings {
    Antialiasing antialiasing = Antialiasing::msaa(4);
    bool geometry = true;          // depth, triangle ids and labels (and normals when `normals`)
    bool normals = true;           // with geometry: camera-space normals (an extra float target)
    bool barycentrics = false;     // per-pixel barycentrics and triangle ids (a slower geometry-shader pass)
    bool cull_back_faces = true;
    // With a uniform albedo (no mesh colours, or one colour at every vertex) and no texture,
    // directional lights or two-sided drawing, the gamma-encoded colour is computed per vertex and
    // interpolated (a sqrt per pixel instead of a pow): within a few levels of encoding per pixel
    // (docs/render.md "Shading"). true: always encode per pixel, as for varying albedo.
    bool per_pixel_colour = false;
    // Directional lights (diffuse and specular) evaluated per vertex and interpolated (Gouraud)
    // instead of per pixel: about half a lit 256² render's CPU, with narrow highlights on ridges and
    // creases softened (docs/render.md "Shading": error and cost). Ignored with shadows or when back
    // faces are drawn (cull_back_faces false): those keep the per-pixel lights.
    bool lights_per_vertex = false;
    // Only the z-buffer (frame.depth; every other map is left empty): no shading, no colour, id or
    // normal targets, no MSAA. For visibility passes, which need the nearest surface and nothing else.
    bool depth_only = false;
    // Texels per side of each directional light's shadow map (with lighting.shadows), fitted to the
    // mesh as the light sees it. 512: a texel is ~0.5 mm on a whole head, about half a pixel of a
    // 256² render, so the 4x4-texel filter softens shadow edges over ~2 pixels; the depth pass costs
    // in proportion to the map's area (docs/render.md "Shadows"). About 2x the image side is the rule.
    int shadow_map_size = 512;
    Lighting lighting;
};

// One render's outputs. Buffers are reused between renders of the same size (no reallocation).
struct Frame {
    cv::Mat rgb;           // CV_8UC3, R G B order, sRGB-encoded, face over black (premultiplied by mask)
    cv::Mat mask;          // CV_8UC1, face coverage 0..255 (anti-aliased with MSAA, supersampling or edge AA)
    cv::Mat depth;         // CV_32FC1, camera-space z in mm at the pixel centre; 0 = background
    cv::Mat normals;       // CV_32FC3, unit normals in OpenCV camera axes (x right, y down, z forward)
    cv::Mat triangle_ids;  // CV_32SC1, triangle index covering the pixel centre; -1 = background
    cv::Mat labels;        // CV_8UC1, Region of the surface at the pixel centre
    cv::Mat barycentrics;  // CV_32FC3, weights of the triangle's corners (with settings.barycentrics)
};

struct RendererOptions {
    Backend backend = Backend::kAuto;  // auto: EGL, then OSMesa
    bool allow_gpu_device = true;      // EGL device platform first when a GPU driver offers one
    // Which of Mesa's two software EGL displays renders when no GPU device is used: even numbers
    // the surfaceless platform, odd ones the software device (EGL_MESA_device_software), or
    // surfaceless where Mesa offers no such device. llvmpipe rasterises one scene at a time per
    // display, so renderers working in parallel on threads render faster on different displays
    // (docs/render.md). The images are the same on either.
    int software_display = 0;
};

class Renderer {
public:
    explicit Renderer(const RendererOptions& options = {});
    ~Renderer();
    Renderer(Renderer&&) noexcept;
    Renderer& operator=(Renderer&&) noexcept;
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Renders into `frame`; throws core::Error on invalid input or GL failure.
    void render(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, Frame& frame,
                const MeshExtras& extras = {});
    [[nodiscard]] Frame render(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings = {},
                               const MeshExtras& extras = {});

    // Unbinds the context from the calling thread, so that another thread can render with this
    // renderer next (an OpenGL context is bound to one thread at a time). Construction leaves it
    // unbound; render() binds it to the calling thread.
    void detach();

    // "egl-device", "egl-surfaceless" or "osmesa".
    [[nodiscard]] std::string backend() const;
    // GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6".
    [[nodiscard]] std::string renderer_string() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace facesynth::render
