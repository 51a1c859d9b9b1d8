#pragma once
// A small, fully specified morphable model for tests: an ellipsoidal head (mm, model-space axes as
// in docs/conventions.md) with smooth random shape components, two blendshapes, a colour model, uv,
// symmetric mirror map, 68 landmarks at vertices and jaw contour chains. Independent of the
// built-in model so tests of algorithms do not move when the built-in model is improved.
#include "morph/model.h"

#include <cstdint>

namespace facesynth::testkit {

struct ToyModelOptions {
    int shape_components = 10;
    int latitude_steps = 40;
    int longitude_steps = 64;  // even, so the mesh is mirror-symmetric about x = 0
    std::uint64_t seed = 1;
};

[[nodiscard]] morph::MorphableModel make_toy_model(const ToyModelOptions& options = {});

// Replaces the model's colour model by a one-component one: `mean` on every vertex, and each σ of
// the component adds `shift_per_sigma` to every vertex (a deliberately broken basis when the shift
// drives the skin out of the range of real skin).
void set_uniform_colour_model(morph::MorphableModel& model, const Eigen::Vector3f& mean, const Eigen::Vector3f& shift_per_sigma);

// A rough frontal iBUG-68 template in model space (x right, y up, mm; nose tip at y = 0).
[[nodiscard]] Eigen::Matrix2Xd ibug68_frontal_template();

}  // namespace facesynth::testkit
