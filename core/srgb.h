#pragma once
// The sRGB transfer function (IEC 61966-2-1): how 8-bit textures and images store linear values.
#include <algorithm>
#include <cmath>

namespace facesynth::core {

// Linear value in [0, 1] (clamped) to its sRGB encoding in [0, 1].
[[nodiscard]] inline double srgb_encode(double linear) {
    const double x = std::clamp(linear, 0.0, 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
}

// sRGB encoding in [0, 1] to the linear value.
[[nodiscard]] inline double srgb_decode(double encoded) {
    return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

}  // namespace facesynth::core
