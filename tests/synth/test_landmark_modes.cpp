// synth's `landmarks.mode = even`: the contour mode's labels with the jaw points respaced evenly along
// the outline (render::space_jaw_evenly), in the labels, the .pts files and the meta files.
#include "common/test_data.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <vector>

namespace facesynth {
namespace {

double step_spread(const Eigen::Matrix2Xd& p, int first, int last) {
    std::vector<double> v;
    for (int i = first; i < last; ++i) v.push_back((p.col(i + 1) - p.col(i)).norm());
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return *hi / *lo;
}

TEST(JawSpacing, SynthEvenModeRespacesTheContourJawOfRenders) {
    const morph::MorphableModel model = morph::load_model("builtin");
    synth::SynthConfig config;
    config.camera.width = config.camera.height = 160;
    synth::apply_override(config, "landmarks.mode=even");
    synth::validate(config);
    const synth::ImageLibrary none;
    synth::SampleGenerator generator(config, model, none, none, render::RendererOptions{render::Backend::kEgl, false});
    for (std::int64_t index = 0; index < 3; ++index) {
        const synth::Sample s = generator.generate(index);
        const auto& even = synth::chosen_landmarks(s.labels, config.landmarks.mode);
        ASSERT_EQ(even.cols(), 68);
        EXPECT_EQ(even.rightCols(51), s.labels.landmarks_contour.rightCols(51)) << "sample " << index;
        for (int i : {0, 8, 16}) EXPECT_EQ(even.col(i), s.labels.landmarks_contour.col(i)) << "sample " << index;
        EXPECT_LT(step_spread(even, 0, 8), step_spread(s.labels.landmarks_contour, 0, 8)) << "sample " << index;
        EXPECT_LT(step_spread(even, 0, 8), 1.15) << "sample " << index;  // chords of equal arcs: equal only where the outline is straight
        EXPECT_EQ(synth::chosen_visibility(s.labels, config.landmarks.mode).size(), 68u);
        EXPECT_EQ(synth::chosen_landmarks_3d(s.labels, config.landmarks.mode).cols(), 68);
    }
}

TEST(JawSpacing, SynthCliWritesEvenLabelsAndTheirMeta) {
    const auto dir = testkit::fresh_temp_dir("synth_even");
    std::string out;
    ASSERT_EQ(testkit::run_command(testkit::cli_path().string() + " synth -q -n 2 --size 128 --seed 4 --set landmarks.mode=even -o " + (dir / "d").string(), &out), 0)
        << out;
    const auto meta = nlohmann::json::parse(std::ifstream(dir / "d" / "meta" / "s00000000.json"));
    EXPECT_EQ(meta["landmark_mode"], "even");
    ASSERT_EQ(meta["landmarks_3d_even"].size(), 68u);
    EXPECT_EQ(meta["landmarks"][30], meta["landmarks_contour"][30]);
    EXPECT_NE(meta["landmarks"][3], meta["landmarks_contour"][3]);
    const auto pts = morph::read_pts(dir / "d" / "landmarks" / "s00000000.pts");
    EXPECT_NEAR(pts(0, 3), meta["landmarks"][3][0].get<double>(), 1e-4);
    EXPECT_EQ(testkit::run_command(testkit::cli_path().string() + " synth -q -n 1 --set landmarks.mode=evenly -o " + (dir / "e").string(), &out), 1) << out;
    EXPECT_NE(out.find("landmarks.mode"), std::string::npos) << out;
}

}  // namespace
}  // namespace facesynth
