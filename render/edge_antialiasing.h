#pragma once
// Analytic anti-aliasing of silhouette edges on the CPU, after a single-sample render: geometric
// post-process anti-aliasing (GPAA, Persson 2011) restricted to the edges where the surface ends.
//
// A silhouette edge is a mesh edge with a drawn triangle on one side only: between a front- and a
// back-facing triangle, or on the open border of a front-facing one (with back faces drawn too:
// between triangles of opposite facing, or any border). Walking such an edge along its major axis,
// each pixel column (or row) it crosses holds one pixel A whose area the edge cuts; the share of A
// beyond the edge, seen from A's centre, is 0.5 - |d| (d: the edge's offset from A's centre along the
// minor axis), and A is blended by that share with its neighbour across the edge, which shows the
// other side. Colour is premultiplied by coverage, so one blend of rgb and mask gives fractional
// coverage on the outer outline and a colour blend with full coverage where the face lies over
// itself (nose over cheek, ears, chin over neck). Geometry maps are not touched.
#include "morph/mesh.h"
#include "render/renderer.h"
#include "render/triangle_list.h"

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace facesynth::render {

// Each undirected edge of a triangle list with its one or two triangles (built once per list).
struct EdgeTopology {
    struct Edge {
        int a = 0, b = 0;                    // vertex ids
        int triangle[2] = {-1, -1};          // -1: none (open border)
        int opposite[2] = {-1, -1};          // each triangle's third vertex
    };
    detail::TriangleListKey source;  // the triangle list it was built from
    std::vector<Edge> edges;       // edges of more than two triangles are left out (not a surface border)
    // Per edge, its triangles + 1 (0: none): all the per-render pass over every edge reads, 8 bytes an
    // edge instead of the 24 of `edges` (a synth worker finds them out of cache at every sample).
    std::vector<std::array<int, 2>> sides;

    [[nodiscard]] bool matches(const morph::Mesh& mesh) const { return source.matches(mesh); }
    // Throws core::Error on a vertex index out of range.
    void build(const morph::Mesh& mesh);
};

// What one pass did (for tests and benchmarks).
struct EdgeAntialiasingStats {
    int silhouette_edges = 0;  // in the image or not
    int blended_pixels = 0;    // pixels blended (by the nearest edge that cuts them)
    int hidden_steps = 0;      // columns skipped because nearer geometry covers the edge there
};

class EdgeAntialiasing {
public:
    // Blends the pixels cut by visible silhouette edges in `rgb` (CV_8UC3, premultiplied by `mask`)
    // and `mask` (CV_8UC1), reading `depth` (CV_32FC1 camera z at pixel centres, 0 = background) of
    // the same single-sample render of `mesh` seen by `camera`. `cull_back_faces` as rendered.
    EdgeAntialiasingStats apply(const morph::Mesh& mesh, const Camera& camera, bool cull_back_faces, const cv::Mat& depth,
                                cv::Mat& rgb, cv::Mat& mask);

    // A silhouette edge is hidden at a pixel column when the surface seen on its far side lies more
    // than this many pixel footprints (mm covered by one pixel at the edge's depth) in front of it.
    static constexpr double kHiddenMarginPixels = 2.0;

private:
    struct Blend {
        int pixel = 0, neighbour = 0;  // row-major pixel indices
        float weight = 0;              // share of `pixel` taken from `neighbour`
        float z = 0;                   // camera z of the edge there
    };
    EdgeTopology topology_;
    std::vector<double> screen_x_, screen_y_, camera_z_;  // per vertex
    // Entry t + 1 for triangle t, entry 0 for none: whether it is drawn (back faces culled: 1 front,
    // else 0) or its facing (back faces drawn: 1 front, -1 back, 0 degenerate). An edge is a
    // silhouette exactly where its two entries differ.
    std::vector<std::int8_t> facing_;
    std::vector<Blend> blends_;
    std::vector<float> deltas_;                            // 4 per blend: r, g, b, coverage
};

}  // namespace facesynth::render
