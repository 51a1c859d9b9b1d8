// fit/dataset_eval.h: reading synth meta JSON, seeded landmark noise, per-yaw-bin summaries.
#include "fit/dataset_eval.h"

#include "common/test_data.h"
#include "common/toy_model.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/pose.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace facesynth::fit {
namespace {

namespace fs = std::filesystem;

nlohmann::json points(const Eigen::Matrix2Xd& p) {
    nlohmann::json a = nlohmann::json::array();
    for (Eigen::Index i = 0; i < p.cols(); ++i) a.push_back({p(0, i), p(1, i)});  // NaN is written as null
    return a;
}

// A meta JSON in the synth layout (docs/synth.md) for a synthetic case of `model`.
nlohmann::json meta_of(const morph::MorphableModel& model, const SyntheticCase& c, int index) {
    nlohmann::json rotation = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) rotation.push_back({c.truth.rotation(r, 0), c.truth.rotation(r, 1), c.truth.rotation(r, 2)});
    const auto& k = c.intrinsics;
    const std::vector<int> visible(morph::kNumIbugLandmarks, 1);
    return {{"key", "s" + std::to_string(index)}, {"index", index}, {"seed", 1}, {"model_name", model.name},
            {"model_checksum", model.checksum()}, {"alpha", c.truth.alpha}, {"psi", c.psi}, {"rotation", rotation},
            {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"width", k.width}, {"height", k.height}}},
            {"landmarks_fixed", points(c.landmarks)}, {"landmarks_contour", points(c.landmarks)},
            {"visibility_fixed", visible}, {"visibility_contour", visible}};
}

fs::path write(const fs::path& path, const nlohmann::json& j) {
    std::ofstream(path) << j.dump();
    return path;
}

TEST(DatasetEval, ReadsAMetaFileAndFitsItLikeTheInMemoryCase) {
    morph::MorphableModel model = testkit::make_toy_model();
    model.shape.eigenvalues *= 100.0f;
    const Fitter fitter(model);
    const auto dir = testkit::fresh_temp_dir("fit_dataset_eval");
    const SyntheticCase c = make_synthetic_case(model, 5, 3);
    const DatasetSample s = read_sample_meta(write(dir / "s3.json", meta_of(model, c, 3)));
    EXPECT_EQ(s.index, 3);
    EXPECT_EQ(s.model_checksum, model.checksum());
    EXPECT_DOUBLE_EQ(s.intrinsics.fx, c.intrinsics.fx);
    EXPECT_TRUE(s.truth.rotation.isApprox(c.truth.rotation, 1e-12));

    DatasetEvalOptions o;
    o.eval.fit.jaw = JawMode::kFixed;
    const FitMetrics from_file = evaluate_dataset_sample(fitter, s, o);
    const FitMetrics direct = evaluate_fit(fitter, c.landmarks, c.truth, o.eval);
    EXPECT_NEAR(from_file.vertex_rmse_mm, direct.vertex_rmse_mm, 1e-9);
    EXPECT_NEAR(from_file.yaw_error_deg, direct.yaw_error_deg, 1e-9);
    EXPECT_NEAR(from_file.truth.yaw, morph::euler_from_rotation(c.truth.rotation).yaw, 1e-9);
    EXPECT_LT(from_file.vertex_rmse_mm, from_file.vertex_rmse_mm_meanshape);
}

TEST(DatasetEval, NoiseIsSeededPerSampleAndIndependentOfTheMode) {
    DatasetSample s;
    s.index = 7;
    s.landmarks_fixed = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks);
    s.landmarks_contour = s.landmarks_fixed;
    DatasetEvalOptions o;
    o.noise_px = 2;
    o.noise_seed = 42;
    const Eigen::Matrix2Xd a = dataset_sample_landmarks(s, o);
    EXPECT_TRUE(a.isApprox(dataset_sample_landmarks(s, o)));
    EXPECT_NEAR(std::sqrt(a.squaredNorm() / static_cast<double>(a.size())), 2.0, 0.5);
    o.eval.fit.jaw = JawMode::kContour;
    EXPECT_TRUE(a.isApprox(dataset_sample_landmarks(s, o)));
    s.index = 8;
    EXPECT_FALSE(a.isApprox(dataset_sample_landmarks(s, o)));
    o.noise_px = 0;
    EXPECT_TRUE(dataset_sample_landmarks(s, o).isZero());
}

TEST(DatasetEval, BadMetaFilesNameTheFileAndTheKey) {
    const morph::MorphableModel model = testkit::make_toy_model();
    const auto dir = testkit::fresh_temp_dir("fit_dataset_eval_bad");
    const nlohmann::json good = meta_of(model, make_synthetic_case(model, 5, 0), 0);
    auto error_of = [&](const fs::path& path) {
        try {
            (void)read_sample_meta(path);
        } catch (const core::Error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    nlohmann::json missing = good;
    missing.erase("landmarks_contour");
    std::string e = error_of(write(dir / "missing.json", missing));
    EXPECT_NE(e.find("missing.json"), std::string::npos) << e;
    EXPECT_NE(e.find("landmarks_contour"), std::string::npos) << e;
    nlohmann::json short_points = good;
    short_points["landmarks_fixed"].erase(0);
    e = error_of(write(dir / "short.json", short_points));
    EXPECT_NE(e.find("landmarks_fixed"), std::string::npos) << e;
    {
        std::ofstream(dir / "truncated.json") << good.dump().substr(0, 100);
    }
    e = error_of(dir / "truncated.json");
    EXPECT_NE(e.find("truncated.json"), std::string::npos) << e;
    e = error_of(dir / "absent.json");
    EXPECT_NE(e.find("absent.json"), std::string::npos) << e;
    EXPECT_THROW((void)read_dataset_manifest(dir), core::Error);  // no manifest.jsonl
    std::ofstream(dir / "manifest.jsonl") << R"({"index": 0, "key": "s0", "meta": "meta/s0.json"})" << "\nnot json\n";
    e = "no error";
    try {
        (void)read_dataset_manifest(dir);
    } catch (const core::Error& x) {
        e = x.what();
    }
    EXPECT_NE(e.find("manifest.jsonl:2"), std::string::npos) << e;
}

TEST(DatasetEval, YawBinsCoverTheRangeAndClampOutliers) {
    YawBinnedSummary summary(60);
    ASSERT_EQ(summary.bins.size(), 8u);
    EXPECT_EQ(summary.prefix(0), "yaw_-60_-45_");
    EXPECT_EQ(summary.label(7), "[45,60)");
    for (double yaw : {-75.0, -59.0, -45.0, 0.0, 59.9, 80.0}) {
        FitMetrics m;
        m.truth.yaw = yaw;
        m.vertex_rmse_mm = 2;
        summary.add(m);
    }
    EXPECT_EQ(summary.all.count, 6);
    EXPECT_EQ(summary.bins[0].count, 2);  // -75 clamped, -59
    EXPECT_EQ(summary.bins[1].count, 1);  // -45
    EXPECT_EQ(summary.bins[4].count, 1);  // 0
    EXPECT_EQ(summary.bins[7].count, 2);  // 59.9, 80 clamped
    nlohmann::json j;
    summary.write(j);
    EXPECT_EQ(j["count"].get<int>(), 6);
    EXPECT_DOUBLE_EQ(j["vertex_rmse_mm"].get<double>(), 2.0);
    EXPECT_EQ(j["yaw_-15_0_count"].get<int>(), 0);
    EXPECT_DOUBLE_EQ(j["yaw_-15_0_vertex_rmse_mm"].get<double>(), 0.0);
    EXPECT_EQ(YawBinnedSummary(90).bins.size(), 12u);
}

}  // namespace
}  // namespace facesynth::fit
