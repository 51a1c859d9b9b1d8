#pragma once
// Photographs as the commands that take folders of them read them: the image (refused, naming the
// file, when too large or undecodable) and its face's 68 landmarks, from the .pts beside it or, where
// there is none, from a detector and regressor opened on first use.
#include "train/face_box.h"
#include "train/regressor.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace facesynth::train {

// The image files of a folder (core::is_image_file), sorted by name, so that what is made from them
// does not depend on directory order. Throws core::Error naming the folder when it does not exist or
// holds none.
[[nodiscard]] std::vector<std::filesystem::path> list_photos(const std::filesystem::path& folder);

// 8-bit B G R; throws core::Error naming the file when it is over core::kMaxImagePixels or cannot
// be decoded.
[[nodiscard]] cv::Mat read_photo(const std::filesystem::path& path);

// An iBUG .pts with 68 points; throws core::Error naming the file otherwise.
[[nodiscard]] Eigen::Matrix2Xd read_pts68(const std::filesystem::path& path);

struct PhotoLandmarks {
    Eigen::Matrix2Xd points;  // 2 x 68, 0-based pixels
    std::string source;       // "pts", or the regressor's label when detected
};

// IMAGE.pts when it exists; otherwise the largest face `detector` finds, landmarked by `regressor`
// (open_regressor and choose_detector specs, opened at the first photograph without a .pts). Use
// from one thread at a time.
class PtsOrDetected {
public:
    PtsOrDetected(std::string regressor, std::string detector);
    ~PtsOrDetected();
    PtsOrDetected(const PtsOrDetected&) = delete;
    PtsOrDetected& operator=(const PtsOrDetected&) = delete;

    // Throws core::Error naming the file: a broken .pts, or no face found where there is none.
    [[nodiscard]] PhotoLandmarks find(const std::filesystem::path& image_path, const cv::Mat& image);
    [[nodiscard]] const std::string& regressor_spec() const { return regressor_spec_; }

private:
    std::string regressor_spec_, detector_spec_;
    std::unique_ptr<LandmarkRegressor> regressor_;
    std::unique_ptr<FaceDetector> detector_;
};

}  // namespace facesynth::train
