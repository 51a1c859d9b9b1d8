#pragma once
// Face boxes and the canonical face frame. Every face, in training and at test time, is cut out of
// its image around a box from OpenCV's Haar cascade (or, in training where the detector misses, a
// box synthesised from the landmarks with the detector's measured offset and spread) and resampled
// so that the box is kCanonicalBoxWidth pixels wide at the centre of a kCanonicalCropSide square.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/objdetect.hpp>

#include <filesystem>
#include <optional>
#include <vector>

namespace facesynth::train {

inline constexpr double kCanonicalBoxWidth = 128.0;
inline constexpr int kCanonicalCropSide = 256;

// Debian's opencv-data cascade used everywhere (scale 1.2, min neighbours 2, min size 50).
[[nodiscard]] std::filesystem::path default_face_cascade_path();

// A square face box: centre in 0-based pixel coordinates and side length in pixels.
struct FaceBox {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double width = 0;
};
[[nodiscard]] FaceBox face_box_from_rect(const cv::Rect& rect);
[[nodiscard]] cv::Rect2d rect_from_face_box(const FaceBox& box);

// Haar cascade face detector; one per thread (cv::CascadeClassifier is not shared across threads).
class FaceDetector {
public:
    explicit FaceDetector(const std::filesystem::path& cascade = default_face_cascade_path());
    // All faces in an 8-bit grey image, largest first.
    [[nodiscard]] std::vector<FaceBox> detect(const cv::Mat& gray) const;

private:
    mutable cv::CascadeClassifier cascade_;
};

// The detection belonging to a ground-truth shape: its centre lies inside the landmarks' bounding
// box and its width is 0.4-2.5 times the landmarks' width; the one nearest the landmarks' centre.
[[nodiscard]] std::optional<FaceBox> match_detection(const std::vector<FaceBox>& detections,
                                                     const Eigen::Matrix2Xd& landmarks);

// Image <-> canonical crop coordinates for one face box.
struct FaceFrame {
    FaceBox box;
    [[nodiscard]] double scale() const { return kCanonicalBoxWidth / box.width; }
    [[nodiscard]] Eigen::Matrix2Xd to_canonical(const Eigen::Matrix2Xd& image_points) const;
    [[nodiscard]] Eigen::Matrix2Xd to_image(const Eigen::Matrix2Xd& canonical_points) const;
};

// The kCanonicalCropSide² 8-bit crop of the frame (anti-aliased by pyramid halving when the face is
// large, replicated borders where the crop leaves the image).
[[nodiscard]] cv::Mat canonical_crop(const cv::Mat& gray, const FaceFrame& frame);

// Any image (grey or colour, 8 or 16 bit) as 8-bit grey.
[[nodiscard]] cv::Mat to_gray8(const cv::Mat& image);

}  // namespace facesynth::train
