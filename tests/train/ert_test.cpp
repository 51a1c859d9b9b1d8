// dlib's ERT trainer as our baseline: trained on canonical crops with the canonical box, run through
// the `ert:` regressor on image boxes, it must learn (beat the mean shape on held-out faces), and the
// same seed and thread count must give the same model, so that a baseline can be trained again.
#include "train/dlib_baseline.h"
#include "train/regressor.h"

#include "cartoon_faces.h"
#include "common/test_data.h"
#include "core/error.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

namespace facesynth::train {
namespace {

using testkit::cartoon_training_faces;

// Small enough to train in about a second on 40 cartoon faces.
ErtTrainOptions small_ert(int threads) {
    ErtTrainOptions options;
    options.threads = threads;
    options.oversampling = 4;
    options.cascade_depth = 4;
    options.tree_depth = 3;
    options.trees_per_level = 40;
    return options;
}

std::string read_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(Ert, BeatsTheMeanShapeOnHeldOutFacesThroughTheRegressorSpec) {
    const auto train = cartoon_training_faces(31, 40);
    const auto test = cartoon_training_faces(32, 15);
    const auto model = testkit::fresh_temp_dir("ert_train") / "ert.dat";
    train_dlib_ert(train, small_ert(1), model);

    const auto regressor = open_regressor("ert:" + model.string());
    EXPECT_EQ(regressor->label(), "ert:" + model.string());
    EXPECT_FALSE(regressor->trained_detector().has_value());  // the dlib file records no detector
    Eigen::Matrix2Xd mean = Eigen::Matrix2Xd::Zero(2, 68);
    for (const auto& face : train) mean += face.truth / static_cast<double>(train.size());
    double mean_shape_nme = 0, ert_nme = 0;
    // The test crops are canonical crops, so the canonical box is the image box and the
    // regressor's crop of it is the identity.
    for (const auto& face : test) {
        mean_shape_nme += landmark_nme(mean, face.truth) / static_cast<double>(test.size());
        ert_nme += landmark_nme(regressor->predict(face.crop, canonical_face_box()), face.truth) / static_cast<double>(test.size());
    }
    RecordProperty("mean_shape_nme", std::to_string(mean_shape_nme));
    RecordProperty("ert_nme", std::to_string(ert_nme));
    EXPECT_LT(ert_nme, 0.5 * mean_shape_nme) << "mean shape " << mean_shape_nme << ", ERT " << ert_nme;
}

// dlib's trainer splits its work differently with more threads, so models differ by thread count
// (measured); with the same thread count and seed they are byte-identical.
TEST(Ert, TheSameSeedAndThreadCountGiveTheSameModel) {
    const auto train = cartoon_training_faces(33, 20);
    const auto dir = testkit::fresh_temp_dir("ert_threads");
    train_dlib_ert(train, small_ert(2), dir / "first.dat");
    train_dlib_ert(train, small_ert(2), dir / "second.dat");
    const std::string first = read_bytes(dir / "first.dat");
    ASSERT_FALSE(first.empty());
    EXPECT_TRUE(first == read_bytes(dir / "second.dat"));
    ErtTrainOptions other_seed = small_ert(2);
    other_seed.seed = 2;
    train_dlib_ert(train, other_seed, dir / "seed2.dat");
    EXPECT_FALSE(first == read_bytes(dir / "seed2.dat"));
    train_dlib_ert(train, small_ert(1), dir / "one_thread.dat");
    RecordProperty("same_as_one_thread", first == read_bytes(dir / "one_thread.dat") ? "yes" : "no");
}

TEST(Ert, NoFacesAndBadModelFilesGiveErrors) {
    const auto dir = testkit::fresh_temp_dir("ert_errors");
    EXPECT_THROW(train_dlib_ert({}, small_ert(1), dir / "none.dat"), core::Error);
    EXPECT_FALSE(std::filesystem::exists(dir / "none.dat"));
    std::ofstream(dir / "garbage.dat") << "not a dlib shape predictor";
    try {
        (void)open_regressor("ert:" + (dir / "garbage.dat").string());
        FAIL() << "garbage accepted";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("garbage.dat"), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)open_regressor("ert:" + (dir / "missing.dat").string()), core::Error);
}

}  // namespace
}  // namespace facesynth::train
