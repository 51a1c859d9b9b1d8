#include "synth/photo_backgrounds.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>

namespace facesynth::synth {

cv::Rect face_exclusion_box(const cv::Size& image, const Eigen::Matrix2Xd& landmarks, const FaceExclusion& grow) {
    if (landmarks.cols() == 0 || !landmarks.allFinite()) throw core::Error("backgrounds: the landmarks are empty or not finite");
    const Eigen::Vector2d low = landmarks.rowwise().minCoeff(), high = landmarks.rowwise().maxCoeff();
    const double w = high.x() - low.x(), h = high.y() - low.y();
    const int x0 = static_cast<int>(std::floor(low.x() - grow.side * w));
    const int x1 = static_cast<int>(std::ceil(high.x() + grow.side * w)) + 1;
    const int y0 = static_cast<int>(std::floor(low.y() - grow.above * h));
    const int y1 = static_cast<int>(std::ceil(high.y() + grow.below * h)) + 1;
    return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & cv::Rect(cv::Point(0, 0), image);
}

std::vector<cv::Rect> background_regions(const cv::Size& image, const Eigen::Matrix2Xd& landmarks, int min_side, const FaceExclusion& grow) {
    const cv::Rect face = face_exclusion_box(image, landmarks, grow);
    std::vector<cv::Rect> out;
    const auto keep = [&](const cv::Rect& r) {
        if (std::min(r.width, r.height) >= min_side && (r & face).area() == 0) out.push_back(r);
    };
    if (face.area() == 0) {  // the face lies outside the image: all of it is background
        keep(cv::Rect(cv::Point(0, 0), image));
        return out;
    }
    keep(cv::Rect(0, 0, face.x, image.height));
    keep(cv::Rect(face.x + face.width, 0, image.width - face.x - face.width, image.height));
    keep(cv::Rect(0, 0, image.width, face.y));
    keep(cv::Rect(0, face.y + face.height, image.width, image.height - face.y - face.height));
    return out;
}

}  // namespace facesynth::synth
