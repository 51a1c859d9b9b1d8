#include "train/dlib_face_detector.h"

#include "core/error.h"

#include <dlib/image_processing/frontal_face_detector.h>
#include <dlib/opencv/cv_image.h>

namespace facesynth::train {

FaceView view_of_dlib_filter(int filter) {
    switch (filter) {
        case 1: return FaceView::kNoseLeft;
        case 2: return FaceView::kNoseRight;
        default: return FaceView::kFrontal;
    }
}

struct DlibHogDetector::Impl {
    dlib::frontal_face_detector detector = dlib::get_frontal_face_detector();
};

DlibHogDetector::DlibHogDetector(double adjust_threshold)
    : impl_(std::make_unique<Impl>()), adjust_threshold_(adjust_threshold) {}
DlibHogDetector::~DlibHogDetector() = default;
DlibHogDetector::DlibHogDetector(DlibHogDetector&&) noexcept = default;
DlibHogDetector& DlibHogDetector::operator=(DlibHogDetector&&) noexcept = default;

std::vector<DlibDetection> DlibHogDetector::detect(const cv::Mat& gray) const {
    if (gray.type() != CV_8UC1 || gray.empty()) throw core::Error("dlib face detector: expected a non-empty 8-bit grey image");
    std::vector<dlib::rect_detection> found;
    impl_->detector(dlib::cv_image<unsigned char>(gray), found, adjust_threshold_);
    std::vector<DlibDetection> detections;
    detections.reserve(found.size());
    for (const auto& d : found) {
        const cv::Rect rect(static_cast<int>(d.rect.left()), static_cast<int>(d.rect.top()),
                            static_cast<int>(d.rect.width()), static_cast<int>(d.rect.height()));
        DlibDetection detection{face_box_from_rect(rect), static_cast<int>(d.weight_index), d.detection_confidence};
        detection.box.view = view_of_dlib_filter(detection.filter);
        detections.push_back(detection);
    }
    return detections;
}

}  // namespace facesynth::train
