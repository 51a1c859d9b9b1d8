// Benchmarks of morph/: model loading (eos, .fsm) and mesh export. Run: build/bench/bench_morph.
#include "morph/mesh_io.h"
#include "morph/model_io.h"
#include "morph/region_labels.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

namespace {

std::filesystem::path sfm_dir() {
    const char* env = std::getenv("FACESYNTH_DATA");
    return std::filesystem::path(env && *env ? env : FACESYNTH_DEFAULT_DATA_DIR) / "sfm";
}

std::filesystem::path scratch(const char* name) {
    const auto dir = std::filesystem::temp_directory_path() / "facesynth-bench";
    std::filesystem::create_directories(dir);
    return dir / name;
}

void BM_LoadSurreyFolder(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    for (auto _ : state) benchmark::DoNotOptimize(facesynth::morph::load_model(sfm_dir().string()));
}
BENCHMARK(BM_LoadSurreyFolder)->Unit(benchmark::kMillisecond);

void BM_LoadSurreyBin(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const std::string path = (sfm_dir() / "sfm_shape_3448.bin").string();
    for (auto _ : state) benchmark::DoNotOptimize(facesynth::morph::load_model(path));
}
BENCHMARK(BM_LoadSurreyBin)->Unit(benchmark::kMillisecond);

void BM_DeriveRegionLabelsSurrey(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const facesynth::morph::MorphableModel model = facesynth::morph::load_model(sfm_dir().string());
    for (auto _ : state) benchmark::DoNotOptimize(facesynth::morph::derive_region_labels(model));
}
BENCHMARK(BM_DeriveRegionLabelsSurrey)->Unit(benchmark::kMillisecond);

void BM_ReadSurreyFsm(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const auto path = scratch("sfm.fsm");
    facesynth::morph::write_model(facesynth::morph::load_model(sfm_dir().string()), path);
    for (auto _ : state) benchmark::DoNotOptimize(facesynth::morph::read_model(path));
}
BENCHMARK(BM_ReadSurreyFsm)->Unit(benchmark::kMillisecond);

void BM_WriteGlbSurreyMean(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const facesynth::morph::Mesh mesh = facesynth::morph::load_model(sfm_dir().string()).instance({});
    for (auto _ : state) facesynth::morph::write_glb(mesh, scratch("mean.glb"));
}
BENCHMARK(BM_WriteGlbSurreyMean)->Unit(benchmark::kMillisecond);

void BM_WriteObjSurreyMean(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const facesynth::morph::Mesh mesh = facesynth::morph::load_model(sfm_dir().string()).instance({});
    for (auto _ : state) facesynth::morph::write_obj(mesh, scratch("mean.obj"));
}
BENCHMARK(BM_WriteObjSurreyMean)->Unit(benchmark::kMillisecond);

}  // namespace
