// The GL pieces the Renderer and the bare benchmark renderer share (gl_program.h): opening a
// context, the projection built from K, compiling and linking shaders.
#include "render/gl_program.h"

#include "core/error.h"
#include "morph/camera.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <string>

namespace facesynth::render {

namespace {

using detail::GlFunctions;

// EGL failing and OSMesa taking over is worth one line on stderr per process (not one per
// renderer or thread): rendering works, only slower or without a hardware device.
void warn_egl_fallback(const std::string& egl_failure) {
    static std::atomic<bool> warned{false};
    if (!warned.exchange(true))
        std::fprintf(stderr, "facesynth: warning: EGL unavailable (%s); rendering with OSMesa\n", egl_failure.c_str());
}

}  // namespace

namespace detail {

std::unique_ptr<GlContext> open_context(const RendererOptions& options) {
    const Backend backend = options.backend;
    std::unique_ptr<GlContext> context;
    std::string failures;
    if (backend != Backend::kOsmesa) {
        try {
            context = create_egl_context(options.allow_gpu_device, options.software_display % 2 != 0);
        } catch (const core::Error& e) {
            if (backend == Backend::kEgl) throw;
            failures = e.what();
        }
    }
    if (!context) {
        try {
            context = create_osmesa_context();
        } catch (const core::Error& e) {
            if (backend == Backend::kOsmesa) throw;
            throw core::Error("render: no OpenGL backend available (" + failures + "; " + e.what() + ")");
        }
        if (!failures.empty()) warn_egl_fallback(failures);
    }
    return context;
}

// The clip matrix for a pinhole (or orthographic) camera given in OpenCV pixels. Window x = u + 0.5
// (pixel u's centre), window y = v + 0.5 with GL row 0 holding image row 0, so read-back needs no
// flip. z_ndc runs from -1 at `near` to +1 at `far` (camera-space z, mm).
Eigen::Matrix4d clip_from_camera(const Camera& camera, double near, double far) {
    const morph::Intrinsics& k = camera.intrinsics;
    const double w = k.width, h = k.height;
    Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
    if (camera.projection == Projection::kPerspective) {
        p(0, 0) = 2.0 * k.fx / w;
        p(0, 2) = 2.0 * (k.cx + 0.5) / w - 1.0;
        p(1, 1) = 2.0 * k.fy / h;
        p(1, 2) = 2.0 * (k.cy + 0.5) / h - 1.0;
        p(2, 2) = (far + near) / (far - near);
        p(2, 3) = -2.0 * far * near / (far - near);
        p(3, 2) = 1.0;
    } else {
        p(0, 0) = 2.0 * k.fx / w;
        p(0, 3) = 2.0 * (k.cx + 0.5) / w - 1.0;
        p(1, 1) = 2.0 * k.fy / h;
        p(1, 3) = 2.0 * (k.cy + 0.5) / h - 1.0;
        p(2, 2) = 2.0 / (far - near);
        p(2, 3) = -(far + near) / (far - near);
        p(3, 3) = 1.0;
    }
    return p;
}

DepthRange depth_range(const Camera& camera, const Eigen::Vector3f& low, const Eigen::Vector3f& high) {
    const Eigen::Vector3d centre = (0.5f * (low + high)).cast<double>();
    const double radius = 0.5 * (high - low).cast<double>().norm();
    const double centre_z = morph::to_camera(camera.pose, centre).z();
    const double margin = 1.0 + 0.01 * radius;
    double far = centre_z + radius + margin, near = centre_z - radius - margin;
    if (camera.projection == Projection::kPerspective) near = std::max(near, std::max(1e-3, far * 1e-4));
    if (far <= near) far = near + 1.0;
    return {near, far};
}

GLuint compile_shader(const GlFunctions& gl, GLenum type, const std::string& source) {
    const GLuint shader = gl.CreateShader(type);
    const char* text = source.c_str();
    gl.ShaderSource(shader, 1, &text, nullptr);
    gl.CompileShader(shader);
    GLint ok = 0;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        std::array<char, 4096> log{};
        gl.GetShaderInfoLog(shader, static_cast<GLsizei>(log.size()), nullptr, log.data());
        gl.DeleteShader(shader);
        throw core::Error(std::string("render: shader compilation failed: ") + log.data());
    }
    return shader;
}

std::string load_functions(const GlContext& context, GlFunctions& gl) {
    gl.load([&context](const char* name) { return context.get_proc_address(name); }, context.backend_name());
    return std::string(reinterpret_cast<const char*>(gl.GetString(GL_RENDERER))) + " | " +
           reinterpret_cast<const char*>(gl.GetString(GL_VERSION));
}

void check_gl(const GlFunctions& gl, const char* stage) {
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
        char code[16];
        std::snprintf(code, sizeof code, "0x%04x", error);
        throw core::Error(std::string("render: OpenGL error ") + code + " during " + stage);
    }
}

GLuint link_shaders(const GlFunctions& gl, std::span<const GLuint> shaders) {
    const GLuint program = gl.CreateProgram();
    for (GLuint s : shaders) gl.AttachShader(program, s);
    gl.LinkProgram(program);
    for (GLuint s : shaders) gl.DeleteShader(s);
    GLint ok = 0;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        std::array<char, 4096> log{};
        gl.GetProgramInfoLog(program, static_cast<GLsizei>(log.size()), nullptr, log.data());
        gl.DeleteProgram(program);
        throw core::Error(std::string("render: shader program link failed: ") + log.data());
    }
    return program;
}

}  // namespace detail

}  // namespace facesynth::render
