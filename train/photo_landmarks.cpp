#include "train/photo_landmarks.h"

#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <utility>

namespace facesynth::train {

std::vector<std::filesystem::path> list_photos(const std::filesystem::path& folder) {
    if (!std::filesystem::is_directory(folder)) throw core::file_error(folder.string(), "photo folder not found");
    std::vector<std::filesystem::path> photos;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        if (entry.is_regular_file() && core::is_image_file(entry.path())) photos.push_back(entry.path());
    std::sort(photos.begin(), photos.end());
    if (photos.empty()) throw core::file_error(folder.string(), "no images in the folder");
    return photos;
}

cv::Mat read_photo(const std::filesystem::path& path) {
    if (!std::filesystem::is_regular_file(path)) throw core::file_error(path.string(), "file not found");
    core::check_image_not_too_large(path);
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw core::file_error(path.string(), "cannot read the image (not an image file, or corrupt)");
    return image;
}

Eigen::Matrix2Xd read_pts68(const std::filesystem::path& path) {
    Eigen::Matrix2Xd points = morph::read_pts(path);
    if (points.cols() != morph::kNumIbugLandmarks)
        throw core::file_error(path.string(), "has " + std::to_string(points.cols()) + " points, expected 68 (iBUG)");
    return points;
}

PtsOrDetected::PtsOrDetected(std::string regressor, std::string detector)
    : regressor_spec_(std::move(regressor)), detector_spec_(std::move(detector)) {}

PtsOrDetected::~PtsOrDetected() = default;

PhotoLandmarks PtsOrDetected::find(const std::filesystem::path& image_path, const cv::Mat& image) {
    std::filesystem::path pts = image_path;
    pts.replace_extension(".pts");
    if (std::filesystem::exists(pts)) return {read_pts68(pts), "pts"};
    if (!regressor_) {
        regressor_ = open_regressor(regressor_spec_);
        const LandmarkRegressor* const regressors[] = {regressor_.get()};
        detector_ = std::make_unique<FaceDetector>(choose_detector(detector_spec_, regressors));
    }
    const cv::Mat gray = to_gray8(image);
    const auto boxes = detector_->detect(gray);
    if (boxes.empty()) throw core::file_error(image_path.string(), "no face found (and no .pts beside it)");
    return {regressor_->predict(gray, boxes.front()), regressor_->label()};
}

}  // namespace facesynth::train
