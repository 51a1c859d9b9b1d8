#include "train/metrics.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace facesynth::train {

double ced_at(std::span<const double> nmes, double x) {
    if (nmes.empty()) return 0;
    const auto below = std::count_if(nmes.begin(), nmes.end(), [x](double e) { return e <= x; });
    return static_cast<double>(below) / static_cast<double>(nmes.size());
}

NmeSummary summarise_nme(std::span<const double> nmes, double threshold) {
    NmeSummary s;
    s.count = static_cast<int>(nmes.size());
    if (nmes.empty()) return s;
    std::vector<double> sorted(nmes.begin(), nmes.end());
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    s.median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    double sum = 0;
    int finite = 0;
    for (double e : sorted)
        if (std::isfinite(e)) {
            sum += e;
            ++finite;
        }
    s.mean = finite ? sum / finite : std::numeric_limits<double>::infinity();
    s.failure_rate_008 = 1.0 - ced_at(nmes, threshold);
    // Exact area under the CED step function: each face below the threshold contributes (t - e).
    double area = 0;
    for (double e : sorted)
        if (e < threshold) area += threshold - e;
    s.auc_008 = area / (threshold * static_cast<double>(n));
    return s;
}

std::string ced_png(std::span<const CedCurve> curves, double max_nme) {
    constexpr int kWidth = 640, kHeight = 480, kLeft = 70, kRight = 20, kTop = 30, kBottom = 60;
    const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
    const auto at = [&](double nme, double share) {
        return cv::Point2d(kLeft + plot_w * nme / max_nme, kTop + plot_h * (1 - share));
    };
    cv::Mat image(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
    const auto text = [&](const std::string& s, cv::Point2d p, const cv::Scalar& colour = cv::Scalar(0, 0, 0)) {
        cv::putText(image, s, p, cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
    };
    char buf[32];
    for (int i = 0; i <= 8; ++i) {
        const double x = max_nme * i / 8;
        cv::line(image, at(x, 0), at(x, 1), cv::Scalar(220, 220, 220));
        std::snprintf(buf, sizeof(buf), "%.2f", x);
        text(buf, at(x, 0) + cv::Point2d(-14, 18));
    }
    for (int i = 0; i <= 10; ++i) {
        cv::line(image, at(0, i / 10.0), at(max_nme, i / 10.0), cv::Scalar(220, 220, 220));
        std::snprintf(buf, sizeof(buf), "%.1f", i / 10.0);
        text(buf, at(0, i / 10.0) + cv::Point2d(-30, 5));
    }
    text("NME (inter-ocular)", cv::Point2d(kLeft + plot_w / 2 - 70, kHeight - 15));
    text("share of faces", cv::Point2d(5, kTop - 10));
    static const cv::Scalar kColours[] = {{180, 119, 31}, {40, 39, 214}, {44, 160, 44}, {14, 127, 255}, {189, 103, 148}};
    for (std::size_t c = 0; c < curves.size(); ++c) {
        std::vector<double> sorted = curves[c].nmes;
        std::sort(sorted.begin(), sorted.end());
        const double n = static_cast<double>(std::max<std::size_t>(sorted.size(), 1));
        std::vector<cv::Point> points{at(0, 0)};
        double share = 0;
        for (std::size_t i = 0; i < sorted.size() && sorted[i] <= max_nme; ++i) {
            points.push_back(at(sorted[i], share));
            share = static_cast<double>(i + 1) / n;
            points.push_back(at(sorted[i], share));
        }
        points.push_back(at(max_nme, share));
        const cv::Scalar colour = kColours[c % std::size(kColours)];
        cv::polylines(image, points, false, colour, 2, cv::LINE_AA);
        text(curves[c].label, cv::Point2d(kLeft + 10, kTop + 18 + 18.0 * static_cast<double>(c)), colour);
    }
    std::vector<unsigned char> png;
    cv::imencode(".png", image, png);
    return {png.begin(), png.end()};
}

}  // namespace facesynth::train
