// Landmark regression speed, single thread, face detector excluded: the SDM cascade (HOG features +
// linear stages, crop included) and the HOG descriptor alone. The cascade is trained here on cartoon
// faces (tests/train/cartoon_faces.h) with the default settings, so its cost is that of a real model
// of the same shape (68 points, 4 stages, 3x3 HOG cells).
#include "train/face_box.h"
#include "train/hog.h"
#include "train/regressor.h"
#include "train/sdm.h"

// Benchmarks link no test library: the cartoon drawing helper is compiled into this program.
#include "train/cartoon_faces.cpp"  // NOLINT(bugprone-suspicious-include)

#include <benchmark/benchmark.h>

#include <vector>

namespace {

using namespace facesynth::train;

std::vector<TrainingFace> faces(int count) {
    std::vector<TrainingFace> out;
    for (int i = 0; i < count; ++i) {
        const auto cartoon = facesynth::testkit::make_cartoon_face(11, static_cast<std::uint64_t>(i));
        const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
        const FaceFrame frame{FaceBox{(low + high) / 2, (high - low).maxCoeff()}};
        out.push_back({canonical_crop(cartoon.gray, frame), frame.to_canonical(cartoon.landmarks), true});
    }
    return out;
}

// Trained once per HOG cell count (2 or 3 cells per patch side).
const SdmModel& model(int hog_cells = 3) {
    static const auto train = [](int cells) {
        SdmTrainOptions options;
        options.augment = 2;
        options.hog_cells = cells;
        return train_sdm(faces(30), BoxStatistics{}, options);
    };
    static const SdmModel two = train(2), three = train(3);
    return hog_cells == 2 ? two : three;
}

void BM_SdmDetectPerFace(benchmark::State& state) {
    const auto cartoon = facesynth::testkit::make_cartoon_face(12, 0, 400);
    const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
    const FaceBox box{(low + high) / 2, (high - low).maxCoeff()};
    const SdmModel& m = model(static_cast<int>(state.range(0)));
    for (auto _ : state) benchmark::DoNotOptimize(sdm_detect(m, cartoon.gray, box));
    state.SetLabel("68 points, 4 stages, crop + HOG + regression; arg = HOG cells per side");
}
BENCHMARK(BM_SdmDetectPerFace)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);

// The two parts of the cascade separately: features for all 4 stages, and the 4 linear updates.
void BM_SdmFeaturesAllStages(benchmark::State& state) {
    const SdmModel& m = model();
    const auto face = faces(1)[0];
    Eigen::VectorXf features(m.feature_dims());
    for (auto _ : state)
        for (const auto& stage : m.stages)
            sdm_features(face.crop, m.mean_shape, m.hog_cells, stage.settings,
                         {features.data(), static_cast<std::size_t>(features.size())});
}
BENCHMARK(BM_SdmFeaturesAllStages)->Unit(benchmark::kMillisecond);

void BM_SdmRegressionAllStages(benchmark::State& state) {
    const SdmModel& m = model();
    const Eigen::VectorXf features = Eigen::VectorXf::Random(m.feature_dims());
    Eigen::VectorXf delta;
    for (auto _ : state)
        for (const auto& stage : m.stages) {
            delta.noalias() = stage.weights * features;
            benchmark::DoNotOptimize(delta.data());
        }
}
BENCHMARK(BM_SdmRegressionAllStages)->Unit(benchmark::kMillisecond);

void BM_HogPatch(benchmark::State& state) {
    const int cells = 3, cell_size = static_cast<int>(state.range(0));
    cv::Mat patch(cells * cell_size + 2, cells * cell_size + 2, CV_8UC1);
    cv::randu(patch, 0, 255);
    std::vector<float> out(hog_dims(cells));
    for (auto _ : state) {
        compute_hog(patch, cells, cell_size, out);
        benchmark::DoNotOptimize(out.data());
    }
}
BENCHMARK(BM_HogPatch)->Arg(5)->Arg(8)->Unit(benchmark::kMicrosecond);

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
