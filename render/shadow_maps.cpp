#include "render/shadow_maps.h"

#include "core/error.h"
#include "render/gl_program.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace facesynth::render::detail {

namespace {

// Shadow-map padding in texels on each side of the mesh's footprint, so that every PCF tap of a
// mesh point (up to 2 texels away) reads inside the map.
constexpr int kShadowPadTexels = 3;
// Depth margin (mm) in front of and behind the mesh in light space.
constexpr double kShadowDepthMarginMm = 1.0;

constexpr int kMinShadowMapSize = 16;

}  // namespace

ShadowProjection fit_shadow_projection(const Eigen::Vector3d& toward_light, const Eigen::Matrix3Xd& camera_points,
                                       int map_size) {
    const Eigen::Vector3d along = -toward_light;
    const Eigen::Vector3d helper = std::abs(along.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d across_x = helper.cross(along).normalized();
    const Eigen::Vector3d across_y = along.cross(across_x);
    Eigen::Matrix3d light_from_camera;
    light_from_camera << across_x.transpose(), across_y.transpose(), along.transpose();
    Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), high = -low;
    for (Eigen::Index i = 0; i < camera_points.cols(); ++i) {
        const Eigen::Vector3d p = light_from_camera * camera_points.col(i);
        low = low.cwiseMin(p);
        high = high.cwiseMax(p);
    }
    const double usable = static_cast<double>(map_size - 2 * kShadowPadTexels) / map_size;
    Eigen::Matrix4d ortho = Eigen::Matrix4d::Identity();
    double texel_mm = 0;
    for (int axis = 0; axis < 2; ++axis) {
        const double half = std::max(0.5 * (high[axis] - low[axis]), 1e-3) / usable;
        ortho(axis, axis) = 1.0 / half;
        ortho(axis, 3) = -0.5 * (high[axis] + low[axis]) / half;
        texel_mm = std::max(texel_mm, 2.0 * half / map_size);
    }
    const double near = low.z() - kShadowDepthMarginMm, far = high.z() + kShadowDepthMarginMm;
    ortho(2, 2) = 2.0 / (far - near);
    ortho(2, 3) = -(far + near) / (far - near);
    Eigen::Matrix4d light = Eigen::Matrix4d::Identity();
    light.topLeftCorner<3, 3>() = light_from_camera;
    return {ortho * light, texel_mm, far - near};
}


void ShadowMaps::release() {
    if (fbo_) gl_.DeleteFramebuffers(1, &fbo_), fbo_ = 0;
    if (texture_) gl_.DeleteTextures(1, &texture_), texture_ = 0;
    size_ = layers_ = 0;
}

void ShadowMaps::ensure(int size, int layers) {
    if (texture_ && size == size_ && layers <= layers_) return;
    if (size == size_) layers = std::max(layers, layers_);
    if (!fbo_) gl_.GenFramebuffers(1, &fbo_);
    if (!texture_) gl_.GenTextures(1, &texture_);
    gl_.ActiveTexture(GL_TEXTURE0 + kShadowTextureUnit);
    gl_.BindTexture(GL_TEXTURE_2D_ARRAY, texture_);
    gl_.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT32F, size, size, layers, 0, GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
    // Bilinear comparisons: each tap is a 2x2 percentage-closer filter in itself.
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    gl_.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    gl_.ActiveTexture(GL_TEXTURE0);
    gl_.BindFramebuffer(GL_FRAMEBUFFER, fbo_);
    gl_.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, texture_, 0, 0);
    const GLenum none = GL_NONE;
    gl_.DrawBuffers(1, &none);
    gl_.ReadBuffer(GL_NONE);
    if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw core::Error("render: shadow-map framebuffer incomplete at " + std::to_string(size) + "x" + std::to_string(size));
    size_ = size;
    layers_ = layers;
    check_gl(gl_, "creating shadow maps");
}

void ShadowMaps::render(const Eigen::Matrix3Xf& model_points, const Eigen::Matrix4d& model_to_camera,
                        std::span<const Eigen::Vector3d> toward_lights, int size, int max_texture_size, GLuint depth_only,
                        GLint model_to_clip, GLsizei index_count) {
    if (size < kMinShadowMapSize || size > max_texture_size)
        throw core::Error("render: shadow_map_size " + std::to_string(size) + " is out of range [" + std::to_string(kMinShadowMapSize) +
                          ", " + std::to_string(max_texture_size) + "]");
    ensure(size, static_cast<int>(toward_lights.size()));
    camera_points_.resize(3, model_points.cols());
    camera_points_.noalias() = model_to_camera.topLeftCorner<3, 3>() * model_points.cast<double>();
    camera_points_.colwise() += model_to_camera.topRightCorner<3, 1>();
    gl_.UseProgram(depth_only);
    gl_.BindFramebuffer(GL_FRAMEBUFFER, fbo_);
    gl_.Viewport(0, 0, size, size);
    gl_.Scissor(0, 0, size, size);  // the image's scissor would clip the map
    gl_.Disable(GL_CULL_FACE);       // open meshes cast shadows with either side
    Eigen::Matrix4d texture_from_clip = 0.5 * Eigen::Matrix4d::Identity();
    texture_from_clip(3, 3) = 1.0;
    texture_from_clip.topRightCorner<3, 1>().setConstant(0.5);
    const float far_depth = 1.0f;
    for (std::size_t i = 0; i < toward_lights.size(); ++i) {
        const ShadowProjection projection = fit_shadow_projection(toward_lights[i], camera_points_, size);
        const Eigen::Matrix4f clip = (projection.clip_from_camera * model_to_camera).cast<float>();
        gl_.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, texture_, 0, static_cast<GLint>(i));
        gl_.ClearBufferfv(GL_DEPTH, 0, &far_depth);
        gl_.UniformMatrix4fv(model_to_clip, 1, GL_FALSE, clip.data());
        gl_.DrawElements(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr);
        const Eigen::Matrix4f lookup = (texture_from_clip * projection.clip_from_camera).cast<float>();
        std::copy(lookup.data(), lookup.data() + 16, lookup_from_camera_.begin() + static_cast<std::ptrdiff_t>(16 * i));
        texel_depth_[i] = static_cast<float>(projection.texel_mm / projection.depth_range_mm);
    }
    gl_.ActiveTexture(GL_TEXTURE0 + kShadowTextureUnit);
    gl_.BindTexture(GL_TEXTURE_2D_ARRAY, texture_);
    gl_.ActiveTexture(GL_TEXTURE0);
}

}  // namespace facesynth::render::detail
