#pragma once
// Ambient occlusion on the CPU: how much of the sky over a point a mesh leaves open. Used to shade
// what the renderer's lights cannot (they are unoccluded but for cast shadows of directional lights):
// the neck under the chin and jaw (synth's head.ambient_occlusion, docs/synth.md "Head parts").
#include "morph/mesh.h"

#include <Eigen/Core>

#include <vector>

namespace facesynth::render {

struct AmbientOcclusionOptions {
    int directions = 96;     // views spread evenly over the sphere (a Fibonacci lattice)
    float texel_mm = 2.0f;   // the views' z-buffer resolution
    float bias_mm = 4.0f;    // a point this far behind the nearest surface still counts as open (it lies on it)
};

// For each point (3 x P, with unit normals 3 x P, in the mesh's frame and units), the cosine-weighted
// share of the directions over its normal along which nothing of the mesh lies: 1 on a lone convex
// surface, less under an overhang. Each direction is one orthographic z-buffer of the whole mesh
// (render/zbuffer.h, back faces culled) seen from that side; a point is open along it when it is no
// more than bias_mm behind the nearest surface there. Throws core::Error on mismatched sizes.
[[nodiscard]] Eigen::VectorXf ambient_visibility(const Eigen::Matrix3Xf& mesh_vertices, const std::vector<morph::Triangle>& mesh_triangles,
                                                 const Eigen::Matrix3Xf& points, const Eigen::Matrix3Xf& normals,
                                                 const AmbientOcclusionOptions& options = {});

}  // namespace facesynth::render
