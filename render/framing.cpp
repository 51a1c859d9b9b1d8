#include "render/framing.h"

#include "morph/camera.h"
#include "morph/pose.h"

#include <algorithm>

namespace facesynth::render {

Camera frame_mesh(const morph::Mesh& mesh, const Framing& f) {
    const Eigen::Vector3f low = mesh.vertices.rowwise().minCoeff(), high = mesh.vertices.rowwise().maxCoeff();
    const Eigen::Vector3d centre = (0.5f * (low + high)).cast<double>();
    const double extent = std::max(high.x() - low.x(), high.y() - low.y());
    Camera camera;
    camera.pose.rotation = morph::rotation_from_euler({f.yaw, f.pitch, f.roll});
    const double fill = 0.8 * std::min(f.width, f.height);
    camera.intrinsics = morph::intrinsics_from_fov(f.fov, f.width, f.height);
    if (f.orthographic) {
        camera.projection = Projection::kOrthographic;
        camera.intrinsics.fx = camera.intrinsics.fy = fill / extent;
    }
    const double distance = f.distance > 0 ? f.distance
                                           : 0.5 * extent * camera.intrinsics.fy / (0.5 * fill) + 0.5 * static_cast<double>(high.z() - low.z());
    camera.pose.translation = -(morph::model_to_camera_flip() * camera.pose.rotation * centre) + Eigen::Vector3d(0, 0, distance);
    return camera;
}

}  // namespace facesynth::render
