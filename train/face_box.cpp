#include "train/face_box.h"

#include "morph/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace facesynth::train {

std::filesystem::path default_face_cascade_path() {
    return "/usr/share/opencv4/haarcascades/haarcascade_frontalface_alt2.xml";
}

FaceBox face_box_from_rect(const cv::Rect& rect) {
    FaceBox box;
    box.centre = {rect.x + (rect.width - 1) / 2.0, rect.y + (rect.height - 1) / 2.0};
    box.width = std::max(rect.width, rect.height);
    return box;
}

cv::Rect2d rect_from_face_box(const FaceBox& box) {
    const double half = (box.width - 1) / 2.0;
    return {box.centre.x() - half, box.centre.y() - half, box.width, box.width};
}

FaceDetector::FaceDetector(const std::filesystem::path& cascade) {
    if (!std::filesystem::exists(cascade))
        throw file_error(cascade.string(), "face detector cascade not found (install Debian package opencv-data)");
    if (!cascade_.load(cascade.string())) throw file_error(cascade.string(), "cannot load the Haar cascade");
}

std::vector<FaceBox> FaceDetector::detect(const cv::Mat& gray) const {
    cv::Mat equalised;
    cv::equalizeHist(gray, equalised);
    std::vector<cv::Rect> rects;
    cascade_.detectMultiScale(equalised, rects, 1.2, 2, 0, cv::Size(50, 50));
    std::vector<FaceBox> boxes;
    for (const auto& r : rects) boxes.push_back(face_box_from_rect(r));
    std::stable_sort(boxes.begin(), boxes.end(), [](const FaceBox& a, const FaceBox& b) { return a.width > b.width; });
    return boxes;
}

std::optional<FaceBox> match_detection(const std::vector<FaceBox>& detections, const Eigen::Matrix2Xd& landmarks) {
    const Eigen::Vector2d low = landmarks.rowwise().minCoeff();
    const Eigen::Vector2d high = landmarks.rowwise().maxCoeff();
    const Eigen::Vector2d centre = landmarks.rowwise().mean();
    const double width = std::max(high.x() - low.x(), high.y() - low.y());
    std::optional<FaceBox> best;
    double best_distance = std::numeric_limits<double>::infinity();
    for (const auto& d : detections) {
        const bool inside = (d.centre.array() >= low.array()).all() && (d.centre.array() <= high.array()).all();
        if (!inside || d.width < 0.4 * width || d.width > 2.5 * width) continue;
        const double distance = (d.centre - centre).norm();
        if (distance < best_distance) {
            best_distance = distance;
            best = d;
        }
    }
    return best;
}

Eigen::Matrix2Xd FaceFrame::to_canonical(const Eigen::Matrix2Xd& image_points) const {
    const double mid = (kCanonicalCropSide - 1) / 2.0;
    return ((image_points.colwise() - box.centre) * scale()).array() + mid;
}

Eigen::Matrix2Xd FaceFrame::to_image(const Eigen::Matrix2Xd& canonical_points) const {
    const double mid = (kCanonicalCropSide - 1) / 2.0;
    return ((canonical_points.array() - mid) / scale()).matrix().colwise() + box.centre;
}

cv::Mat canonical_crop(const cv::Mat& gray, const FaceFrame& frame) {
    if (gray.type() != CV_8UC1 || gray.empty()) throw Error("canonical_crop: expected a non-empty 8-bit grey image");
    const double scale = frame.scale();
    if (!(scale > 0) || !std::isfinite(scale)) throw Error("canonical_crop: invalid face box");
    // The image region the crop covers, with a margin for interpolation and pyramid filtering.
    const double half = (kCanonicalCropSide / 2.0) / scale + 4.0;
    const cv::Rect wanted(static_cast<int>(std::floor(frame.box.centre.x() - half)),
                          static_cast<int>(std::floor(frame.box.centre.y() - half)),
                          static_cast<int>(std::ceil(2 * half)) + 1, static_cast<int>(std::ceil(2 * half)) + 1);
    const cv::Rect roi = wanted & cv::Rect(0, 0, gray.cols, gray.rows);
    if (roi.empty()) return cv::Mat(kCanonicalCropSide, kCanonicalCropSide, CV_8UC1, cv::Scalar(0));
    cv::Mat source = gray(roi);
    // Halve until one crop pixel spans at most two source pixels; pyrDown maps source x to 2·x.
    double factor = 1;
    while (scale * factor < 0.5 && source.cols >= 4 && source.rows >= 4) {
        cv::Mat smaller;
        cv::pyrDown(source, smaller);
        source = smaller;
        factor *= 2;
    }
    const double mid = (kCanonicalCropSide - 1) / 2.0;
    // canonical = (q·factor + roi.tl - centre)·scale + mid for a point q of `source`.
    const cv::Matx23d source_to_crop(factor * scale, 0, (roi.x - frame.box.centre.x()) * scale + mid, 0,
                                     factor * scale, (roi.y - frame.box.centre.y()) * scale + mid);
    cv::Mat crop;
    cv::warpAffine(source, crop, source_to_crop, cv::Size(kCanonicalCropSide, kCanonicalCropSide), cv::INTER_LINEAR,
                   cv::BORDER_REPLICATE);
    return crop;
}

cv::Mat to_gray8(const cv::Mat& image) {
    cv::Mat gray;
    if (image.channels() == 3) {
        cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    } else if (image.channels() == 4) {
        cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
    } else {
        gray = image;
    }
    if (gray.depth() == CV_16U) {
        gray.convertTo(gray, CV_8U, 1.0 / 257.0);
    } else if (gray.depth() != CV_8U) {
        gray.convertTo(gray, CV_8U);
    }
    return gray;
}

}  // namespace facesynth::train
