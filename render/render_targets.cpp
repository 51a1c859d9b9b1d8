#include "render/render_targets.h"

#include "core/error.h"
#include "render/gl_program.h"

#include <algorithm>
#include <string>

namespace facesynth::render::detail {

void RenderTargets::create(int max_samples) {
    max_samples_ = max_samples;
    gl_.GenFramebuffers(1, &fbo_);
    gl_.GenFramebuffers(1, &msaa_fbo_);
}

void RenderTargets::release() {
    release_single_and_multisample();
    release_supersampled();
    if (fbo_) gl_.DeleteFramebuffers(1, &fbo_), fbo_ = 0;
    if (msaa_fbo_) gl_.DeleteFramebuffers(1, &msaa_fbo_), msaa_fbo_ = 0;
}

void RenderTargets::release_single_and_multisample() {
    for (GLuint& t : targets_)
        if (t) gl_.DeleteRenderbuffers(1, &t), t = 0;
    for (GLuint& t : msaa_targets_)
        if (t) gl_.DeleteRenderbuffers(1, &t), t = 0;
}

void RenderTargets::release_supersampled() {
    for (GLuint& t : supersample_targets_)
        if (t) gl_.DeleteRenderbuffers(1, &t), t = 0;
    if (supersample_fbo_) gl_.DeleteFramebuffers(1, &supersample_fbo_), supersample_fbo_ = 0;
}

GLuint RenderTargets::storage(GLenum format, int sample_count, int w, int h) {
    GLuint rb = 0;
    gl_.GenRenderbuffers(1, &rb);
    gl_.BindRenderbuffer(GL_RENDERBUFFER, rb);
    if (sample_count > 1)
        gl_.RenderbufferStorageMultisample(GL_RENDERBUFFER, sample_count, format, w, h);
    else
        gl_.RenderbufferStorage(GL_RENDERBUFFER, format, w, h);
    return rb;
}

void RenderTargets::ensure(int w, int h, int sample_count) {
    sample_count = std::min(sample_count <= 1 ? 0 : sample_count, max_samples_);
    gl_.Scissor(0, 0, w, h);
    if (w <= width_ && h <= height_ && sample_count == samples_ && targets_[0]) return;
    const bool grow = sample_count == samples_ && targets_[0];
    release_single_and_multisample();
    width_ = grow ? std::max(w, width_) : w;
    height_ = grow ? std::max(h, height_) : h;
    samples_ = sample_count;
    const std::array<GLenum, 4> colour_formats{GL_RGBA8, GL_RGBA32F, GL_R32UI, GL_RGBA32F};  // by Target
    gl_.BindFramebuffer(GL_FRAMEBUFFER, fbo_);
    for (std::size_t i = 0; i < colour_formats.size(); ++i) {
        targets_[i] = storage(colour_formats[i], 0, width_, height_);
        gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(i), GL_RENDERBUFFER, targets_[i]);
    }
    // 32-bit float depth: camera z is recovered from it to ~1e-5 mm (the Renderer's read_depth).
    targets_[kDepthTarget] = storage(GL_DEPTH_COMPONENT32F, 0, width_, height_);
    gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, targets_[kDepthTarget]);
    if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw core::Error("render: framebuffer incomplete at " + std::to_string(width_) + "x" + std::to_string(height_));
    if (samples_ > 1) {
        gl_.BindFramebuffer(GL_FRAMEBUFFER, msaa_fbo_);
        msaa_targets_[0] = storage(GL_RGBA8, samples_, width_, height_);
        gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msaa_targets_[0]);
        msaa_targets_[1] = storage(GL_DEPTH_COMPONENT24, samples_, width_, height_);
        gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msaa_targets_[1]);
        if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw core::Error("render: multisample framebuffer incomplete (" + std::to_string(samples_) + " samples)");
    }
    check_gl(gl_, "creating render targets");
}

void RenderTargets::ensure_supersampled(int w, int h) {
    if (w <= supersample_width_ && h <= supersample_height_) return;
    supersample_width_ = std::max(w, supersample_width_);
    supersample_height_ = std::max(h, supersample_height_);
    for (GLuint& t : supersample_targets_)
        if (t) gl_.DeleteRenderbuffers(1, &t), t = 0;
    if (!supersample_fbo_) gl_.GenFramebuffers(1, &supersample_fbo_);
    gl_.BindFramebuffer(GL_FRAMEBUFFER, supersample_fbo_);
    supersample_targets_[0] = storage(GL_RGBA8, 0, supersample_width_, supersample_height_);
    gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, supersample_targets_[0]);
    supersample_targets_[1] = storage(GL_DEPTH_COMPONENT24, 0, supersample_width_, supersample_height_);
    gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, supersample_targets_[1]);
    if (gl_.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw core::Error("render: supersampling framebuffer incomplete at " + std::to_string(w) + "x" + std::to_string(h));
    check_gl(gl_, "creating supersampling targets");
}

}  // namespace facesynth::render::detail
