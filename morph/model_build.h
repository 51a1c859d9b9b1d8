#pragma once
// `facesynth model build`: a morphable model from meshes in dense correspondence (same vertex
// count and triangles, vertex i the same anatomical point in every mesh), through build_pca, the
// code the built-in model also uses.
#include "morph/mesh.h"
#include "morph/model.h"
#include "morph/pca.h"

#include <string>
#include <vector>

namespace facesynth::morph {

struct ModelBuildOptions {
    PcaBuildOptions shape;         // components / variance kept for the shape model
    PcaBuildOptions colour;        // the same for the colour model
    std::string name = "built";
};

struct ModelBuildResult {
    MorphableModel model;
    double length_scale = 1.0;  // factor applied to reach millimetres (unit_scale_to_mm); 1 when already mm
};

// Shape PCA over the meshes' vertices; a colour PCA when every mesh has per-vertex colours (a
// mean-only colour model when they are all the same); triangles and uv from the first mesh.
// `sources` name the meshes in errors (same order as `meshes`). Throws core::Error when there
// are fewer than 2 meshes or their topologies differ.
[[nodiscard]] ModelBuildResult build_model(const std::vector<Mesh>& meshes, const std::vector<std::string>& sources,
                                           const ModelBuildOptions& options = {});

}  // namespace facesynth::morph
