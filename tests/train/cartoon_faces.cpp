#include "cartoon_faces.h"

#include "core/random.h"
#include "train/face_box.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>
#include <vector>

namespace facesynth::testkit {
namespace {

// The 68 template points in a face frame: x right, y down, face about 1 unit wide, centre at 0.
Eigen::Matrix2Xd template_shape(core::Rng& rng) {
    Eigen::Matrix2Xd p(2, 68);
    const double eye_spacing = 0.21 + 0.02 * rng.normal();
    const double eye_height = -0.12 + 0.02 * rng.normal();
    const double mouth_width = 0.17 + 0.02 * rng.normal();
    const double mouth_y = 0.3 + 0.02 * rng.normal();
    const double mouth_open = std::max(0.0, 0.03 + 0.03 * rng.normal());
    const double jaw_width = 0.5 + 0.03 * rng.normal();
    const double chin_y = 0.55 + 0.03 * rng.normal();
    for (int i = 0; i < 17; ++i) {  // jaw: ear level on the image left, round the chin, to the right
        const double t = std::numbers::pi * (1.0 - i / 16.0);
        p.col(i) << jaw_width * std::cos(t), -0.1 + (chin_y + 0.1) * std::sin(t) * (0.6 + 0.4 * std::sin(t));
    }
    for (int i = 0; i < 5; ++i) {  // brows in iBUG order: left brow outer->inner, right brow inner->outer
        p.col(17 + i) << -(0.34 - 0.07 * i), eye_height - 0.12 - 0.04 * std::sin(std::numbers::pi * i / 4.0);
        p.col(22 + i) << (0.06 + 0.07 * i), eye_height - 0.12 - 0.04 * std::sin(std::numbers::pi * (4 - i) / 4.0);
    }
    for (int i = 0; i < 4; ++i) p.col(27 + i) << 0, eye_height + 0.05 + 0.06 * i;  // nose bridge
    for (int i = 0; i < 5; ++i) p.col(31 + i) << -0.08 + 0.04 * i, eye_height + 0.27 - 0.02 * (i == 2);
    for (int side = 0; side < 2; ++side) {  // eyes 36..41 and 42..47, each from its outer-left corner clockwise
        const double cx = side == 0 ? -eye_spacing : eye_spacing;
        const int base = 36 + 6 * side;
        const double w = 0.07, h = 0.03 + 0.006 * rng.normal();
        p.col(base + 0) << cx - w, eye_height;
        p.col(base + 1) << cx - w / 3, eye_height - h;
        p.col(base + 2) << cx + w / 3, eye_height - h;
        p.col(base + 3) << cx + w, eye_height;
        p.col(base + 4) << cx + w / 3, eye_height + h;
        p.col(base + 5) << cx - w / 3, eye_height + h;
    }
    for (int i = 0; i < 12; ++i) {  // outer lip 48..59
        const double t = std::numbers::pi * (1 - i / 6.0);
        p.col(48 + i) << mouth_width * std::cos(t), mouth_y - (0.05 + mouth_open / 2) * std::sin(t);
    }
    for (int i = 0; i < 8; ++i) {  // inner lip 60..67
        const double t = std::numbers::pi * (1 - i / 4.0);
        p.col(60 + i) << 0.7 * mouth_width * std::cos(t), mouth_y - (0.005 + mouth_open / 2) * std::sin(t);
    }
    for (Eigen::Index i = 0; i < p.cols(); ++i) p.col(i) += 0.006 * Eigen::Vector2d(rng.normal(), rng.normal());
    return p;
}

// Points of the flat template placed on a rounded head (depth falls off toward the sides), with the
// nose (iBUG 28-36) standing out toward its tip, then turned about the vertical axis and projected.
void turn(Eigen::Matrix2Xd& p, double yaw) {
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
        const double x = p(0, i);
        double depth = 0.45 * std::sqrt(std::max(0.0, 1.0 - (x / 0.6) * (x / 0.6)));
        if (i >= 27 && i <= 30) depth += 0.04 * static_cast<double>(i - 26);  // bridge to tip
        if (i >= 31 && i <= 35) depth += 0.08;                              // nostrils
        p(0, i) = x * std::cos(yaw) + depth * std::sin(yaw);
    }
}

std::vector<cv::Point> polyline(const Eigen::Matrix2Xd& p, int first, int count) {
    std::vector<cv::Point> points;
    for (int i = first; i < first + count; ++i)
        points.emplace_back(static_cast<int>(std::lround(p(0, i) * 16)), static_cast<int>(std::lround(p(1, i) * 16)));
    return points;
}

}  // namespace

CartoonFace make_cartoon_face(std::uint64_t seed, std::uint64_t index, int image_size, double yaw_deg) {
    core::Rng rng(seed, index, 77);
    Eigen::Matrix2Xd shape = template_shape(rng);
    if (yaw_deg != 0) turn(shape, yaw_deg * std::numbers::pi / 180.0);
    const double scale = image_size * (0.42 + 0.04 * rng.normal());
    const double angle = 6.0 * rng.normal() * std::numbers::pi / 180.0;
    const Eigen::Vector2d centre(image_size / 2.0 + 0.05 * image_size * rng.normal(),
                                 image_size / 2.0 + 0.05 * image_size * rng.normal());
    Eigen::Matrix2d r;
    r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
    CartoonFace face;
    face.landmarks = ((scale * r) * shape).colwise() + centre;

    const int background = 40 + static_cast<int>(rng.uniform() * 60);
    face.gray = cv::Mat(image_size, image_size, CV_8UC1, cv::Scalar(background));
    const auto& l = face.landmarks;
    constexpr int kShift = 4;  // sub-pixel drawing with 4 fractional bits
    std::vector<cv::Point> head = polyline(l, 0, 17);
    // Forehead: close the jaw curve over the top of the head.
    const Eigen::Vector2d top = centre + (scale * r) * Eigen::Vector2d(0, -0.65);
    head.emplace_back(static_cast<int>(std::lround(top.x() * 16)), static_cast<int>(std::lround(top.y() * 16)));
    const int skin = 150 + static_cast<int>(rng.uniform() * 60);
    cv::fillPoly(face.gray, std::vector<std::vector<cv::Point>>{head}, cv::Scalar(skin), cv::LINE_AA, kShift);
    cv::polylines(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, 0, 17)}, false, cv::Scalar(skin - 60), 2,
                  cv::LINE_AA, kShift);
    cv::polylines(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, 17, 5), polyline(l, 22, 5)}, false,
                  cv::Scalar(30), 3, cv::LINE_AA, kShift);
    cv::polylines(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, 27, 4), polyline(l, 31, 5)}, false,
                  cv::Scalar(skin - 70), 2, cv::LINE_AA, kShift);
    for (int base : {36, 42}) {
        cv::fillPoly(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, base, 6)}, cv::Scalar(235), cv::LINE_AA, kShift);
        const Eigen::Vector2d pupil = l.middleCols(base, 6).rowwise().mean();
        cv::circle(face.gray, cv::Point(static_cast<int>(pupil.x() * 16), static_cast<int>(pupil.y() * 16)),
                   static_cast<int>(scale * 0.025 * 16), cv::Scalar(20), cv::FILLED, cv::LINE_AA, kShift);
    }
    cv::fillPoly(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, 48, 12)}, cv::Scalar(skin - 80), cv::LINE_AA, kShift);
    cv::fillPoly(face.gray, std::vector<std::vector<cv::Point>>{polyline(l, 60, 8)}, cv::Scalar(15), cv::LINE_AA, kShift);

    cv::Mat noise(face.gray.size(), CV_16SC1);
    for (int y = 0; y < noise.rows; ++y)
        for (int x = 0; x < noise.cols; ++x) noise.at<short>(y, x) = static_cast<short>(std::lround(6 * rng.normal()));
    cv::Mat noisy;
    face.gray.convertTo(noisy, CV_16SC1);
    noisy += noise;
    noisy.convertTo(face.gray, CV_8UC1);
    return face;
}

std::vector<train::TrainingFace> cartoon_training_faces(std::uint64_t seed, int count, double yaw_deg) {
    using namespace train;
    std::vector<TrainingFace> faces;
    for (int i = 0; i < count; ++i) {
        core::Rng rng(seed, static_cast<std::uint64_t>(i), 5);
        const double yaw = yaw_deg == 0 ? 0.0 : yaw_deg + 5 * (2 * core::Rng(seed, static_cast<std::uint64_t>(i), 6).uniform() - 1);
        const auto cartoon = testkit::make_cartoon_face(seed, static_cast<std::uint64_t>(i), 200, yaw);
        const Eigen::Vector2d low = cartoon.landmarks.rowwise().minCoeff(), high = cartoon.landmarks.rowwise().maxCoeff();
        FaceBox box;
        box.width = (high - low).maxCoeff() * (1.0 + 0.03 * rng.normal());
        box.centre = (low + high) / 2 + 0.03 * box.width * Eigen::Vector2d(rng.normal(), rng.normal());
        const FaceFrame frame{box};
        TrainingFace face;
        face.crop = canonical_crop(cartoon.gray, frame);
        face.truth = frame.to_canonical(cartoon.landmarks);
        face.box_from_detector = true;
        if (yaw_deg != 0) {
            face.yaw_deg = yaw;
            face.view = std::abs(yaw) < 20 ? FaceView::kFrontal : yaw < 0 ? FaceView::kNoseLeft : FaceView::kNoseRight;
        }
        faces.push_back(std::move(face));
    }
    return faces;
}

std::vector<train::TrainingFace> three_view_faces(std::uint64_t seed, int per_view) {
    const auto frontal = cartoon_training_faces(seed, per_view);
    const auto left = cartoon_training_faces(seed + 1, per_view, -45);
    const auto right = cartoon_training_faces(seed + 2, per_view, 45);
    std::vector<train::TrainingFace> faces;
    for (int i = 0; i < per_view; ++i)
        for (const auto* set : {&frontal, &left, &right}) faces.push_back((*set)[static_cast<std::size_t>(i)]);
    return faces;
}

std::vector<train::TrainingFace> concatenate(std::initializer_list<std::vector<train::TrainingFace>> parts) {
    std::vector<train::TrainingFace> all;
    for (const auto& part : parts) all.insert(all.end(), part.begin(), part.end());
    return all;
}

}  // namespace facesynth::testkit
