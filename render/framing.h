#pragma once
// A camera that frames a mesh: the `render` command's view (and the Python package's).
#include "morph/mesh.h"
#include "render/renderer.h"

namespace facesynth::render {

struct Framing {
    double yaw = 0, pitch = 0, roll = 0;  // degrees (morph/pose.h)
    int width = 256, height = 256;
    double fov = 30.0;         // vertical, degrees
    double distance = 0.0;     // camera to mesh-centre distance in mm; 0: the mesh fills 80 % of the shorter side
    bool orthographic = false; // scaled so that the mesh fills 80 % of the shorter side (fov and distance unused)
};

// A camera looking at the centre of the mesh's bounding box with the framing's pose.
[[nodiscard]] Camera frame_mesh(const morph::Mesh& mesh, const Framing& framing);

}  // namespace facesynth::render
