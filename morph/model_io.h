#pragma once
// Loading and saving morphable models. Every reader validates what it reads and throws
// core::Error naming the file and the problem; none trusts a size field before checking it
// against the file's length.
#include "morph/model.h"

#include <filesystem>
#include <string>
#include <string_view>

namespace facesynth::morph {

// `spec` as given to --model: "builtin", a model file (eos .bin, BFM 2017 .h5, our own .fsm), or a
// folder holding a model with its side files (as ../shared/data/sfm/: model, blendshapes, landmark
// mapping, contours, symmetry), which loads them all.
[[nodiscard]] MorphableModel load_model(const std::string& spec);

// Our own format (docs/model-format.md): versioned, checksummed, round-trips every field.
void write_model(const MorphableModel& model, const std::filesystem::path& path);
[[nodiscard]] MorphableModel read_model(const std::filesystem::path& path);
// The same from the bytes of an .fsm file; `name` says where they came from in errors.
[[nodiscard]] MorphableModel parse_model(std::string_view bytes, const std::string& name);

}  // namespace facesynth::morph
