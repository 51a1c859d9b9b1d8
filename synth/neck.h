#pragma once
// A neck under a model's jaw (synth's head.neck, docs/synth.md "Neck"): an elliptic cylinder placed
// from the sample's own landmarks (its width from the jaw, its front behind the chin, its top hidden
// inside the head), so that the jaw line meets skin instead of background. It is added to the rendered
// mesh only: the model, its landmarks and region labels stay as they are. Neck vertices take the uv
// (and the colour, darkened for the jaw's shadow) of the model vertex under the chin nearest to them
// in angle round the neck, and the region label Region::kNeck.
#include "morph/mesh.h"
#include "morph/model.h"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <vector>

namespace facesynth::synth {

struct NeckTemplate {
    int rings = 8;                    // rings of vertices from the top (inside the head) down
    int segments = 32;                // vertices per ring, round the neck
    int first_vertex = 0;             // index of the first neck vertex (the model's vertex count)
    std::vector<morph::Triangle> triangles;  // the neck's, outward counter-clockwise, indices from first_vertex
    std::vector<int> source;          // per neck vertex: the model vertex whose uv and colour it takes
};

// The neck of `model`, or nothing when it has no 68 landmarks to place it by.
[[nodiscard]] std::optional<NeckTemplate> make_neck_template(const morph::MorphableModel& model);

// Appends the neck's vertices to `mesh`, whose first vertices are the sample's model shape.
void append_neck_vertices(const NeckTemplate& neck, const morph::MorphableModel& model, morph::Mesh& mesh);

// The model's triangles, uv, region labels and colours (3 x V) followed by the neck's.
[[nodiscard]] std::vector<morph::Triangle> mesh_triangles_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck);
[[nodiscard]] Eigen::Matrix2Xf uv_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck);
[[nodiscard]] std::vector<std::uint8_t> labels_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck);
[[nodiscard]] Eigen::Matrix3Xf colours_with_neck(const Eigen::Matrix3Xf& colours, const NeckTemplate& neck, float shade = 0.8f);

}  // namespace facesynth::synth
