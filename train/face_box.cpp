#include "train/face_box.h"

#include "core/error.h"
#include "train/dlib_face_detector.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace facesynth::train {

std::filesystem::path default_face_cascade_path() {
    return "/usr/share/opencv4/haarcascades/haarcascade_frontalface_alt2.xml";
}

std::filesystem::path default_profile_cascade_path() {
    return "/usr/share/opencv4/haarcascades/haarcascade_profileface.xml";
}

const char* view_name(FaceView view) {
    switch (view) {
        case FaceView::kNoseLeft: return "nose_left";
        case FaceView::kNoseRight: return "nose_right";
        case FaceView::kFrontal: break;
    }
    return "frontal";
}

const char* detector_name(DetectorKind kind) {
    switch (kind) {
        case DetectorKind::kMultiView: return "multiview";
        case DetectorKind::kDlib: return "dlib";
        case DetectorKind::kDlibProfile: return "dlib+profile";
        case DetectorKind::kFrontal: break;
    }
    return "frontal";
}

DetectorKind parse_detector_kind(const std::string& name) {
    for (const auto kind : {DetectorKind::kFrontal, DetectorKind::kMultiView, DetectorKind::kDlib, DetectorKind::kDlibProfile})
        if (name == detector_name(kind)) return kind;
    throw core::Error("unknown face detector '" + name + "' (expected frontal, multiview, dlib or dlib+profile)");
}

bool detector_has_views(DetectorKind kind) { return kind != DetectorKind::kFrontal; }

namespace {

double overlap_of_smaller(const FaceBox& a, const FaceBox& b) {
    const cv::Rect2d ra = rect_from_face_box(a), rb = rect_from_face_box(b);
    const double smaller = std::min(ra.area(), rb.area());
    return smaller > 0 ? (ra & rb).area() / smaller : 0.0;
}

cv::CascadeClassifier load_cascade(const std::filesystem::path& path) {
    if (!std::filesystem::exists(path))
        throw core::file_error(path.string(), "face detector cascade not found (install Debian package opencv-data)");
    cv::CascadeClassifier cascade;
    if (!cascade.load(path.string())) throw core::file_error(path.string(), "cannot load the cascade");
    return cascade;
}

void run_cascade(cv::CascadeClassifier& cascade, const cv::Mat& equalised, FaceView view, bool mirrored,
                 std::vector<ScoredBox>& out) {
    std::vector<cv::Rect> rects;
    std::vector<int> neighbours;
    cascade.detectMultiScale(equalised, rects, neighbours, 1.2, 2, 0, cv::Size(50, 50));
    for (std::size_t i = 0; i < rects.size(); ++i) {
        ScoredBox scored{face_box_from_rect(rects[i]), i < neighbours.size() ? neighbours[i] : 0};
        if (mirrored) scored.box.centre.x() = equalised.cols - 1 - scored.box.centre.x();
        scored.box.view = view;
        out.push_back(scored);
    }
}

}  // namespace

std::vector<FaceBox> merge_detections(std::vector<ScoredBox> detections) {
    std::stable_sort(detections.begin(), detections.end(), [](const ScoredBox& a, const ScoredBox& b) {
        if (a.neighbours != b.neighbours) return a.neighbours > b.neighbours;
        const bool a_frontal = a.box.view == FaceView::kFrontal, b_frontal = b.box.view == FaceView::kFrontal;
        if (a_frontal != b_frontal) return a_frontal;
        return a.box.width > b.box.width;
    });
    std::vector<FaceBox> kept;
    for (const auto& d : detections) {
        const bool duplicate =
            std::any_of(kept.begin(), kept.end(), [&](const FaceBox& k) { return overlap_of_smaller(k, d.box) >= 0.5; });
        if (!duplicate) kept.push_back(d.box);
    }
    std::stable_sort(kept.begin(), kept.end(), [](const FaceBox& a, const FaceBox& b) { return a.width > b.width; });
    return kept;
}

FaceBox face_box_from_rect(const cv::Rect& rect) {
    FaceBox box;
    box.centre = {rect.x + (rect.width - 1) / 2.0, rect.y + (rect.height - 1) / 2.0};
    box.width = std::max(rect.width, rect.height);
    return box;
}

FaceBox canonical_face_box(FaceView view) {
    FaceBox box;
    box.centre = Eigen::Vector2d::Constant((kCanonicalCropSide - 1) / 2.0);
    box.width = kCanonicalBoxWidth;
    box.view = view;
    return box;
}

cv::Rect2d rect_from_face_box(const FaceBox& box) {
    const double half = (box.width - 1) / 2.0;
    return {box.centre.x() - half, box.centre.y() - half, box.width, box.width};
}

FaceDetector::FaceDetector(DetectorKind kind) : kind_(kind) {
    if (kind == DetectorKind::kFrontal || kind == DetectorKind::kMultiView) frontal_ = load_cascade(default_face_cascade_path());
    if (kind != DetectorKind::kFrontal && kind != DetectorKind::kDlib) profile_ = load_cascade(default_profile_cascade_path());
    if (kind == DetectorKind::kDlib || kind == DetectorKind::kDlibProfile) dlib_ = std::make_unique<DlibHogDetector>();
}

FaceDetector::FaceDetector(const std::filesystem::path& frontal_cascade, const std::filesystem::path& profile_cascade)
    : kind_(profile_cascade.empty() ? DetectorKind::kFrontal : DetectorKind::kMultiView), frontal_(load_cascade(frontal_cascade)) {
    if (!profile_cascade.empty()) profile_ = load_cascade(profile_cascade);
}

FaceDetector::~FaceDetector() = default;
FaceDetector::FaceDetector(FaceDetector&&) noexcept = default;
FaceDetector& FaceDetector::operator=(FaceDetector&&) noexcept = default;

std::vector<ScoredBox> FaceDetector::detect_unmerged(const cv::Mat& gray) const {
    if (gray.type() != CV_8UC1 || gray.empty()) throw core::Error("face detector: expected a non-empty 8-bit grey image");
    cv::Mat equalised;
    cv::equalizeHist(gray, equalised);
    std::vector<ScoredBox> found;
    if (frontal_) run_cascade(*frontal_, equalised, FaceView::kFrontal, false, found);
    if (profile_) {
        run_cascade(*profile_, equalised, FaceView::kNoseLeft, false, found);
        cv::Mat mirrored;
        cv::flip(equalised, mirrored, 1);
        run_cascade(*profile_, mirrored, FaceView::kNoseRight, true, found);
    }
    return found;
}

std::vector<FaceBox> FaceDetector::detect(const cv::Mat& gray) const {
    if (dlib_) {
        // dlib's boxes (its own non-maximum suppression already made them one per face); with
        // dlib+profile the Haar profile cascades look only at images where dlib finds nothing.
        std::vector<FaceBox> boxes;
        for (const auto& d : dlib_->detect(gray)) boxes.push_back(d.box);
        if (boxes.empty() && profile_) boxes = merge_detections(detect_unmerged(gray));
        std::stable_sort(boxes.begin(), boxes.end(), [](const FaceBox& a, const FaceBox& b) { return a.width > b.width; });
        return boxes;
    }
    if (!profile_) {  // the frontal detector as it always was: every detection, largest first
        std::vector<FaceBox> boxes;
        for (const auto& d : detect_unmerged(gray)) boxes.push_back(d.box);
        std::stable_sort(boxes.begin(), boxes.end(), [](const FaceBox& a, const FaceBox& b) { return a.width > b.width; });
        return boxes;
    }
    return merge_detections(detect_unmerged(gray));
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
    if (gray.type() != CV_8UC1 || gray.empty()) throw core::Error("canonical_crop: expected a non-empty 8-bit grey image");
    const double scale = frame.scale();
    if (!(scale > 0) || !std::isfinite(scale)) throw core::Error("canonical_crop: invalid face box");
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
