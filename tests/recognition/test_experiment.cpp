// The recognition experiment on a tiny set: it runs, its numbers are rates, it is deterministic,
// and near-frontal probes are told apart better than chance by both representations.
#include "fit/recognition/experiment.h"
#include "morph/builtin.h"
#include "morph/error.h"

#include <gtest/gtest.h>

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
    const facesynth::MorphableModel model = facesynth::builtin_model();
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
    EXPECT_THROW((void)run_experiment(facesynth::builtin_model(), o), facesynth::Error);
}

}  // namespace
