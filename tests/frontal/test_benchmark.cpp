// The frontalisation benchmark as a library call (frontal/benchmark.h): its bins, its hook for found
// landmarks, its JSON keys and its determinism.
#include "frontal/benchmark.h"
#include "core/error.h"
#include "morph/builtin.h"
#include "common/test_data.h"

#include <gtest/gtest.h>

#include <cmath>

namespace facesynth::frontal {
namespace {

BenchmarkOptions small_benchmark() {
    BenchmarkOptions o;
    o.count = 1;
    o.isomap_size = 128;
    o.size = 96;
    o.view.size = 128;
    o.detection_framing = 1.5;  // the standard view: the finder sees what the truth run sees
    return o;
}

TEST(FrontalBenchmark, EveryYawBinHasOneViewPerIdentityAndFiniteScores) {
    const morph::MorphableModel& model = morph::builtin_model();
    int identities = 0;
    const BenchmarkResult r = run_benchmark(model, small_benchmark(), [&] { ++identities; });
    EXPECT_EQ(identities, 1);
    EXPECT_FALSE(r.has_detected);
    for (const ViewScores& bin : r.truth) {
        ASSERT_EQ(bin.count, 1);
        EXPECT_TRUE(std::isfinite(bin.psnr) && bin.psnr > 0) << bin.psnr;
        EXPECT_GT(bin.psnr_mirror, 20);  // the unseen side filled from the seen one: close to the truth
        EXPECT_GE(bin.psnr_mirror, bin.psnr);
        EXPECT_GT(bin.isomap_coverage_mirror, bin.isomap_coverage - 1e-9);  // mirror filling only adds texels
    }
    // Without the mirror, the unseen far side (black) lowers the score as the face turns.
    EXPECT_GT(r.truth.front().psnr, r.truth.back().psnr);
    EXPECT_EQ(r.truth_all().count, kYawBins);
}

TEST(FrontalBenchmark, FoundLandmarksEqualToTheTruthScoreAsTheTruthAndMissesAreCounted) {
    const morph::MorphableModel& model = morph::builtin_model();
    const BenchmarkOptions o = small_benchmark();
    const BenchmarkResult exact = run_benchmark(model, o, {}, [](const cv::Mat&, const Eigen::Matrix2Xd& truth) {
        return std::optional<Eigen::Matrix2Xd>(truth);
    });
    ASSERT_TRUE(exact.has_detected);
    EXPECT_EQ(exact.detector_misses_all(), 0);
    for (int b = 0; b < kYawBins; ++b) {
        const auto bin = static_cast<std::size_t>(b);
        EXPECT_DOUBLE_EQ(exact.detected[bin].psnr, exact.truth[bin].psnr) << yaw_bin_label(b);
    }
    const BenchmarkResult missed = run_benchmark(model, o, {}, [](const cv::Mat&, const Eigen::Matrix2Xd&) {
        return std::optional<Eigen::Matrix2Xd>{};
    });
    EXPECT_EQ(missed.detector_misses_all(), kYawBins);
    EXPECT_EQ(missed.detected_all().count, 0);
    const nlohmann::json j = to_json(missed, o, model);
    EXPECT_EQ(j.at("detector_misses"), kYawBins);
    EXPECT_EQ(j.at("detected_all_count"), 0);
    EXPECT_FALSE(j.contains("detected_all_psnr"));  // an empty set has only its count
    EXPECT_DOUBLE_EQ(j.at("all_psnr").get<double>(), missed.truth_all().mean().psnr);
    EXPECT_DOUBLE_EQ(j.at("all_psnr").get<double>(), to_json(exact, o, model).at("all_psnr").get<double>());  // deterministic
}

TEST(FrontalBenchmark, RefusesAModelWithoutSymmetryAndADetectionFramingBelowTheViewsNamingThem) {
    morph::MorphableModel model = morph::builtin_model();
    BenchmarkOptions o = small_benchmark();
    o.detection_framing = 1.2;
    const LandmarkFinder finder = [](const cv::Mat&, const Eigen::Matrix2Xd& truth) { return std::optional<Eigen::Matrix2Xd>(truth); };
    EXPECT_NE(testkit::error_message_of([&] { (void)run_benchmark(model, o, {}, finder); }).find("--detection-framing"), std::string::npos);
    model.symmetry.clear();
    EXPECT_NE(testkit::error_message_of([&] { (void)run_benchmark(model, small_benchmark()); }).find("no symmetry map"), std::string::npos);
}

}  // namespace
}  // namespace facesynth::frontal
