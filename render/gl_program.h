#pragma once
// Internal: pieces shared by the Renderer and the bare benchmark renderer (bare_renderer.h):
// opening a context, the GL projection built from K, and compiling shader programs.
#include "render/gl_context.h"
#include "render/gl_functions.h"
#include "render/renderer.h"

#include <Eigen/Core>

#include <memory>
#include <span>
#include <string>

namespace facesynth::render::detail {

// EGL then OSMesa for Backend::kAuto (one warning per process when OSMesa takes over), or the one
// asked for; throws core::Error saying what failed.
[[nodiscard]] std::unique_ptr<GlContext> open_context(const RendererOptions& options);

// Camera space to clip space for a pinhole (or orthographic) camera in OpenCV pixels: window
// x = u + 0.5, GL row 0 holds image row 0, z_ndc from -1 at `near` to +1 at `far` (docs/render.md).
[[nodiscard]] Eigen::Matrix4d clip_from_camera(const Camera& camera, double near, double far);

struct DepthRange {
    double near = 0, far = 0;  // camera-space z, mm
};
// Near and far planes around the bounding sphere of the model-space box [low, high], with a margin.
[[nodiscard]] DepthRange depth_range(const Camera& camera, const Eigen::Vector3f& low, const Eigen::Vector3f& high);

// Resolves the GL entry points of the current `context` into `gl`; returns "GL_RENDERER | GL_VERSION".
[[nodiscard]] std::string load_functions(const GlContext& context, GlFunctions& gl);
// Throws core::Error naming `stage` when the context has a GL error pending.
void check_gl(const GlFunctions& gl, const char* stage);

// Throws core::Error with the compiler's or linker's log. link_shaders deletes the shaders.
[[nodiscard]] GLuint compile_shader(const GlFunctions& gl, GLenum type, const std::string& source);
[[nodiscard]] GLuint link_shaders(const GlFunctions& gl, std::span<const GLuint> shaders);

}  // namespace facesynth::render::detail
