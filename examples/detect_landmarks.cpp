// Finds the faces in a photograph and their 68 landmarks; writes one .pts per face beside OUT_PREFIX.
//   detect_landmarks IMAGE OUT_PREFIX [REGRESSOR] [DETECTOR]
// REGRESSOR: an SDM file from `facesynth train`, or "dlib" (dlib's predictor, Debian libdlib-data).
// DETECTOR: frontal, multiview, dlib or dlib+profile.
#include "core/error.h"
#include "morph/landmarks.h"
#include "train/face_box.h"
#include "train/regressor.h"

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <string>

using namespace facesynth;

int main(int argc, char** argv) try {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s IMAGE OUT_PREFIX [REGRESSOR] [DETECTOR]\n", argv[0]);
        return 2;
    }
    const std::string image_path = argv[1];
    const std::string prefix = argv[2];
    const auto regressor = train::open_regressor(argc > 3 ? argv[3] : "dlib");
    const train::FaceDetector detector(train::parse_detector_kind(argc > 4 ? argv[4] : "dlib"));

    const cv::Mat image = cv::imread(image_path, cv::IMREAD_COLOR);
    if (image.empty()) throw core::file_error(image_path, "cannot read the image");
    const cv::Mat gray = train::to_gray8(image);

    const std::vector<train::FaceBox> faces = detector.detect(gray);  // largest first
    if (faces.empty()) throw core::file_error(image_path, "no face found");
    for (std::size_t i = 0; i < faces.size(); ++i) {
        const Eigen::Matrix2Xd landmarks = regressor->predict(gray, faces[i]);  // 0-based pixels
        const std::string path = prefix + "_" + std::to_string(i) + ".pts";
        morph::write_pts(path, landmarks);
        std::printf("%s: face %zu (%s view) -> %s\n", image_path.c_str(), i, train::view_name(faces[i].view), path.c_str());
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "detect_landmarks: %s\n", e.what());
    return 1;
}
