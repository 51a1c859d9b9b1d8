#include "recognition/face_crop.h"

#include "core/error.h"

#include <opencv2/imgproc.hpp>

#include <cmath>

namespace facesynth::recognition {
namespace {

cv::Mat to_grey(const cv::Mat& image) {
    if (image.channels() == 1) return image;
    cv::Mat grey;
    cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    return grey;
}

}  // namespace

cv::Mat eye_aligned_crop(const cv::Mat& image, const Eigen::Matrix2Xd& landmarks, const CropOptions& options) {
    if (landmarks.cols() != 68) throw core::Error("eye-aligned crop: needs 68 landmarks, got " + std::to_string(landmarks.cols()));
    // iBUG 37-42: the eye on the image's left, 43-48: on its right (0-based 36-41 and 42-47).
    const Eigen::Vector2d left = landmarks.middleCols(36, 6).rowwise().mean();
    const Eigen::Vector2d right = landmarks.middleCols(42, 6).rowwise().mean();
    const Eigen::Vector2d span = right - left;
    if (!left.allFinite() || !right.allFinite() || span.norm() < 1e-6) throw core::Error("eye-aligned crop: the eye centres coincide or are not finite");
    const double s = options.size;
    const Eigen::Vector2d target_left(0.5 * s * (1 - options.eye_span), options.eye_height * s);
    const double scale = options.eye_span * s / span.norm();
    const double angle = std::atan2(span.y(), span.x());
    // x' = scale · R(-angle) · (x - left) + target_left
    const double c = scale * std::cos(-angle), n = scale * std::sin(-angle);
    cv::Matx23d transform(c, -n, 0, n, c, 0);
    transform(0, 2) = target_left.x() - (c * left.x() - n * left.y());
    transform(1, 2) = target_left.y() - (n * left.x() + c * left.y());
    cv::Mat crop;
    cv::warpAffine(to_grey(image), crop, transform, cv::Size(options.size, options.size), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    return crop;
}

cv::Mat frontal_crop(const cv::Mat& frontal, const CropOptions& options) {
    if (frontal.empty()) throw core::Error("frontal crop: empty image");
    cv::Mat crop;
    cv::resize(to_grey(frontal), crop, cv::Size(options.size, options.size), 0, 0, cv::INTER_AREA);
    return crop;
}

}  // namespace facesynth::recognition
