#pragma once
// Face boxes and the canonical face frame. Every face, in training and at test time, is cut out of
// its image around a box from a face detector (OpenCV's Haar cascades or dlib's HOG detector; or, in training where the detector misses, a
// box synthesised from the landmarks with the detector's measured offset and spread) and resampled
// so that the box is kCanonicalBoxWidth pixels wide at the centre of a kCanonicalCropSide square.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/objdetect.hpp>

#include <filesystem>
#include <memory>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::train {

inline constexpr double kCanonicalBoxWidth = 128.0;
inline constexpr int kCanonicalCropSide = 256;

// Debian's opencv-data cascades (scale 1.2, min neighbours 2, min size 50): the frontal one, and the
// profile one that the multi-view detector adds (it finds faces whose nose points to the image's
// left; the detector also runs it on the mirrored image for the other side).
[[nodiscard]] std::filesystem::path default_face_cascade_path();
[[nodiscard]] std::filesystem::path default_profile_cascade_path();

// Which cascade found a face: frontal, or profile with the nose toward the image's left or right.
enum class FaceView : std::uint8_t { kFrontal = 0, kNoseLeft = 1, kNoseRight = 2 };
inline constexpr int kFaceViews = 3;
[[nodiscard]] const char* view_name(FaceView view);  // "frontal", "nose_left", "nose_right"

// A square face box: centre in 0-based pixel coordinates and side length in pixels.
struct FaceBox {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double width = 0;
    FaceView view = FaceView::kFrontal;
};

// The face detectors: OpenCV's frontal Haar cascade alone; multi-view (frontal + profile on the
// image and on its mirror image, overlapping detections merged); dlib's HOG detector (five filters,
// the turned-face ones giving the profile views); or dlib plus the Haar profile cascades for faces
// dlib does not find. Recorded in SDM model files.
enum class DetectorKind : std::uint8_t { kFrontal = 0, kMultiView = 1, kDlib = 2, kDlibProfile = 3 };
inline constexpr DetectorKind kLastDetectorKind = DetectorKind::kDlibProfile;
// "frontal", "multiview", "dlib", "dlib+profile"
[[nodiscard]] const char* detector_name(DetectorKind kind);
// One of the names above; throws core::Error for anything else.
[[nodiscard]] DetectorKind parse_detector_kind(const std::string& name);
// Whether the detector's boxes carry profile views (all but the frontal Haar cascade).
[[nodiscard]] bool detector_has_views(DetectorKind kind);

// One detection before merging: its box and the cascade's neighbour count (how many raw windows
// grouped into it, OpenCV's confidence).
struct ScoredBox {
    FaceBox box;
    int neighbours = 0;
};

// One box per face: detections are taken by decreasing neighbour count (ties: frontal before
// profile, then larger first), and one is dropped when it covers at least half of a box already
// kept, or a kept box covers at least half of it (intersection / smaller area >= 0.5). The kept
// boxes are returned largest first.
[[nodiscard]] std::vector<FaceBox> merge_detections(std::vector<ScoredBox> detections);
[[nodiscard]] FaceBox face_box_from_rect(const cv::Rect& rect);
[[nodiscard]] cv::Rect2d rect_from_face_box(const FaceBox& box);
// The box every face is resampled to: kCanonicalBoxWidth wide at the centre of the canonical crop.
[[nodiscard]] FaceBox canonical_face_box(FaceView view = FaceView::kFrontal);

class DlibHogDetector;

// The face detector of one DetectorKind; one per thread (neither cv::CascadeClassifier nor dlib's
// detector is shared across threads).
class FaceDetector {
public:
    explicit FaceDetector(DetectorKind kind = DetectorKind::kFrontal);
    // Explicit Haar cascades; an empty profile path gives the frontal-only detector.
    FaceDetector(const std::filesystem::path& frontal_cascade, const std::filesystem::path& profile_cascade);
    ~FaceDetector();
    FaceDetector(FaceDetector&&) noexcept;
    FaceDetector& operator=(FaceDetector&&) noexcept;
    FaceDetector(const FaceDetector&) = delete;
    FaceDetector& operator=(const FaceDetector&) = delete;

    // All faces in an 8-bit grey image, largest first, each with the view that found it.
    [[nodiscard]] std::vector<FaceBox> detect(const cv::Mat& gray) const;
    // Every detection of every Haar cascade before merging (diagnosis and tests; empty for dlib).
    [[nodiscard]] std::vector<ScoredBox> detect_unmerged(const cv::Mat& gray) const;
    [[nodiscard]] DetectorKind kind() const { return kind_; }

private:
    DetectorKind kind_;
    mutable std::optional<cv::CascadeClassifier> frontal_;
    mutable std::optional<cv::CascadeClassifier> profile_;
    std::unique_ptr<DlibHogDetector> dlib_;
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
