#pragma once
// Moved and degraded copies of training photographs (SdmTrainOptions::image_copies, `facesynth train
// --image-copies K`): each copy is the canonical crop turned, scaled and shifted a little, with its
// landmarks moved alike, and then degraded as another camera would have taken it (degrade/degrade.h:
// gamma, gain, blur, sensor noise, JPEG). On helen_train they lowered the photographs' SDM's error where
// as many more perturbed starts did half as much (docs/results.md, "The SDM's training settings").
#include "train/sdm.h"

#include <cstddef>
#include <cstdint>

namespace facesynth::train {

// The largest change a copy draws (each uniform in ±): turn, relative scale, shift in crop pixels.
inline constexpr double kCopyMaxTurnDeg = 10.0;
inline constexpr double kCopyMaxScale = 0.07;
inline constexpr double kCopyMaxShift = 3.0;
// The most copies per photograph `--image-copies` takes (each adds the photograph's rows again).
inline constexpr int kMaxImageCopies = 32;

// Copy `copy` (0-based) of training face `face_index`. Its draws depend on (seed, face_index, copy) only,
// so that a face's first copies stay the same whatever the number of copies. The copy's box is no longer
// the detector's (box_from_detector false): it enters neither the mean shape nor the starts' spread.
[[nodiscard]] TrainingFace moved_and_degraded_copy(const TrainingFace& face, std::uint64_t seed, std::size_t face_index, int copy);

}  // namespace facesynth::train
