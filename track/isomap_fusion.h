#pragma once
// A face's texture fused over the frames of a video (docs/track.md): every frame's isomap (alpha =
// 255 cos θ of the view, frontal/isomap.h) is offered texel by texel, and the frame that saw a texel
// most frontally wins it, so the far side fills in as the head turns.
#include <opencv2/core.hpp>

namespace facesynth::track {

class IsomapFusion {
public:
    // `isomap`: CV_8UC4 B G R A of the fused size (the first one sets it). Throws core::Error on a
    // different size or type.
    void add(const cv::Mat& isomap);
    [[nodiscard]] const cv::Mat& fused() const { return fused_; }  // CV_8UC4; empty before the first add
    [[nodiscard]] int frames() const { return frames_; }
    // Share of the layout's texels seen in some frame (alpha > 0), over `layout` (CV_8UC1, non-zero
    // inside the uv layout).
    [[nodiscard]] double coverage(const cv::Mat& layout) const;

private:
    cv::Mat fused_;
    int frames_ = 0;
};

}  // namespace facesynth::track
