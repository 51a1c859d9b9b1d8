#pragma once
// The built-in default model: a procedural human face built from anatomy, with no external data.
//
// A head-and-face surface on a regular (column, row) grid, shaped by smooth anthropometric
// profiles (Farkas 1994 norms, docs/builtin-model.md) and local displacement fields anchored at anatomical
// points (brow ridge, eye sockets with eyeballs and lids, nose, lips, chin, cheeks, jaw). A
// population of varied individuals in dense correspondence goes through build_pca (the code behind
// `facesynth model build`) for the shape and the colour model; expressions are named blendshapes.
// See docs/builtin-model.md.
#include "morph/model.h"

namespace facesynth::morph {

// Grid size of the built-in mesh (columns run from the subject's right ear round the face to the
// left ear; rows from above the hairline to under the chin).
inline constexpr int kBuiltinColumns = 85;
inline constexpr int kBuiltinRows = 88;

// Builds the model. Deterministic (fixed seeds through core::Rng): every call returns the same
// model, bit for bit. Nothing is cached: each call recomputes it (about 0.6 s of CPU time in a
// Release build), so callers that need it repeatedly should keep the returned value.
[[nodiscard]] MorphableModel builtin_model();

}  // namespace facesynth::morph
