#include "recognition/appearance.h"

#include "core/error.h"

#include <opencv2/face.hpp>
#include <opencv2/imgproc.hpp>

namespace facesynth::recognition {

cv::Mat lbph_descriptor(const cv::Mat& grey, const LbphSettings& settings) {
    if (grey.empty() || grey.type() != CV_8UC1) throw core::Error("LBPH descriptor: needs a non-empty 8-bit grey image");
    const cv::Ptr<cv::face::LBPHFaceRecognizer> lbph =
        cv::face::LBPHFaceRecognizer::create(settings.radius, settings.neighbours, settings.grid, settings.grid);
    lbph->train(std::vector<cv::Mat>{grey}, std::vector<int>{0});
    return lbph->getHistograms().front().clone();
}

double lbph_distance(const cv::Mat& a, const cv::Mat& b) {
    if (a.empty() || a.size() != b.size() || a.type() != b.type()) throw core::Error("LBPH distance: descriptors of different settings");
    return cv::compareHist(a, b, cv::HISTCMP_CHISQR_ALT);
}

}  // namespace facesynth::recognition
