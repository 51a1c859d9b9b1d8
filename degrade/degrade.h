#pragma once
// What a camera does to an image: downscaling, defocus blur, the camera's own sharpening, gamma and
// white balance, sensor noise, greyscale and JPEG compression, in that order. synth draws a
// DegradationSpec per render (synth/scene.h); train draws one per copy of a training photograph
// (train/image_copies.h).
#include "core/random.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace facesynth::degrade {

// One value per degradation; the neutral value means "not applied".
struct DegradationSpec {
    double blur_sigma = 0;          // px, 0 = none
    double noise_sigma = 0;         // 8-bit levels, 0 = none
    int jpeg_quality = 0;           // 0 = none
    double gamma = 1;               // 1 = none
    Eigen::Vector3d gains = Eigen::Vector3d::Ones();  // per-channel RGB gains, 1 = none
    double downscale = 1;           // 1 = none
    double sharpen_amount = 0;      // unsharp mask: image + amount (image - blurred), 0 = none
    // The whole image in grey, as the photograph the sample's texture came from was (a texture bank's
    // greyscale photographs: ImageLibrary::greyscale); set by the sample generator, not drawn.
    bool greyscale = false;
};

// `image`: 8-bit RGB or 8-bit grey, changed in place; `noise` gives the sensor noise's values (drawn
// only when d.noise_sigma > 0). A grey image takes a gain only where the three are equal: throws
// core::Error otherwise.
void apply(cv::Mat& image, const DegradationSpec& d, core::Rng& noise);

// N(0, sigma) per channel value in 8-bit levels, rounded and clamped to [0, 255].
void add_sensor_noise(cv::Mat& image, double sigma, core::Rng& rng);

}  // namespace facesynth::degrade
