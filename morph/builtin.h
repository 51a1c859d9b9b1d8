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

// The model, read from the copy that generate_builtin_model() wrote at build time and that is
// embedded in the library (an .fsm, docs/model-format.md, checksum verified on reading), so that a
// command using the built-in model no longer pays the generation (`facesynth model info`: 0.2 CPU-s
// instead of 0.6 in Release, 0.5 instead of 3.1 under the sanitizers; docs/builtin-model.md). A program linked without the copy (the
// build's own generator) generates it instead. Either way the same model, bit for bit.
[[nodiscard]] MorphableModel builtin_model();

// Builds the model from its procedural population. Deterministic (fixed seeds through core::Rng):
// every call returns the same model, bit for bit; nothing is cached.
[[nodiscard]] MorphableModel generate_builtin_model();

// Whether this program carries the build-time copy that builtin_model() reads.
[[nodiscard]] bool builtin_model_is_embedded();

}  // namespace facesynth::morph
