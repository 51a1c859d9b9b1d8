// The recognition experiment on a tiny set: it runs, its numbers are rates, it is deterministic,
// and near-frontal probes are told apart better than chance by both representations.
#include "recognition/experiment.h"
#include "morph/builtin.h"
#include "core/error.h"
#include "train/face_box.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace facesynth::recognition;

ExperimentOptions tiny() {
    ExperimentOptions o;
    o.identities = 6;
    o.gallery_yaws = {0};
    o.probe_max_yaw = 20;
    o.image_size = 128;
    o.isomap_size = 128;
    o.frontal_size = 96;
    o.crop.size = 64;
    o.example_identities = 2;
    return o;
}

TEST(RecognitionExperiment, TinySetGivesRatesBetterThanChanceAndIsDeterministic) {
    const facesynth::morph::MorphableModel model = facesynth::morph::builtin_model();
    const ExperimentResult a = run_experiment(model, tiny());
    ASSERT_EQ(a.bins.size(), 2u);  // gallery 0 x probe bins [0,10), [10,20)
    EXPECT_EQ(a.images, 6 * 3);
    EXPECT_EQ(a.failed_frontalisations, 0);
    for (const BinScores& bin : a.bins) {
        EXPECT_EQ(bin.org.genuine.size(), 6u);
        EXPECT_EQ(bin.org.impostor.size(), 30u);
        EXPECT_EQ(bin.lm.impostor.size(), 30u);
        for (const MatchScores* s : {&bin.org, &bin.lm}) {
            const double frr = frr_at_far(*s, 0.01);
            EXPECT_GE(frr, 0.0);
            EXPECT_LE(frr, 1.0);
        }
    }
    // Near-frontal probes against the frontal gallery: genuine pairs closer than impostors.
    EXPECT_GT(separation_auc(a.bins[0].org), 0.5);
    EXPECT_GT(separation_auc(a.bins[0].lm), 0.5);
    EXPECT_EQ(a.examples.rows, 2 * 2 * 64);
    EXPECT_EQ(a.examples.cols, 3 * 64);

    const ExperimentResult b = run_experiment(model, tiny());
    EXPECT_EQ(a.bins[1].lm.genuine, b.bins[1].lm.genuine);
    EXPECT_EQ(a.bins[1].org.impostor, b.bins[1].org.impostor);
}

TEST(RecognitionExperiment, RefusesSetsWithoutImpostors) {
    ExperimentOptions o = tiny();
    o.identities = 1;
    EXPECT_THROW((void)run_experiment(facesynth::morph::builtin_model(), o), facesynth::core::Error);
}


// Probes frontalised from found landmarks: the real multi-view face detector on the probes' wider
// views, with the true landmarks standing in for a regressor's where it finds the face (a trained
// regressor is not part of the test data). Probes at 60-70° that the detector misses must count as
// rejected genuine pairs, with the pair counts of the other columns.
TEST(RecognitionExperiment, DetectedLandmarkProbesCountDetectorMissesAsRejected) {
    const facesynth::morph::MorphableModel model = facesynth::morph::builtin_model();
    ExperimentOptions o = tiny();
    o.identities = 4;
    o.probe_bin_width = 30;
    o.probe_max_yaw = 90;  // bins [0,30), [30,60), [60,90): the last one beyond the cascades' reach
    o.image_size = 160;
    const facesynth::train::FaceDetector detector(facesynth::train::DetectorKind::kMultiView);
    int asked = 0, found = 0;
    const LandmarkFinder finder = [&](const cv::Mat& image, const Eigen::Matrix2Xd& truth) -> std::optional<Eigen::Matrix2Xd> {
        ++asked;
        EXPECT_GT(image.cols, o.image_size);  // the wider view with context
        if (!facesynth::train::match_detection(detector.detect(facesynth::train::to_gray8(image)), truth)) return std::nullopt;
        ++found;
        return truth;
    };
    const ExperimentResult r = run_experiment(model, o, {}, finder);
    ASSERT_TRUE(r.detected);
    ASSERT_EQ(r.bins.size(), 3u);
    EXPECT_EQ(asked, 4 * 3);  // every probe, never a gallery image
    EXPECT_EQ(r.detector_misses, asked - found);
    int misses = 0;
    for (const BinScores& bin : r.bins) {
        misses += bin.detector_misses;
        EXPECT_EQ(bin.lm_detected.genuine.size(), bin.lm.genuine.size());
        EXPECT_EQ(bin.lm_detected.impostor.size(), bin.lm.impostor.size());
        int rejected = 0;
        for (double d : bin.lm_detected.genuine) rejected += std::isinf(d);
        EXPECT_EQ(rejected, bin.detector_misses);
        if (bin.detector_misses == static_cast<int>(bin.lm.genuine.size())) {
            EXPECT_EQ(frr_at_far(bin.lm_detected, 0.01), 1.0);
        }
    }
    EXPECT_EQ(misses, r.detector_misses);
    EXPECT_GT(found, 0);                      // near-frontal probes are found
    EXPECT_GT(r.bins[2].detector_misses, 0);  // and some beyond 60° are not
    // Where the face is found, the probe is the same face seen with more context: it matches as
    // well as the standard probe does.
    EXPECT_GT(separation_auc(r.bins[0].lm_detected), 0.5);
}

}  // namespace
