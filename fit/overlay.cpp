#include "fit/overlay.h"

#include "core/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>

namespace facesynth::fit {

cv::Mat draw_fit_overlay(const cv::Mat& image, const Eigen::Matrix2Xd& vertices_px, const std::vector<morph::Triangle>& triangles,
                         const Eigen::Matrix2Xd& observed, const Eigen::Matrix2Xd& fitted) {
    if (image.empty()) throw core::Error("overlay: empty image");
    cv::Mat out;
    if (image.channels() == 1)
        cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
    else if (image.channels() == 4)
        cv::cvtColor(image, out, cv::COLOR_BGRA2BGR);
    else
        out = image.clone();
    if (out.depth() != CV_8U) out.convertTo(out, CV_8U);
    const int thickness = std::max(1, std::min(out.cols, out.rows) / 500);
    const int shift = 4;  // sub-pixel drawing: coordinates in 1/16 pixel
    auto point = [&](const Eigen::Vector2d& p) { return cv::Point(cvRound(p.x() * (1 << shift)), cvRound(p.y() * (1 << shift))); };
    cv::Mat wire = out.clone();
    for (const auto& t : triangles) {
        const Eigen::Vector2d a = vertices_px.col(t[0]), b = vertices_px.col(t[1]), c = vertices_px.col(t[2]);
        if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
        const double cross = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
        if (cross >= 0) continue;  // back-facing
        const cv::Point pts[3] = {point(a), point(b), point(c)};
        cv::polylines(wire, std::vector<std::vector<cv::Point>>{{pts[0], pts[1], pts[2]}}, true, cv::Scalar(255, 200, 60), 1,
                      cv::LINE_AA, shift);
    }
    cv::addWeighted(wire, 0.3, out, 0.7, 0.0, out);
    const int radius = std::max(2, std::min(out.cols, out.rows) / 150);
    for (Eigen::Index i = 0; i < observed.cols(); ++i)
        if (observed.col(i).allFinite())
            cv::circle(out, point(observed.col(i)), radius << shift, cv::Scalar(60, 220, 60), thickness, cv::LINE_AA, shift);
    for (Eigen::Index i = 0; i < fitted.cols(); ++i)
        if (fitted.col(i).allFinite())
            cv::circle(out, point(fitted.col(i)), (radius << shift) / 2, cv::Scalar(40, 40, 240), cv::FILLED, cv::LINE_AA, shift);
    return out;
}

}  // namespace facesynth::fit
