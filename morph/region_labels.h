#pragma once
// Region labels (morph/regions.h) for a model that has the 68 iBUG landmarks but no labels of its
// own (the Surrey model, a Basel model with a landmark mapping, ...), derived from the landmarks on
// the frontal projection of the mean shape. docs/models.md, "Derived region labels", says what is
// derived and how.
#include "morph/model.h"

#include <cstdint>
#include <vector>

namespace facesynth::morph {

// One Region id per vertex of the model: brows, eyes, lips, mouth interior and nose from polygons
// through the landmarks, neck below the jaw line, skin elsewhere (hair and ears are not derived).
// Empty when the model lacks the 68 landmarks or they are degenerate (outer eye corners coincide).
[[nodiscard]] std::vector<std::uint8_t> derive_region_labels(const MorphableModel& model);

}  // namespace facesynth::morph
