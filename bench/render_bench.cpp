// Benchmarks of render/: one render (draw + read-back) of small and real meshes. Run: build/bench/bench_render.
// The CPU column is the figure to trust on a shared machine.
#include "morph/model_io.h"
#include "morph/pose.h"
#include "render/landmarks.h"
#include "render/renderer.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

namespace {

using namespace facesynth;

render::Camera camera_for(int size, double yaw) {
    render::Camera camera;
    camera.intrinsics = morph::intrinsics_from_fov(30.0, size, size);
    camera.pose.rotation = morph::rotation_from_euler({yaw, 0.0, 0.0});
    camera.pose.translation = Eigen::Vector3d(0, 0, 600.0);
    return camera;
}

morph::Mesh one_triangle() {
    morph::Mesh mesh;
    mesh.vertices.resize(3, 3);
    mesh.vertices << -50, 50, 0, -50, -50, 50, 0, 0, 0;
    mesh.triangles = {morph::Triangle{0, 1, 2}};
    return mesh;
}

void run(benchmark::State& state, const morph::Mesh& mesh, int size, bool geometry, int msaa) {  // msaa: samples, 0 = none
    render::Renderer renderer({render::Backend::kAuto, false});
    render::RenderSettings settings;
    settings.geometry = geometry;
    settings.antialiasing = msaa > 1 ? render::Antialiasing::msaa(msaa) : render::Antialiasing::none();
    render::Frame frame;
    const render::Camera camera = camera_for(size, 20.0);
    for (auto _ : state) renderer.render(mesh, camera, settings, frame);
}

void BM_OneTriangle(benchmark::State& state) { run(state, one_triangle(), static_cast<int>(state.range(0)), state.range(1) != 0, 0); }
BENCHMARK(BM_OneTriangle)->Args({64, 0})->Args({64, 1})->Args({256, 0})->Args({256, 1})->Unit(benchmark::kMillisecond);

std::filesystem::path sfm_dir() {
    const char* env = std::getenv("FACESYNTH_DATA");
    return std::filesystem::path(env && *env ? env : FACESYNTH_DEFAULT_DATA_DIR) / "sfm";
}

void BM_Surrey(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    static const morph::Mesh mesh = morph::load_model(sfm_dir().string()).instance({});
    run(state, mesh, static_cast<int>(state.range(0)), state.range(1) != 0, static_cast<int>(state.range(2)));
}
BENCHMARK(BM_Surrey)->Args({64, 0, 0})->Args({256, 0, 0})->Args({256, 1, 0})->Args({256, 1, 4})->Unit(benchmark::kMillisecond);

void BM_Builtin(benchmark::State& state) {
    static const morph::Mesh mesh = morph::load_model("builtin").instance({});
    run(state, mesh, static_cast<int>(state.range(0)), state.range(1) != 0, static_cast<int>(state.range(2)));
}
BENCHMARK(BM_Builtin)->Args({256, 1, 0})->Args({256, 1, 4})->Unit(benchmark::kMillisecond);

// Landmarks of one render (68 points, both jaw modes, outline visibility) at yaw 60, without the render.
void BM_ProjectLandmarksSurrey(benchmark::State& state) {
    if (!std::filesystem::exists(sfm_dir())) return state.SkipWithError("no ../shared/data/sfm (set FACESYNTH_DATA)");
    const morph::MorphableModel model = morph::load_model(sfm_dir().string());
    const morph::Mesh mesh = model.instance({});
    const morph::JawContourRegion region = morph::jaw_contour_region(model);
    render::Renderer renderer({render::Backend::kAuto, false});
    render::RenderSettings settings;
    settings.antialiasing = render::Antialiasing::none();
    const render::Camera camera = camera_for(256, 60.0);
    const render::Frame frame = renderer.render(mesh, camera, settings);
    for (auto _ : state) benchmark::DoNotOptimize(render::project_landmarks(model.landmarks, mesh, camera, frame, {}, &region));
}
BENCHMARK(BM_ProjectLandmarksSurrey)->Unit(benchmark::kMicrosecond);

}  // namespace
