#include "morph/pose.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace facesynth::morph {
namespace {

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }
double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

}  // namespace

Eigen::Matrix3d rotation_from_euler(const EulerAngles& angles) {
    const double y = radians(angles.yaw), p = radians(angles.pitch), r = radians(angles.roll);
    Eigen::Matrix3d ry, rx, rz;
    ry << std::cos(y), 0, std::sin(y),  //
        0, 1, 0,                        //
        -std::sin(y), 0, std::cos(y);
    // Right-handed rotation about +x by -pitch, so that positive pitch lifts the nose.
    rx << 1, 0, 0,                      //
        0, std::cos(p), std::sin(p),    //
        0, -std::sin(p), std::cos(p);
    rz << std::cos(r), -std::sin(r), 0,  //
        std::sin(r), std::cos(r), 0,     //
        0, 0, 1;
    return rz * rx * ry;
}

EulerAngles euler_from_rotation(const Eigen::Matrix3d& m) {
    // From m = Rz(r) Rx(p) Ry(y): m(2,1) = -sin p, m(2,0) = -cos p sin y, m(2,2) = cos p cos y,
    // m(0,1) = -sin r cos p, m(1,1) = cos r cos p.
    EulerAngles a;
    const double sin_pitch = std::clamp(-m(2, 1), -1.0, 1.0);
    a.pitch = degrees(std::asin(sin_pitch));
    if (std::abs(sin_pitch) < 1.0 - 1e-9) {
        a.yaw = degrees(std::atan2(-m(2, 0), m(2, 2)));
        a.roll = degrees(std::atan2(-m(0, 1), m(1, 1)));
    } else {
        // Gimbal lock: yaw and roll share one axis; put it all into yaw.
        a.roll = 0;
        a.yaw = degrees(std::atan2(m(0, 2), m(0, 0)));
    }
    return a;
}

}  // namespace facesynth::morph
