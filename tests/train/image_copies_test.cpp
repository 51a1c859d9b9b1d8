// The moved and degraded copies of training photographs (train/image_copies.h) and where the SDM's rows
// take them (training_rows): the landmarks follow the image, the draws depend on (seed, face, copy) only,
// and neither validation faces nor renders are copied.
#include "train/face_box.h"
#include "train/image_copies.h"
#include "train/sdm.h"

#include "cartoon_faces.h"
#include "core/error.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

namespace facesynth::train {
namespace {

// A black crop with a white disc at each of 68 points on a grid: after the copy, each disc must be
// where the copy says its point is.
TrainingFace dotted_face() {
    TrainingFace face;
    face.crop = cv::Mat(kCanonicalCropSide, kCanonicalCropSide, CV_8UC1, cv::Scalar(0));
    face.truth.resize(2, 68);
    for (int i = 0; i < 68; ++i) {
        face.truth(0, i) = 50.0 + 16.0 * (i % 10) + 0.3 * i / 10.0;
        face.truth(1, i) = 60.0 + 20.0 * (i / 10);
        cv::circle(face.crop, cv::Point(static_cast<int>(std::lround(face.truth(0, i))), static_cast<int>(std::lround(face.truth(1, i)))), 3,
                   cv::Scalar(255), -1, cv::LINE_AA);
    }
    face.box_from_detector = true;
    face.view = FaceView::kNoseLeft;
    face.yaw_deg = -30.0;
    return face;
}

// The brightness-weighted centre of the 9 × 9 window around `p`.
Eigen::Vector2d local_centroid(const cv::Mat& crop, const Eigen::Vector2d& p) {
    double sum = 0, sx = 0, sy = 0;
    const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
    for (int y = cy - 4; y <= cy + 4; ++y)
        for (int x = cx - 4; x <= cx + 4; ++x) {
            const double v = std::max(0, crop.at<uchar>(y, x) - 40);  // above the noise
            sum += v, sx += v * x, sy += v * y;
        }
    return sum > 0 ? Eigen::Vector2d(sx / sum, sy / sum) : Eigen::Vector2d(-100, -100);
}

TEST(ImageCopies, TheLandmarksMoveWithTheImage) {
    const TrainingFace face = dotted_face();
    double largest_move = 0;
    for (int copy = 0; copy < 8; ++copy) {
        const TrainingFace c = moved_and_degraded_copy(face, 7, 3, copy);
        ASSERT_EQ(c.crop.type(), CV_8UC1);
        ASSERT_EQ(c.crop.rows, kCanonicalCropSide);
        ASSERT_EQ(c.truth.cols(), 68);
        EXPECT_FALSE(c.box_from_detector);  // not the detector's box any more
        EXPECT_EQ(c.view, FaceView::kNoseLeft);
        EXPECT_EQ(c.yaw_deg, -30.0);
        for (int i = 0; i < 68; ++i) {
            const Eigen::Vector2d at = c.truth.col(i);
            EXPECT_LT((local_centroid(c.crop, at) - at).norm(), 0.6) << "copy " << copy << " point " << i;
        }
        largest_move = std::max(largest_move, (c.truth - face.truth).colwise().norm().maxCoeff());
    }
    EXPECT_GT(largest_move, 4.0);  // the copies are moved, not only degraded
}

TEST(ImageCopies, DependOnSeedFaceAndCopyOnly) {
    const auto faces = testkit::cartoon_training_faces(4, 2);
    const TrainingFace a = moved_and_degraded_copy(faces[0], 5, 1, 2);
    const TrainingFace again = moved_and_degraded_copy(faces[0], 5, 1, 2);
    EXPECT_EQ(cv::norm(a.crop, again.crop, cv::NORM_INF), 0);
    EXPECT_EQ((a.truth - again.truth).cwiseAbs().maxCoeff(), 0);
    for (const auto& other : {moved_and_degraded_copy(faces[0], 5, 1, 3), moved_and_degraded_copy(faces[0], 6, 1, 2),
                              moved_and_degraded_copy(faces[0], 5, 2, 2)})
        EXPECT_GT((a.truth - other.truth).cwiseAbs().maxCoeff(), 0.01);
    EXPECT_THROW((void)moved_and_degraded_copy(faces[0], 5, 1, -1), core::Error);
    TrainingFace colour = faces[0];
    cv::cvtColor(faces[0].crop, colour.crop, cv::COLOR_GRAY2RGB);
    EXPECT_THROW((void)moved_and_degraded_copy(colour, 5, 1, 0), core::Error);
}

bool same_face(const TrainingFace& a, const TrainingFace& b) {
    return cv::norm(a.crop, b.crop, cv::NORM_INF) == 0 && (a.truth - b.truth).cwiseAbs().maxCoeff() == 0;
}

TEST(ImageCopies, TrainOnlyThePhotographsThatAreNotHeldOut) {
    std::vector<TrainingFace> faces = testkit::cartoon_training_faces(11, 20);
    for (int f : {0, 1, 2, 3, 4}) faces[static_cast<std::size_t>(f)].photograph = false;  // renders
    SdmTrainOptions options;
    options.validation_share = 0.25;  // faces 3, 7, 11, 15, 19 held out
    options.image_copies = 2;
    options.seed = 9;
    const TrainingRows rows = training_rows(faces, options);
    EXPECT_EQ(rows.validation, (std::vector<std::size_t>{3, 7, 11, 15, 19}));
    const std::vector<std::size_t> photographs = {5, 6, 8, 9, 10, 12, 13, 14, 16, 17, 18};
    ASSERT_EQ(rows.train.size(), 15 + 2 * photographs.size());
    const auto all = rows.faces(faces);
    for (std::size_t k = 0; k < 15; ++k) EXPECT_LT(rows.train[k], faces.size());
    for (std::size_t copy = 0; copy < 2; ++copy)
        for (std::size_t k = 0; k < photographs.size(); ++k) {
            const std::size_t row = rows.train[15 + copy * photographs.size() + k];
            EXPECT_TRUE(same_face(all[row], moved_and_degraded_copy(faces[photographs[k]], 9, photographs[k], static_cast<int>(copy))))
                << "copy " << copy << " of face " << photographs[k];
        }

    // The same rows with any thread count; one copy is the first of two.
    options.threads = 3;
    const TrainingRows threaded = training_rows(faces, options);
    ASSERT_EQ(threaded.train, rows.train);
    for (std::size_t row : rows.train) EXPECT_TRUE(same_face(threaded.faces(faces)[row], all[row])) << row;
    options.image_copies = 1;
    const TrainingRows one = training_rows(faces, options);
    ASSERT_EQ(one.train.size(), 15 + photographs.size());
    for (std::size_t k = 15; k < one.train.size(); ++k) EXPECT_TRUE(same_face(one.faces(faces)[one.train[k]], all[rows.train[k]])) << k;

    // Mirrors come first and are not copied.
    options.mirror = true;
    const TrainingRows mirrored = training_rows(faces, options);
    EXPECT_EQ(mirrored.train.size(), 15 + 15 + photographs.size());
    options.image_copies = kMaxImageCopies + 1;
    EXPECT_THROW((void)training_rows(faces, options), core::Error);
}

// A cascade trained with copies still learns: its held-out error falls stage by stage.
TEST(ImageCopies, ACascadeTrainedWithCopiesStillGeneralises) {
    const auto train = testkit::cartoon_training_faces(12, 30);
    SdmTrainOptions options;
    options.augment = 2;
    options.stages = 2;
    options.threads = 2;
    options.image_copies = 2;
    std::vector<SdmStageReport> reports;
    options.on_stage = [&](const SdmStageReport& r) { reports.push_back(r); };
    const SdmModel model = train_sdm(train, BoxStatistics{}, options);
    EXPECT_EQ(model.training_faces, train.size());
    ASSERT_EQ(reports.size(), 2u);
    for (const auto& r : reports) EXPECT_LT(r.validation_nme_after, r.validation_nme_before) << "stage " << r.stage;
}

}  // namespace
}  // namespace facesynth::train
