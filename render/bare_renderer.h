#pragma once
// The floor under a render: the "minimal GL program" in the same binary, so that a full
// render's cost is compared with it in the same minutes (`facesynth bench render --bare`).
//
// It draws the mesh given at construction (positions only, uploaded once, the mesh's own triangle
// list, back faces culled as in a full render) with a constant-colour shader into one RGBA8 target
// and a 24-bit depth buffer, and reads back RGBA only: no normals, colours, ids, labels, depth
// read-back, shading or per-frame upload. Not a renderer for any other use.
#include "morph/mesh.h"
#include "render/renderer.h"

#include <opencv2/core.hpp>

#include <memory>
#include <string>

namespace facesynth::render {

class BareRenderer {
public:
    explicit BareRenderer(const morph::Mesh& mesh, const RendererOptions& options = {});
    ~BareRenderer();
    BareRenderer(BareRenderer&&) noexcept;
    BareRenderer& operator=(BareRenderer&&) noexcept;
    BareRenderer(const BareRenderer&) = delete;
    BareRenderer& operator=(const BareRenderer&) = delete;

    // The mesh seen by `camera` into `rgba` (CV_8UC4, R G B A; face white, background 0).
    void render(const Camera& camera, cv::Mat& rgba);
    // Unbinds the context from the calling thread (as Renderer::detach).
    void detach();
    [[nodiscard]] std::string backend() const;
    [[nodiscard]] std::string renderer_string() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace facesynth::render
