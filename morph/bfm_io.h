#pragma once
// Basel Face Model 2017 (statismo HDF5 layout) and the units rule shared by every reader of
// outside geometry. See docs/models.md.
#include "morph/model.h"

#include <filesystem>
#include <string>

namespace facesynth::morph {

// Reads /shape (required), /color and /expression (optional): model/{mean,pcaBasis,pcaVariance}
// and representer/{points,cells}. Coordinates are converted to millimetres by unit_scale_to_mm
// (a warning on stderr says so when they were not in mm). Throws core::Error naming the file,
// the dataset and the problem. HDF5's own error printing is switched off while it reads (a
// process-wide HDF5 setting): do not read HDF5 files on other threads at the same time.
[[nodiscard]] MorphableModel read_bfm2017(const std::filesystem::path& path);

// The factor that turns coordinates into millimetres, judged from the bounding-box diagonal of a
// stacked 3V point vector (a head is 150-400 mm across): 1 for a diagonal in [30 mm, 3 m]
// (millimetres), 0.001 for [30e3, 3e6] (micrometres, as BFM 2009), 1000 for [0.03, 3] (metres,
// as FLAME). Anything else throws naming `source`.
[[nodiscard]] double unit_scale_to_mm(const Eigen::VectorXf& stacked_points, const std::string& source);

// Scales every length in the model by `factor` (means, blendshapes; variances by factor²).
void scale_model_lengths(MorphableModel& model, double factor);

}  // namespace facesynth::morph
