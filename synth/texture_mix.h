#pragma once
// New skin from two textures of a bank: one texture's features (brows, eyes, lips, pores, the edges its
// fitted shape was made for) under the coarse colour of another (tone, blotches, beard shadow, what
// shading the de-lighting left). Both are isomaps of one model, so texel (u, v) is the same point of
// the face in each.
#include <opencv2/core.hpp>

namespace facesynth::synth {

// The features' linear albedo times (coarse(colour) / coarse(features))^weight, where coarse() keeps what
// varies over more than 1/16 of the map's side (area-averaged to a 16th, then bilinear back): weight 0
// gives `features`, 1 its features on `colour`'s coarse colour. `colour` is resized to `features`' size
// when they differ. Both 8-bit sRGB.
void mix_coarse_colour(const cv::Mat& features, const cv::Mat& colour, double weight, cv::Mat& out);

}  // namespace facesynth::synth
