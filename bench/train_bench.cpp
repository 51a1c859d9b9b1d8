// Landmark regression speed, single thread, face detector excluded: the SDM cascade (HOG features +
// linear stages, crop included) and the HOG descriptor alone. The cascade is trained here on cartoon
// faces (tests/train/cartoon_faces.h) with the default settings, so its cost is that of a real model
// of the same shape (68 points, 4 stages, 2x2 or 3x3 HOG cells, full or reduced update rank).
#include "train/face_box.h"
#include "train/hog.h"
#include "train/regressor.h"
#include "train/sdm.h"

// Benchmarks link no test library: the cartoon drawing helper is compiled into this program.
#include "train/cartoon_faces.cpp"  // NOLINT(bugprone-suspicious-include)

#include <benchmark/benchmark.h>

#include <map>
#include <utility>
#include <vector>

namespace {

using namespace facesynth::train;

std::vector<TrainingFace> faces(int count) {
    std::vector<TrainingFace> out;
    for (int i = 0; i < count; ++i) {
        const auto cartoon = facesynth::testkit::make_cartoon_face(11, static_cast<std::uint64_t>(i));
        const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
        const FaceFrame frame{FaceBox{(low + high) / 2, (high - low).maxCoeff()}};
        TrainingFace face;
        face.crop = canonical_crop(cartoon.gray, frame);
        face.truth = frame.to_canonical(cartoon.landmarks);
        face.box_from_detector = true;
        out.push_back(std::move(face));
    }
    return out;
}

// Trained once per (HOG cells per patch side, update rank); λ fixed, no validation split.
const SdmModel& model(int hog_cells = 3, int rank = 136) {
    static std::map<std::pair<int, int>, SdmModel> trained;
    auto& m = trained[{hog_cells, rank}];
    if (m.stages.empty()) {
        SdmTrainOptions options;
        options.augment = 2;
        options.hog.cells = hog_cells;
        options.ranks = {rank};
        options.lambda_factors = {3.0};
        options.validation_share = 0;
        m = train_sdm(faces(30), BoxStatistics{}, options);
    }
    return m;
}

void BM_SdmDetectPerFace(benchmark::State& state) {
    const auto cartoon = facesynth::testkit::make_cartoon_face(12, 0, 400);
    const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
    const FaceBox box{(low + high) / 2, (high - low).maxCoeff()};
    const SdmModel& m = model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) benchmark::DoNotOptimize(sdm_detect(m, cartoon.gray, box));
    state.SetLabel("68 points, 4 stages, crop + HOG + regression; args = HOG cells per side, update rank");
}
BENCHMARK(BM_SdmDetectPerFace)
    ->Args({2, 136})
    ->Args({2, 32})
    ->Args({2, 16})
    ->Args({3, 136})
    ->Args({3, 32})
    ->Unit(benchmark::kMillisecond);

// The two parts of the cascade separately: features for all 4 stages, and the 4 linear updates.
void BM_SdmFeaturesAllStages(benchmark::State& state) {
    const SdmModel& m = model(static_cast<int>(state.range(0)));
    const auto face = faces(1)[0];
    Eigen::VectorXf features;
    for (auto _ : state)
        for (const auto& stage : m.stages) {
            features.resize(m.feature_dims(stage.settings));
            sdm_features(face.crop, m.mean_shape, m.hog, stage.settings, m.unit,
                         {features.data(), static_cast<std::size_t>(features.size())});
        }
}
BENCHMARK(BM_SdmFeaturesAllStages)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);

void BM_SdmRegressionAllStages(benchmark::State& state) {
    const SdmModel& m = model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const Eigen::VectorXf features = Eigen::VectorXf::Random(m.feature_dims(SdmStageSettings{}));
    Eigen::VectorXf reduced, delta;
    for (auto _ : state)
        for (const auto& stage : m.stages) {
            reduced.noalias() = stage.weights * features.head(stage.weights.cols());
            delta.noalias() = stage.basis * reduced;
            benchmark::DoNotOptimize(delta.data());
        }
}
BENCHMARK(BM_SdmRegressionAllStages)->Args({2, 136})->Args({2, 32})->Args({3, 136})->Unit(benchmark::kMillisecond);

// Arguments: cell size in pixels, orientations.
void BM_HogPatch(benchmark::State& state) {
    const HogLayout layout{.cells = 3, .orientations = static_cast<int>(state.range(1))};
    const int cell_size = static_cast<int>(state.range(0));
    cv::Mat patch(layout.cells * cell_size + 2, layout.cells * cell_size + 2, CV_8UC1);
    cv::randu(patch, 0, 255);
    std::vector<float> out(static_cast<std::size_t>(layout.dims()));
    for (auto _ : state) {
        compute_hog(patch, layout, cell_size, out);
        benchmark::DoNotOptimize(out.data());
    }
}
BENCHMARK(BM_HogPatch)->Args({5, 4})->Args({8, 4})->Args({8, 9})->Unit(benchmark::kMicrosecond);

void BM_DlibPretrainedPerFace(benchmark::State& state) {
    std::unique_ptr<LandmarkRegressor> dlib;
    try {
        dlib = open_regressor("dlib");
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    const auto cartoon = facesynth::testkit::make_cartoon_face(12, 0, 400);
    const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
    const FaceBox box{(low + high) / 2, (high - low).maxCoeff()};
    for (auto _ : state) benchmark::DoNotOptimize(dlib->predict(cartoon.gray, box));
}
BENCHMARK(BM_DlibPretrainedPerFace)->Unit(benchmark::kMillisecond);

}  // namespace
