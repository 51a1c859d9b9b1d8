#pragma once
// Internal to the Renderer: its framebuffers. The single-sample targets (colour, normals, triangle ids,
// barycentrics, depth), the multisampled colour pass and the supersampled colour pass, each growing to
// the largest image asked for and drawn into at their bottom-left corner.
#include "render/gl_functions.h"

#include <array>
#include <cstddef>

namespace facesynth::render::detail {

// Single-sample colour attachments by shader output location, then the depth attachment.
enum Target : std::size_t { kColourTarget = 0, kNormalTarget = 1, kIdTarget = 2, kBarycentricTarget = 3, kDepthTarget = 4 };

// Every call needs the renderer's context current.
class RenderTargets {
public:
    explicit RenderTargets(const GlFunctions& gl) : gl_(gl) {}
    RenderTargets(const RenderTargets&) = delete;
    RenderTargets& operator=(const RenderTargets&) = delete;

    // The framebuffer objects; `max_samples` is the context's GL_MAX_SAMPLES.
    void create(int max_samples);
    void release();

    // Targets for a w x h image with `sample_count` samples in the colour pass (0 or 1: none; capped
    // at the context's maximum), and the scissor on the image. At one sample count the targets only
    // grow, so that renders of varying sizes (a visibility pass per face, then a frontal view)
    // allocate nothing; a new sample count starts again at the image's size.
    void ensure(int w, int h, int sample_count);
    // Colour and depth of the supersampled pass at w x h (created on first use, growing likewise).
    void ensure_supersampled(int w, int h);

    [[nodiscard]] GLuint single_sample() const { return fbo_; }
    [[nodiscard]] GLuint multisample() const { return msaa_fbo_; }
    [[nodiscard]] GLuint supersample() const { return supersample_fbo_; }
    [[nodiscard]] int samples() const { return samples_; }  // of the colour pass since the last ensure: 0 or >= 2

private:
    GLuint storage(GLenum format, int sample_count, int w, int h);
    void release_single_and_multisample();
    void release_supersampled();

    const GlFunctions& gl_;
    GLuint fbo_ = 0;
    std::array<GLuint, 5> targets_{};  // by Target
    GLuint msaa_fbo_ = 0;
    std::array<GLuint, 2> msaa_targets_{};
    GLuint supersample_fbo_ = 0;
    std::array<GLuint, 2> supersample_targets_{};
    int supersample_width_ = 0, supersample_height_ = 0;
    int width_ = 0, height_ = 0;  // of the single-sample and multisampled targets
    int samples_ = 0, max_samples_ = 0;
};

}  // namespace facesynth::render::detail
