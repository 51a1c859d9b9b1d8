#pragma once
// Writers of outside model formats for tests and fuzzing seeds: eos's cereal binary (model versions
// 1-4, blendshapes) and the Basel 2017 / statismo HDF5 layout, as docs/models.md describes them.
// facesynth itself only reads these formats, so the writers live with the tests.
#include "morph/model.h"

#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace facesynth::testkit {

// An eos MorphableModel file of `version` (1-4) holding `model` (blendshapes or PCA expression,
// colour model when present, uv); from version 3 on the landmarks as iBUG ids plus one non-iBUG name.
[[nodiscard]] std::string eos_model_bytes(const morph::MorphableModel& model, std::uint32_t version, bool with_landmarks = true);
// eos's vector<Blendshape> file.
[[nodiscard]] std::string eos_blendshape_bytes(const std::vector<morph::Blendshape>& shapes);

// One float dataset of a statismo file: dims and row-major values.
struct DatasetSpec {
    std::vector<hsize_t> dims;
    std::vector<float> values;          // row-major
    bool chunked_without_data = false;  // declare dims but store nothing (a lying header)
};
[[nodiscard]] DatasetSpec vector_spec(const Eigen::VectorXf& v);
[[nodiscard]] DatasetSpec matrix_spec(const Eigen::MatrixXf& m);

struct StatismoOverrides {
    std::string skip;                            // dataset left out
    std::map<std::string, DatasetSpec> replace;  // dataset replaced
};

// `model` in statismo layout: /shape, /color (albedo) and /expression (a PCA expression model)
// with model/{mean,pcaBasis,pcaVariance,noiseVariance} and representer/{points,cells}.
void write_statismo(const std::filesystem::path& path, const morph::MorphableModel& model, const StatismoOverrides& overrides = {});

// Writes bytes to a file as they are (no temporary name: tests write broken files on purpose).
void write_bytes(const std::filesystem::path& path, const std::string& bytes);

}  // namespace facesynth::testkit
