// Fitting speed, single thread (issue 5 targets: linear camera + identity + expression, 5 iterations,
// 68 points < 0.3 ms; with contour updates < 2 ms; refined < 20 ms). Uses the Surrey model from
// FACESYNTH_DEFAULT_DATA_DIR/sfm when it loads, otherwise the built-in model.
#include "fit/evaluate.h"
#include "fit/fit.h"
#include "fit/refine.h"
#include "morph/model_io.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>

namespace {

using namespace facesynth;

const morph::MorphableModel& bench_model() {
    static const morph::MorphableModel model = [] {
        const std::filesystem::path sfm = std::filesystem::path(FACESYNTH_DEFAULT_DATA_DIR) / "sfm";
        if (std::filesystem::exists(sfm)) {
            try {
                return morph::load_model(sfm.string());
            } catch (const std::exception& e) {
                std::fprintf(stderr, "bench_fit: %s; using the built-in model\n", e.what());
            }
        }
        return morph::load_model("builtin");
    }();
    return model;
}

fit::FitOptions five_iterations(fit::JawMode jaw) {
    fit::FitOptions o;
    o.iterations = 5;
    o.convergence_px = -1;  // never stop early: always 5 rounds
    o.jaw = jaw;
    return o;
}

void run_linear(benchmark::State& state, fit::JawMode jaw) {
    const morph::MorphableModel& model = bench_model();
    const fit::Fitter fitter(model);
    fit::SyntheticOptions s;
    s.noise_px = 1.0;
    const fit::SyntheticCase c = fit::make_synthetic_case(model, 4242, 0, s);
    const fit::FitOptions o = five_iterations(jaw);
    for (auto _ : state) benchmark::DoNotOptimize(fitter.fit(c.landmarks, o));
    state.SetLabel(model.name + ", " + std::to_string(model.num_shape_components()) + " identity + " +
                   std::to_string(model.num_expression_components()) + " expression components");
}

void BM_LinearFit(benchmark::State& state) { run_linear(state, fit::JawMode::kFixed); }
void BM_LinearFitWithContour(benchmark::State& state) { run_linear(state, fit::JawMode::kContour); }

void BM_RefinedFit(benchmark::State& state) {
    const morph::MorphableModel& model = bench_model();
    const fit::Fitter fitter(model);
    fit::SyntheticOptions s;
    s.noise_px = 1.0;
    const fit::SyntheticCase c = fit::make_synthetic_case(model, 4242, 0, s);
    const fit::FitOptions o = five_iterations(fit::JawMode::kContour);
    fit::RefineOptions r;
    r.intrinsics = c.intrinsics;
    for (auto _ : state) benchmark::DoNotOptimize(fit::fit_and_refine(fitter, c.landmarks, o, r));
    state.SetLabel(model.name + ", linear with contour + Ceres, known focal");
}

void BM_FitterSetup(benchmark::State& state) {
    const morph::MorphableModel& model = bench_model();
    for (auto _ : state) benchmark::DoNotOptimize(fit::Fitter(model));
}

}  // namespace

BENCHMARK(BM_LinearFit)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LinearFitWithContour)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RefinedFit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FitterSetup)->Unit(benchmark::kMillisecond);
