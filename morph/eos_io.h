#pragma once
// Readers for the eos library's files, as shipped with the Surrey Face Model (../shared/data/sfm/):
// the MorphableModel cereal binary (model versions 1-4), the expression blendshapes binary, the
// TOML iBUG landmark mapping, the contour JSON and the reference symmetry list.
// Layouts: docs/models.md. Every reader throws core::Error naming the file and the problem.
#include "morph/model.h"

#include <filesystem>
#include <map>
#include <vector>

namespace facesynth::morph {

// A partial iBUG 68 definition: 1-based iBUG id -> 0-based vertex id.
using LandmarkMapping = std::map<int, int>;

struct EosModelFile {
    MorphableModel model;       // landmarks empty; contour and symmetry empty
    LandmarkMapping landmarks;  // from a version-3+ landmark map whose keys are iBUG ids; may be empty
    int version = 0;
};

[[nodiscard]] EosModelFile read_eos_model(const std::filesystem::path& path);
// vector<Blendshape> as eos writes it; every blendshape must have `expected_values` values when
// that is non-zero (3 x the model's vertex count).
[[nodiscard]] std::vector<Blendshape> read_eos_blendshapes(const std::filesystem::path& path,
                                                           long expected_values = 0);

// `[landmark_mappings]` of an eos TOML mapping file (iBUG id = vertex id).
[[nodiscard]] LandmarkMapping read_landmark_mapping(const std::filesystem::path& path);
// `model_contour.right_contour` / `left_contour` of an eos contour JSON file.
[[nodiscard]] ContourChains read_model_contours(const std::filesystem::path& path);
// One 1-based mirror vertex id per line for the first lines' vertices; returns a 0-based map of
// `num_vertices` entries, -1 for vertices the file does not cover.
[[nodiscard]] std::vector<int> read_symmetry(const std::filesystem::path& path, int num_vertices);

// Extra landmark vertices for a model whose mapping is incomplete (the Surrey model leaves out the
// jaw points 1-8, 10-17 and the inner mouth corners 61, 65). The TOML file holds
// `model_vertices` and `model_triangles` (the mesh it applies to) and `[landmark_mappings]` like
// eos's file.
struct LandmarkCompletion {
    int model_vertices = 0;
    int model_triangles = 0;
    LandmarkMapping mapping;
};
[[nodiscard]] LandmarkCompletion parse_landmark_completion(const std::string& toml_text,
                                                           const std::string& source_name);
// The project's completion for the Surrey 3448-vertex model (data/sfm_landmarks_completion.toml,
// compiled in).
[[nodiscard]] const LandmarkCompletion& sfm_landmark_completion();
// Whether `completion` was made for `model`'s mesh.
[[nodiscard]] bool completion_applies(const LandmarkCompletion& completion, const MorphableModel& model);

// All 68 landmarks in iBUG order from `mapping`; throws naming the missing iBUG ids.
[[nodiscard]] std::vector<SurfacePoint> ibug68_from_mapping(const LandmarkMapping& mapping,
                                                            const std::string& context);

}  // namespace facesynth::morph
