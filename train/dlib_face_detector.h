#pragma once
// dlib's HOG face detector (dlib::get_frontal_face_detector(), built into libdlib: five linear HOG
// filters on an image pyramid, 80×80 px window). Its own translation unit, because dlib's detector
// headers (and the serialised filters) are heavy to compile.
#include "train/face_box.h"

#include <opencv2/core.hpp>

#include <memory>
#include <vector>

namespace facesynth::train {

// One detection after dlib's non-maximum suppression: the box, the index of the filter that found it
// (0 frontal, 1 and 2 the two turned-face filters, 3 and 4 frontal rotated in the image plane) and
// its score above the filter's threshold.
struct DlibDetection {
    FaceBox box;
    int filter = 0;
    double confidence = 0;
};

// The threshold adjustment facesynth uses (docs/train.md "Face detectors"; measured in docs/history/train-runs.md): with dlib's default 0 it
// missed 146 of 300 synthetic test faces, with -0.6 it misses 50 and finds 6 boxes that are not the
// labelled face on 20 photographs (1 on the synthetic set); -1.0 misses 19 but finds 28 such boxes.
inline constexpr double kDlibAdjustThreshold = -0.6;

// The view a filter's detections get (measured on synthetic faces of known yaw, docs/train.md).
[[nodiscard]] FaceView view_of_dlib_filter(int filter);

// Not thread-safe (the detector keeps its feature pyramid between calls): one per thread.
class DlibHogDetector {
public:
    // adjust_threshold is added to every filter's threshold (dlib's own default 0; negative finds more
    // faces and more false ones).
    explicit DlibHogDetector(double adjust_threshold = kDlibAdjustThreshold);
    ~DlibHogDetector();
    DlibHogDetector(DlibHogDetector&&) noexcept;
    DlibHogDetector& operator=(DlibHogDetector&&) noexcept;
    DlibHogDetector(const DlibHogDetector&) = delete;
    DlibHogDetector& operator=(const DlibHogDetector&) = delete;

    // All faces in an 8-bit grey image, best score first, each box's view from its filter.
    [[nodiscard]] std::vector<DlibDetection> detect(const cv::Mat& gray) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    double adjust_threshold_;
};

}  // namespace facesynth::train
