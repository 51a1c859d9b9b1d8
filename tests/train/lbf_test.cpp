#include "train/lbf_baseline.h"

#include "cartoon_faces.h"
#include "common/test_data.h"
#include "core/error.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

namespace facesynth::train {
namespace {

using testkit::cartoon_training_faces;

// A forest small enough to train in about a second on 40 cartoon faces.
LbfTrainOptions small_forest() {
    LbfTrainOptions options;
    options.augment = 2;
    options.stages = 2;
    options.trees = 3;
    options.depth = 4;
    options.features = {100, 100};
    options.radii = {0.3, 0.2};
    return options;
}

double mean_nme(const LbfPredictor& predictor, const std::vector<TrainingFace>& faces) {
    double sum = 0;
    for (const auto& face : faces) sum += landmark_nme(predictor.predict(face.crop), face.truth);
    return sum / static_cast<double>(faces.size());
}

std::string read_text(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

void write_text(const std::filesystem::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

TEST(Lbf, BeatsTheMeanShapeOnHeldOutFacesAndTheFileRoundTrips) {
    const auto train = cartoon_training_faces(11, 40);
    const auto test = cartoon_training_faces(12, 15);
    const auto model = testkit::fresh_temp_dir("lbf_train") / "model.yaml";
    const LbfTrainReport report = train_lbf(train, small_forest(), model);
    EXPECT_EQ(report.faces_used, 40);
    EXPECT_EQ(report.faces_outside_box, 0);
    EXPECT_LT(report.train_nme_final, 0.7 * report.train_nme_initial);

    const LbfPredictor predictor(model);
    // The loaded model predicts what the trained one did on the training faces.
    EXPECT_NEAR(mean_nme(predictor, train), report.train_nme_final, 1e-9);

    Eigen::Matrix2Xd mean = Eigen::Matrix2Xd::Zero(2, 68);
    for (const auto& face : train) mean += face.truth / static_cast<double>(train.size());
    double mean_shape_nme = 0;
    for (const auto& face : test) mean_shape_nme += landmark_nme(mean, face.truth) / static_cast<double>(test.size());
    const double lbf_nme = mean_nme(predictor, test);
    EXPECT_LT(lbf_nme, 0.5 * mean_shape_nme) << "mean shape " << mean_shape_nme << ", LBF " << lbf_nme;
}

TEST(Lbf, FacesFailingOpenCVsBoxTestAreCountedNotSilentlyDropped) {
    auto train = cartoon_training_faces(13, 12);
    train[3].truth.row(0).array() += 200.0;  // centre far right of the canonical box
    const auto model = testkit::fresh_temp_dir("lbf_box") / "model.yaml";
    LbfTrainOptions options = small_forest();
    options.stages = 1;
    const LbfTrainReport report = train_lbf(train, options, model);
    EXPECT_EQ(report.faces_used, 11);
    EXPECT_EQ(report.faces_outside_box, 1);
}

TEST(Lbf, BadOptionsAreRefusedBeforeTraining) {
    const auto train = cartoon_training_faces(14, 4);
    const auto out = testkit::fresh_temp_dir("lbf_options") / "model.yaml";
    LbfTrainOptions options = small_forest();
    options.stages = 3;  // two features and radii for three stages
    EXPECT_THROW(train_lbf(train, options, out), core::Error);
    options = small_forest();
    options.depth = 1;
    EXPECT_THROW(train_lbf(train, options, out), core::Error);
    EXPECT_THROW(train_lbf(std::span<const TrainingFace>(train.data(), 1), small_forest(), out), core::Error);
    EXPECT_FALSE(std::filesystem::exists(out));
}

void expect_error_naming(const std::filesystem::path& path, const std::string& problem) {
    try {
        const LbfPredictor predictor(path);
        ADD_FAILURE() << "no error for " << path << " (" << problem << ")";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(problem), std::string::npos) << e.what();
    }
}

TEST(Lbf, MissingCorruptAndTruncatedModelFilesGiveErrorsNamingTheFile) {
    const auto dir = testkit::fresh_temp_dir("lbf_corrupt");
    const auto model = dir / "model.yaml";
    LbfTrainOptions options = small_forest();
    options.stages = 1;
    (void)train_lbf(cartoon_training_faces(15, 8), options, model);
    const std::string text = read_text(model);

    expect_error_naming(dir / "absent.yaml", "not found");
    write_text(dir / "garbage.yaml", "\x89PNG not a model at all {{{");
    expect_error_naming(dir / "garbage.yaml", "not an OpenCV LBF model");
    write_text(dir / "empty.yaml", "%YAML:1.0\n---\n");
    expect_error_naming(dir / "empty.yaml", "stages_n");
    write_text(dir / "truncated.yaml", text.substr(0, text.size() / 2));
    expect_error_naming(dir / "truncated.yaml", "not an OpenCV LBF model");
    std::string five_landmarks = text;
    const auto at = five_landmarks.find("n_landmarks: 68");
    ASSERT_NE(at, std::string::npos);
    five_landmarks.replace(at, 15, "n_landmarks: 5");
    write_text(dir / "landmarks.yaml", five_landmarks);
    expect_error_naming(dir / "landmarks.yaml", "n_landmarks");
}

}  // namespace
}  // namespace facesynth::train
