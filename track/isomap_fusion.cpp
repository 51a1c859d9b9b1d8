#include "track/isomap_fusion.h"

#include "core/error.h"

#include <string>

namespace facesynth::track {

void IsomapFusion::add(const cv::Mat& isomap) {
    if (isomap.type() != CV_8UC4) throw core::Error("isomap fusion: an isomap is 8-bit BGRA");
    if (fused_.empty()) fused_ = cv::Mat::zeros(isomap.size(), CV_8UC4);
    if (isomap.size() != fused_.size())
        throw core::Error("isomap fusion: a " + std::to_string(isomap.cols) + " px isomap cannot join " + std::to_string(fused_.cols) + " px ones");
    for (int y = 0; y < isomap.rows; ++y) {
        const auto* in = isomap.ptr<cv::Vec4b>(y);
        auto* out = fused_.ptr<cv::Vec4b>(y);
        for (int x = 0; x < isomap.cols; ++x)
            if (in[x][3] > out[x][3]) out[x] = in[x];
    }
    ++frames_;
}

double IsomapFusion::coverage(const cv::Mat& layout) const {
    if (fused_.empty() || layout.size() != fused_.size()) return 0;
    int inside = 0, seen = 0;
    for (int y = 0; y < layout.rows; ++y)
        for (int x = 0; x < layout.cols; ++x)
            if (layout.at<unsigned char>(y, x) != 0) {
                ++inside;
                if (fused_.at<cv::Vec4b>(y, x)[3] > 0) ++seen;
            }
    return inside > 0 ? static_cast<double>(seen) / inside : 0.0;
}

}  // namespace facesynth::track
