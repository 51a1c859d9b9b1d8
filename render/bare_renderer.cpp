#include "render/bare_renderer.h"

#include "core/error.h"
#include "render/gl_program.h"

#include <array>
#include <utility>

namespace facesynth::render {
namespace {

constexpr const char* kBareVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 model_to_clip;
void main() { gl_Position = model_to_clip * vec4(position, 1.0); }
)";

constexpr const char* kBareFragmentShader = R"(#version 330 core
out vec4 colour;
void main() { colour = vec4(1.0); }
)";

}  // namespace

struct BareRenderer::Impl {
    std::unique_ptr<detail::GlContext> context;
    detail::GlFunctions gl;
    std::string renderer_string;
    GLuint program = 0, vao = 0, positions = 0, indices = 0, fbo = 0;
    std::array<GLuint, 2> targets{};  // RGBA8 colour, 24-bit depth
    GLint model_to_clip = -1;
    GLsizei index_count = 0;
    int width = 0, height = 0;
    Eigen::Vector3f low, high;

    Impl(const morph::Mesh& mesh, const RendererOptions& options) {
        if (mesh.num_vertices() == 0 || mesh.triangles.empty()) throw core::Error("render: the mesh is empty");
        for (const morph::Triangle& t : mesh.triangles)
            for (int i : t)
                if (i < 0 || i >= mesh.num_vertices())
                    throw core::Error("render: triangle vertex index " + std::to_string(i) + " out of range");
        context = detail::open_context(options);
        context->make_current();
        renderer_string = detail::load_functions(*context, gl);
        const std::array<GLuint, 2> shaders{detail::compile_shader(gl, GL_VERTEX_SHADER, kBareVertexShader),
                                            detail::compile_shader(gl, GL_FRAGMENT_SHADER, kBareFragmentShader)};
        program = detail::link_shaders(gl, shaders);
        model_to_clip = gl.GetUniformLocation(program, "model_to_clip");
        gl.GenVertexArrays(1, &vao);
        gl.BindVertexArray(vao);
        gl.GenBuffers(1, &positions);
        gl.BindBuffer(GL_ARRAY_BUFFER, positions);
        gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(sizeof(float) * mesh.vertices.size()), mesh.vertices.data(),
                      GL_STATIC_DRAW);
        gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
        gl.EnableVertexAttribArray(0);
        gl.GenBuffers(1, &indices);
        gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, indices);
        gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(sizeof(morph::Triangle) * mesh.triangles.size()),
                      mesh.triangles.data(), GL_STATIC_DRAW);
        index_count = static_cast<GLsizei>(3 * mesh.triangles.size());
        low = mesh.vertices.rowwise().minCoeff();
        high = mesh.vertices.rowwise().maxCoeff();
        gl.GenFramebuffers(1, &fbo);
        gl.Enable(GL_DEPTH_TEST);
        gl.DepthFunc(GL_LESS);
        gl.FrontFace(GL_CW);  // image rows run down the GL rows, as in Renderer
        gl.CullFace(GL_BACK);
        gl.Enable(GL_CULL_FACE);
        gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
        check("initialisation");
        context->release();
    }

    ~Impl() {
        if (!context) return;
        try {
            context->make_current();
        } catch (const core::Error&) {
            return;
        }
        release_targets();
        gl.DeleteFramebuffers(1, &fbo);
        gl.DeleteBuffers(1, &indices);
        gl.DeleteBuffers(1, &positions);
        gl.DeleteVertexArrays(1, &vao);
        gl.DeleteProgram(program);
        context->release();
    }

    Impl(const Impl&) = delete;
    Impl& operator=(const Impl&) = delete;
    Impl(Impl&&) = delete;
    Impl& operator=(Impl&&) = delete;

    void check(const char* stage) const { detail::check_gl(gl, stage); }

    void release_targets() {
        for (GLuint& t : targets)
            if (t) gl.DeleteRenderbuffers(1, &t), t = 0;
    }

    void ensure_targets(int w, int h) {
        if (w == width && h == height) return;
        release_targets();
        gl.BindFramebuffer(GL_FRAMEBUFFER, fbo);
        const std::array<std::pair<GLenum, GLenum>, 2> formats{{{GL_RGBA8, GL_COLOR_ATTACHMENT0},
                                                                {GL_DEPTH_COMPONENT24, GL_DEPTH_ATTACHMENT}}};
        for (std::size_t i = 0; i < formats.size(); ++i) {
            gl.GenRenderbuffers(1, &targets[i]);
            gl.BindRenderbuffer(GL_RENDERBUFFER, targets[i]);
            gl.RenderbufferStorage(GL_RENDERBUFFER, formats[i].first, w, h);
            gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, formats[i].second, GL_RENDERBUFFER, targets[i]);
        }
        if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw core::Error("render (bare): framebuffer incomplete at " + std::to_string(w) + "x" + std::to_string(h));
        width = w;
        height = h;
        gl.Viewport(0, 0, w, h);
        check("creating render targets");
    }

    void render(const Camera& camera, cv::Mat& rgba) {
        const morph::Intrinsics& k = camera.intrinsics;
        if (k.width <= 0 || k.height <= 0 || k.width > 16384 || k.height > 16384)
            throw core::Error("render: image size " + std::to_string(k.width) + "x" + std::to_string(k.height) + " is out of range");
        context->make_current();
        ensure_targets(k.width, k.height);
        Eigen::Matrix4d model_to_camera = Eigen::Matrix4d::Identity();
        model_to_camera.topLeftCorner<3, 3>() = morph::model_to_camera_flip() * camera.pose.rotation;
        model_to_camera.topRightCorner<3, 1>() = camera.pose.translation;
        const detail::DepthRange range = detail::depth_range(camera, low, high);
        const Eigen::Matrix4f clip = (detail::clip_from_camera(camera, range.near, range.far) * model_to_camera).cast<float>();
        gl.BindFramebuffer(GL_FRAMEBUFFER, fbo);
        gl.UseProgram(program);
        gl.BindVertexArray(vao);
        gl.UniformMatrix4fv(model_to_clip, 1, GL_FALSE, clip.data());
        const std::array<float, 4> zeros{};
        const float far_depth = 1.0f;
        gl.ClearBufferfv(GL_COLOR, 0, zeros.data());
        gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
        gl.DrawElements(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr);
        rgba.create(height, width, CV_8UC4);
        gl.ReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
        check("rendering");
    }
};

BareRenderer::BareRenderer(const morph::Mesh& mesh, const RendererOptions& options)
    : impl_(std::make_unique<Impl>(mesh, options)) {}
BareRenderer::~BareRenderer() = default;
BareRenderer::BareRenderer(BareRenderer&&) noexcept = default;
BareRenderer& BareRenderer::operator=(BareRenderer&&) noexcept = default;

void BareRenderer::render(const Camera& camera, cv::Mat& rgba) { impl_->render(camera, rgba); }
void BareRenderer::detach() {
    if (impl_) impl_->context->release();
}
std::string BareRenderer::backend() const { return impl_->context->backend_name(); }
std::string BareRenderer::renderer_string() const { return impl_->renderer_string; }

}  // namespace facesynth::render
