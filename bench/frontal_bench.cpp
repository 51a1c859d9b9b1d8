// Frontalisation speed per stage (issue 7 target: fit + 512² isomap + 256² frontal render under 15 ms
// per face, single thread). Run with LP_NUM_THREADS=0 so that llvmpipe renders on the calling thread:
// Google Benchmark's CPU time is the main thread's. Uses the built-in model, or the model that
// FACESYNTH_BENCH_MODEL names (e.g. ../shared/data/sfm). Posed renders of 8 identities at yaws within
// ±60°, cycled through, so that no stage sees one face only.
#include "frontal/evaluate.h"
#include "frontal/frontalise.h"
#include "morph/jaw_contour.h"
#include "morph/model_io.h"
#include "core/random.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>
#include <vector>

namespace {

using namespace facesynth;

struct Scene {
    morph::MorphableModel model;
    std::unique_ptr<frontal::Frontaliser> frontaliser;
    std::vector<frontal::SyntheticView> views;
    std::vector<frontal::Frontalisation> results;  // each view frontalised once: the stages' inputs
    frontal::FrontaliseOptions options;
};

Scene& scene() {
    static Scene s = [] {
        Scene scene;
        const char* path = std::getenv("FACESYNTH_BENCH_MODEL");
        scene.model = morph::load_model(path ? path : "builtin");
        scene.frontaliser = std::make_unique<frontal::Frontaliser>(scene.model);
        const morph::JawContourRegion region = morph::jaw_contour_region(scene.model);
        constexpr std::uint64_t kSeed = 77;
        constexpr int kFaces = 8;
        for (int i = 0; i < kFaces; ++i) {
            const frontal::TexturedFace face =
                frontal::make_textured_face(scene.model, *scene.frontaliser, kSeed, static_cast<std::uint64_t>(i), scene.options.isomap.size);
            core::Rng rng = core::make_rng(kSeed, static_cast<std::uint64_t>(i), core::RandomStream::kPose);
            scene.views.push_back(frontal::render_view(scene.frontaliser->renderer(), scene.model, face, rng.uniform(-60, 60), {}, &region));
            scene.results.push_back(scene.frontaliser->frontalise(scene.views.back().image, scene.views.back().landmarks, scene.options));
        }
        return scene;
    }();
    return s;
}

void label(benchmark::State& state) {
    const Scene& s = scene();
    state.SetLabel(s.model.name + ", " + std::to_string(s.model.num_vertices()) + " vertices");
}

void BM_Fit(benchmark::State& state) {
    Scene& s = scene();
    std::size_t i = 0;
    for (auto _ : state) {
        const frontal::SyntheticView& view = s.views[i++ % s.views.size()];
        benchmark::DoNotOptimize(s.frontaliser->fitter().fit(view.landmarks, s.options.fit));
    }
    label(state);
}

void BM_FittedShape(benchmark::State& state) {
    Scene& s = scene();
    std::size_t i = 0;
    for (auto _ : state) benchmark::DoNotOptimize(fit::fitted_shape(s.model, s.results[i++ % s.results.size()].fit));
    label(state);
}

void BM_Isomap(benchmark::State& state) {
    Scene& s = scene();
    std::size_t i = 0;
    for (auto _ : state) {
        const std::size_t k = i++ % s.views.size();
        const frontal::Frontalisation& r = s.results[k];
        benchmark::DoNotOptimize(s.frontaliser->extract_isomap(s.views[k].image, r.vertices, {r.fit.camera, r.fit.pose}, s.options.isomap));
    }
    label(state);
}

void BM_FrontalRender(benchmark::State& state) {
    Scene& s = scene();
    std::size_t i = 0;
    for (auto _ : state) {
        const frontal::Frontalisation& r = s.results[i++ % s.results.size()];
        benchmark::DoNotOptimize(s.frontaliser->render_frontal(r.vertices, r.isomap, s.options.frontal));
    }
    label(state);
}

void BM_Frontalise(benchmark::State& state) {
    Scene& s = scene();
    std::size_t i = 0;
    for (auto _ : state) {
        const frontal::SyntheticView& view = s.views[i++ % s.views.size()];
        benchmark::DoNotOptimize(s.frontaliser->frontalise(view.image, view.landmarks, s.options));
    }
    label(state);
}

}  // namespace

BENCHMARK(BM_Fit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FittedShape)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Isomap)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrontalRender)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Frontalise)->Unit(benchmark::kMillisecond);
