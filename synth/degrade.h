#pragma once
// What a camera does to a rendered image: downscaling, defocus blur, the camera's own sharpening,
// gamma and white balance, sensor noise and JPEG compression, in that order (DegradationSpec, drawn by
// synth/scene.h).
#include "core/random.h"
#include "synth/scene.h"

#include <opencv2/core.hpp>

#include <cstdint>

namespace facesynth::synth {

// `image`: 8-bit RGB, changed in place. The noise draws from stream kNoise of (seed, index).
void degrade(cv::Mat& image, const DegradationSpec& d, std::uint64_t seed, std::int64_t index);

// N(0, sigma) per channel value in 8-bit levels, rounded and clamped to [0, 255].
void add_sensor_noise(cv::Mat& image, double sigma, core::Rng& rng);

}  // namespace facesynth::synth
