#pragma once
// Internal to the Renderer: shadow maps of its directional lights. One depth layer per light, drawn
// along the light with an orthographic box fitted to the mesh, and the matrices with which the shading
// pass looks them up (docs/render.md "Shadows").
#include "render/gl_functions.h"

#include <Eigen/Core>

#include <array>
#include <span>

namespace facesynth::render::detail {

// Texture unit of the shadow maps (unit 0 holds the albedo texture).
inline constexpr GLint kShadowTextureUnit = 1;

// One light's orthographic shadow projection, fitted to the mesh as the light sees it.
struct ShadowProjection {
    Eigen::Matrix4d clip_from_camera;  // camera space to the light's clip space
    double texel_mm = 0;               // the larger side of one texel
    double depth_range_mm = 0;         // far - near
};

// Light space: x, y across the beam, z along it (away from the light); the orthographic box is the
// mesh's bounding box in those axes (a tight fit, recomputed per render), padded by a few texels.
[[nodiscard]] ShadowProjection fit_shadow_projection(const Eigen::Vector3d& toward_light, const Eigen::Matrix3Xd& camera_points,
                                                     int map_size);

// Created on the first render with shadows and kept for later ones; the texture's storage is replaced
// only when the map size changes or more lights than ever before need a layer. Every call needs the
// renderer's context current.
class ShadowMaps {
public:
    explicit ShadowMaps(const GlFunctions& gl) : gl_(gl) {}
    ShadowMaps(const ShadowMaps&) = delete;
    ShadowMaps& operator=(const ShadowMaps&) = delete;

    void release();

    // One depth-only pass per light (`toward_lights`, camera space, at most 4) over the bound vertex
    // array's `index_count` indices with `depth_only`, whose model-to-clip uniform is at
    // `model_to_clip`. Leaves the maps bound to kShadowTextureUnit, back faces drawn, and viewport and
    // scissor on the map: the caller sets them for its image again.
    void render(const Eigen::Matrix3Xf& model_points, const Eigen::Matrix4d& model_to_camera,
                std::span<const Eigen::Vector3d> toward_lights, int size, int max_texture_size, GLuint depth_only,
                GLint model_to_clip, GLsizei index_count);

    // For the shading pass: per light a column-major 4x4 matrix from camera space to map texture
    // coordinates and depth, one texel's depth extent, and the map side.
    [[nodiscard]] const std::array<float, 64>& lookup_from_camera() const { return lookup_from_camera_; }
    [[nodiscard]] const std::array<float, 4>& texel_depth() const { return texel_depth_; }
    [[nodiscard]] int size() const { return size_; }

private:
    void ensure(int size, int layers);

    const GlFunctions& gl_;
    GLuint fbo_ = 0;
    GLuint texture_ = 0;
    int size_ = 0, layers_ = 0;
    Eigen::Matrix3Xd camera_points_;  // mesh vertices in camera space, for fitting the light boxes
    std::array<float, 64> lookup_from_camera_{};
    std::array<float, 4> texel_depth_{};
};

}  // namespace facesynth::render::detail
