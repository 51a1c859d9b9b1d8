// Verification metrics on hand-made distances, where the answers can be counted by hand.
#include "recognition/face_crop.h"
#include "recognition/verification.h"
#include "core/error.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace {

using namespace facesynth::recognition;

TEST(Verification, FrrAtFarCountsByHand) {
    MatchScores s;
    s.genuine = {0.1, 0.2, 0.3, 0.4, 0.9};
    for (int i = 0; i < 100; ++i) s.impostor.push_back(0.35 + 0.01 * i);  // 0.35 .. 1.34
    // FAR 0.01 allows 1 impostor: accept d < 0.36, so 0.4 and 0.9 are rejected.
    EXPECT_DOUBLE_EQ(frr_at_far(s, 0.01), 0.4);
    // FAR 0 allows none: accept d < 0.35.
    EXPECT_DOUBLE_EQ(frr_at_far(s, 0.0), 0.4);
    // FAR 0.06 allows 6: accept d < 0.41.
    EXPECT_DOUBLE_EQ(frr_at_far(s, 0.06), 0.2);
    EXPECT_DOUBLE_EQ(frr_at_far(s, 1.0), 0.0);
}

TEST(Verification, TiesNeverRaiseFarAboveTheTarget) {
    MatchScores s;
    s.genuine = {0.5, 0.5};
    s.impostor = std::vector<double>(10, 0.5);  // every impostor ties with every genuine pair
    EXPECT_DOUBLE_EQ(frr_at_far(s, 0.5), 1.0);  // accepting d < 0.5 accepts nothing
}

TEST(Verification, DetCurveIsMonotoneAndSeparationAucCountsPairs) {
    MatchScores s;
    s.genuine = {0.1, 0.3, 0.6};
    s.impostor = {0.2, 0.4, 0.5, 0.7};
    const auto det = det_curve(s, 10);
    ASSERT_GE(det.size(), 2u);
    for (std::size_t i = 1; i < det.size(); ++i) {
        EXPECT_GT(det[i].far, det[i - 1].far);
        EXPECT_LE(det[i].frr, det[i - 1].frr);
    }
    EXPECT_DOUBLE_EQ(det.back().far, 1.0);
    EXPECT_DOUBLE_EQ(det.back().frr, 0.0);
    // Genuine 0.1 beats 4 impostors, 0.3 beats 3, 0.6 beats 1: 8 of 12 pairs.
    EXPECT_DOUBLE_EQ(separation_auc(s), 8.0 / 12.0);
    EXPECT_THROW((void)frr_at_far(MatchScores{{0.1}, {}}, 0.01), facesynth::core::Error);
}

TEST(FaceCrop, PutsTheEyeCentresWhereAsked) {
    // A white image with two dark discs as eyes, rotated by the landmark geometry.
    cv::Mat image(200, 200, CV_8UC3, cv::Scalar(255, 255, 255));
    Eigen::Matrix2Xd landmarks = Eigen::Matrix2Xd::Constant(2, 68, 100.0);
    const Eigen::Vector2d left(70, 90), right(130, 110);
    for (int i = 36; i < 42; ++i) landmarks.col(i) = left;
    for (int i = 42; i < 48; ++i) landmarks.col(i) = right;
    cv::circle(image, cv::Point(70, 90), 4, cv::Scalar(0, 0, 0), cv::FILLED);
    cv::circle(image, cv::Point(130, 110), 4, cv::Scalar(0, 0, 0), cv::FILLED);
    CropOptions options;
    const cv::Mat crop = eye_aligned_crop(image, landmarks, options);
    ASSERT_EQ(crop.type(), CV_8UC1);
    ASSERT_EQ(crop.rows, options.size);
    const double row = options.eye_height * options.size, span = options.eye_span * options.size;
    const double left_x = 0.5 * (options.size - span), right_x = 0.5 * (options.size + span);
    EXPECT_LT(crop.at<std::uint8_t>(cvRound(row), cvRound(left_x)), 60);
    EXPECT_LT(crop.at<std::uint8_t>(cvRound(row), cvRound(right_x)), 60);
    EXPECT_GT(crop.at<std::uint8_t>(cvRound(row), options.size / 2), 200);
    landmarks.middleCols(42, 6) = landmarks.middleCols(36, 6);
    EXPECT_THROW((void)eye_aligned_crop(image, landmarks, options), facesynth::core::Error);
}

}  // namespace
