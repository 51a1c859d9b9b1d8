#include "train/realism.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "train/sdm.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <tuple>
#include <utility>

namespace facesynth::train {

namespace {

// The convex hull of the label as a mask of `size`, shrunk by `inset` pixels.
cv::Mat hull_mask(cv::Size size, const Eigen::Matrix2Xd& label, int inset) {
    std::vector<cv::Point> points, hull;
    for (Eigen::Index i = 0; i < label.cols(); ++i)
        points.emplace_back(static_cast<int>(std::lround(label(0, i))), static_cast<int>(std::lround(label(1, i))));
    cv::convexHull(points, hull);
    cv::Mat inside = cv::Mat::zeros(size, CV_8UC1);
    cv::fillConvexPoly(inside, hull, cv::Scalar(255));
    if (inset > 0) cv::erode(inside, inside, cv::Mat(), cv::Point(-1, -1), inset);
    return inside;
}

// Mean grey level inside the convex hull of the label. synth meters the same quantity on the face layer
// before it is composited (synth/exposure.h, through render::landmark_hull_mask, which train cannot
// call: it does not link the renderer); here it is measured on finished images of any source.
double hull_grey(const cv::Mat& gray, const Eigen::Matrix2Xd& label) {
    const cv::Mat inside = hull_mask(gray.size(), label, 0);
    if (cv::countNonZero(inside) == 0) return std::numeric_limits<double>::quiet_NaN();
    return cv::mean(gray, inside)[0] / 255.0;
}

// Mean grey of a disc `below` inter-ocular distances under the chin (iBUG 9) along the face frame's
// down axis (perpendicular to the line between the outer eye corners), radius 0.06 of them; NaN when
// the disc leaves the image.
double grey_below_chin(const cv::Mat& gray, const Eigen::Matrix2Xd& label, double below) {
    const Eigen::Vector2d eyes = label.col(45) - label.col(36);
    const double iod = eyes.norm();
    if (!(iod > 0)) return std::numeric_limits<double>::quiet_NaN();
    const Eigen::Vector2d down = Eigen::Vector2d(-eyes.y(), eyes.x()) / iod;
    const Eigen::Vector2d centre = label.col(8) + below * iod * down;
    const int radius = std::max(1, static_cast<int>(std::lround(0.06 * iod)));
    const cv::Point c(static_cast<int>(std::lround(centre.x())), static_cast<int>(std::lround(centre.y())));
    if (c.x - radius < 0 || c.y - radius < 0 || c.x + radius >= gray.cols || c.y + radius >= gray.rows) return std::numeric_limits<double>::quiet_NaN();
    // The disc's square only: a full-image mask per call would cost a photograph's size each time.
    const cv::Rect square(c.x - radius, c.y - radius, 2 * radius + 1, 2 * radius + 1);
    cv::Mat inside = cv::Mat::zeros(square.size(), CV_8UC1);
    cv::circle(inside, cv::Point(radius, radius), radius, cv::Scalar(255), cv::FILLED);
    return cv::mean(gray(square), inside)[0] / 255.0;
}

// 0 for no values.
double median_of(std::vector<double> values) {
    if (values.empty()) return 0;
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    if (values.size() % 2) return *middle;
    return 0.5 * (*middle + *std::max_element(values.begin(), middle));
}

// The image and its label scaled by `scale` (area averaging when shrinking); pixel centres stay at
// integers, as cv::resize maps them.
std::pair<cv::Mat, Eigen::Matrix2Xd> scaled_face(const cv::Mat& gray, const Eigen::Matrix2Xd& label, double scale) {
    cv::Mat scaled;
    cv::resize(gray, scaled, cv::Size(), scale, scale, scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
    return {scaled, ((label.array() + 0.5) * scale - 0.5).matrix()};
}

}  // namespace

double face_detail(const cv::Mat& gray, const Eigen::Matrix2Xd& label) {
    const double iod = morph::inter_ocular_distance(label);
    if (!(std::isfinite(iod) && iod > 0)) return std::numeric_limits<double>::quiet_NaN();
    const auto [scaled, scaled_label] = scaled_face(gray, label, kDetailIodPx / iod);
    const cv::Mat inside = hull_mask(scaled.size(), scaled_label, 2);
    if (cv::countNonZero(inside) == 0) return std::numeric_limits<double>::quiet_NaN();
    cv::Mat grey, laplacian;
    scaled.convertTo(grey, CV_32F, 1.0 / 255.0);
    cv::Laplacian(grey, laplacian, CV_32F, 1);
    cv::Scalar mean, spread;
    cv::meanStdDev(laplacian, mean, spread, inside);
    return spread[0];
}

RealismSide measure_realism(const std::vector<LabelledImage>& images, const LandmarkRegressor& regressor, DetectorKind detector_kind,
                            const std::function<void()>& on_image, std::optional<double> iod_px) {
    if (iod_px && !(std::isfinite(*iod_px) && *iod_px > 0)) throw core::Error("eval realism: the face size to match must be a positive number of pixels");
    RealismSide side;
    side.bias = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks);
    const FaceDetector detector(detector_kind);
    std::vector<double> greys, under_chin, neck, iods, scales, details;
    for (const LabelledImage& image : images) {
        ++side.faces;
        double nme = std::numeric_limits<double>::infinity();
        try {
            auto [truth, gray] = load_labelled_face(image);
            // Before any matching of face sizes: face_detail sets its own.
            if (const double detail = face_detail(gray, truth); std::isfinite(detail)) details.push_back(detail);
            const double iod = morph::inter_ocular_distance(truth);
            if (std::isfinite(iod) && iod > 0) {
                iods.push_back(iod);
                if (iod_px) {
                    const double scale = *iod_px / iod;
                    std::tie(gray, truth) = scaled_face(gray, truth, scale);
                    scales.push_back(scale);
                }
            }
            if (const double grey = hull_grey(gray, truth); std::isfinite(grey)) {
                greys.push_back(grey);
                if (grey > 0) {
                    if (const double g = grey_below_chin(gray, truth, 0.12); std::isfinite(g)) under_chin.push_back(g / grey);
                    if (const double g = grey_below_chin(gray, truth, 0.30); std::isfinite(g)) neck.push_back(g / grey);
                }
            }
            if (const auto box = match_detection(detector.detect(gray), truth)) {
                const Eigen::Matrix2Xd predicted = regressor.predict(gray, *box);
                nme = landmark_nme(predicted, truth);
                side.bias += morph::face_frame_offsets(predicted, truth);
                ++side.detected;
            }
        } catch (const core::Error& e) {
            side.warnings.push_back(std::string(e.what()) + " (counted as a miss)");
        }
        side.nmes.push_back(nme);
        if (on_image) on_image();
    }
    if (side.detected > 0) side.bias /= side.detected;
    if (!greys.empty()) {
        const Eigen::Map<const Eigen::ArrayXd> g(greys.data(), static_cast<Eigen::Index>(greys.size()));
        side.face_grey_mean = g.mean();
        side.face_grey_stddev = std::sqrt((g - g.mean()).square().mean());
    }
    const auto mean = [](const std::vector<double>& values) {
        return values.empty() ? 0.0 : std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
    };
    side.under_chin_shade = mean(under_chin);
    side.neck_shade = mean(neck);
    side.face_detail = mean(details);
    side.iod_px_median = median_of(iods);
    side.scale_median = scales.empty() ? 1.0 : median_of(scales);
    side.nme = summarise_nme(side.nmes);
    return side;
}

namespace {

// Near-frontal images: renders by their true yaw (meta), photographs by `photo_yaw` of their annotation.
std::vector<LabelledImage> near_frontal(const std::vector<LabelledImage>& images, double max_yaw, const AnnotationYaw* photo_yaw) {
    std::vector<LabelledImage> out;
    for (const auto& image : images) {
        std::optional<double> yaw;
        if (!photo_yaw) {
            yaw = read_meta_yaw(image);
        } else {
            try {
                yaw = (*photo_yaw)(morph::read_pts(image.pts));
            } catch (const core::Error&) {
                yaw.reset();  // unreadable: measure_realism reports it when kept
            }
        }
        if (yaw && std::abs(*yaw) <= max_yaw) out.push_back(image);
    }
    return out;
}

void add_side(nlohmann::json& j, const std::string& prefix, const RealismSide& side) {
    j[prefix + "_faces"] = side.faces;
    j[prefix + "_detected"] = side.detected;
    j[prefix + "_nme_mean"] = side.nme.mean;
    j[prefix + "_nme_median"] = side.nme.median;
    j[prefix + "_failure_rate_008"] = side.nme.failure_rate_008;
    j[prefix + "_auc_008"] = side.nme.auc_008;
    j[prefix + "_face_grey_mean"] = side.face_grey_mean;
    j[prefix + "_face_grey_stddev"] = side.face_grey_stddev;
    j[prefix + "_under_chin_shade"] = side.under_chin_shade;
    j[prefix + "_neck_shade"] = side.neck_shade;
    j[prefix + "_face_detail"] = side.face_detail;
    j[prefix + "_iod_px_median"] = side.iod_px_median;
    j[prefix + "_scale_median"] = side.scale_median;
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        char key[48];
        std::snprintf(key, sizeof key, "%s_bias_x_%02d", prefix.c_str(), i + 1);
        j[key] = side.bias(0, i);
        std::snprintf(key, sizeof key, "%s_bias_y_%02d", prefix.c_str(), i + 1);
        j[key] = side.bias(1, i);
    }
}

}  // namespace

RealismReport evaluate_realism(const RealismSettings& settings, const LandmarkRegressor& regressor, DetectorKind detector,
                               const AnnotationYaw& photo_yaw, const std::function<void(std::size_t total)>& on_start,
                               const std::function<void()>& on_image) {
    if (!(settings.max_yaw_deg >= 0 && settings.max_yaw_deg <= 90)) throw core::Error("eval realism: max_yaw must be in [0, 90] degrees");
    const auto renders = near_frontal(list_labelled_images({settings.data}), settings.max_yaw_deg, nullptr);
    if (renders.empty())
        throw core::file_error(settings.data, "no render with |yaw| <= " + std::to_string(settings.max_yaw_deg) +
                                                  "° (needs a facesynth synth dataset with meta/)");
    std::vector<LabelledImage> photos;
    if (!settings.photos.empty()) {
        photos = near_frontal(list_labelled_images({settings.photos}), settings.max_yaw_deg, &photo_yaw);
        if (photos.empty())
            throw core::file_error(settings.photos, "no photograph with |yaw| <= " + std::to_string(settings.max_yaw_deg) + "° by its fitted annotation");
    }
    if (on_start) on_start(renders.size() + photos.size());
    RealismReport report;
    report.renders = measure_realism(renders, regressor, detector, on_image);
    if (!photos.empty()) {
        std::optional<double> photo_iod_px;
        if (settings.match_face_size) {
            if (!(report.renders.iod_px_median > 0)) throw core::file_error(settings.data, "no readable render to take the face size from");
            photo_iod_px = report.renders.iod_px_median;
        }
        report.photos = measure_realism(photos, regressor, detector, on_image, photo_iod_px);
    }
    report.nme_ratio = photos.empty() || !(report.photos.nme.mean > 0) ? 0 : report.renders.nme.mean / report.photos.nme.mean;

    const Eigen::Matrix2Xd gap = photos.empty() ? report.renders.bias : Eigen::Matrix2Xd(report.renders.bias - report.photos.bias);
    report.largest_gaps.resize(morph::kNumIbugLandmarks);
    std::iota(report.largest_gaps.begin(), report.largest_gaps.end(), 0);
    std::stable_sort(report.largest_gaps.begin(), report.largest_gaps.end(), [&](int x, int y) { return gap.col(x).norm() > gap.col(y).norm(); });

    nlohmann::json& j = report.json;
    j["regressor"] = regressor.label();
    j["detector"] = detector_name(detector);
    j["max_yaw_deg"] = settings.max_yaw_deg;
    j["match_face_size"] = settings.match_face_size;
    j["nme_ratio"] = report.nme_ratio;
    add_side(j, "renders", report.renders);
    if (!photos.empty()) add_side(j, "photos", report.photos);
    return report;
}

}  // namespace facesynth::train

