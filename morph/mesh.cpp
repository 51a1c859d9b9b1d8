#include "morph/mesh.h"

#include <Eigen/Geometry>

namespace facesynth::morph {

Eigen::Matrix3Xf vertex_normals(const Eigen::Matrix3Xf& vertices, const std::vector<Triangle>& triangles) {
    Eigen::Matrix3Xf normals = Eigen::Matrix3Xf::Zero(3, vertices.cols());
    for (const auto& t : triangles) {
        const Eigen::Vector3f a = vertices.col(t[0]), b = vertices.col(t[1]), c = vertices.col(t[2]);
        const Eigen::Vector3f face_normal = (b - a).cross(c - a);  // length = 2 × area: area weighting
        for (int v : t) normals.col(v) += face_normal;
    }
    for (Eigen::Index i = 0; i < normals.cols(); ++i) {
        const float n = normals.col(i).norm();
        if (n > 0) normals.col(i) /= n;
    }
    return normals;
}

}  // namespace facesynth::morph
