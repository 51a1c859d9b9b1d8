#include "render/ambient_occlusion.h"

#include "core/error.h"
#include "render/zbuffer.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>
#include <string>

namespace facesynth::render {

Eigen::VectorXf ambient_visibility(const Eigen::Matrix3Xf& mesh_vertices, const std::vector<morph::Triangle>& mesh_triangles,
                                   const Eigen::Matrix3Xf& points, const Eigen::Matrix3Xf& normals, const AmbientOcclusionOptions& options) {
    if (points.cols() != normals.cols())
        throw core::Error("ambient occlusion: " + std::to_string(points.cols()) + " points but " + std::to_string(normals.cols()) + " normals");
    if (options.directions < 1 || !(options.texel_mm > 0) || !(options.bias_mm >= 0))
        throw core::Error("ambient occlusion: needs at least one direction, a positive texel size and a bias of at least 0");
    const Eigen::Index count = points.cols();
    Eigen::VectorXf open = Eigen::VectorXf::Zero(count), total = Eigen::VectorXf::Zero(count);
    if (count == 0 || mesh_vertices.cols() == 0) return Eigen::VectorXf::Ones(count);
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < options.directions; ++k) {
        // Fibonacci lattice: z evenly spaced, the azimuth turning by the golden angle.
        const double z = 1.0 - (2.0 * k + 1.0) / options.directions;
        const double radius = std::sqrt(std::max(0.0, 1.0 - z * z));
        const Eigen::Vector3f toward(static_cast<float>(radius * std::cos(golden * k)), static_cast<float>(radius * std::sin(golden * k)),
                                     static_cast<float>(z));
        // A camera far out along `toward` looking back: right-handed OpenCV axes, z into the scene.
        const Eigen::Vector3f axis_z = -toward;
        const Eigen::Vector3f helper = std::abs(axis_z.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
        const Eigen::Vector3f axis_x = helper.cross(axis_z).normalized();
        const Eigen::Vector3f axis_y = axis_z.cross(axis_x);
        Eigen::Matrix3f view;
        view.row(0) = axis_x.transpose();
        view.row(1) = axis_y.transpose();
        view.row(2) = axis_z.transpose();
        const Eigen::Matrix3Xf seen = view * mesh_vertices;
        const Eigen::Vector3f low = seen.rowwise().minCoeff(), high = seen.rowwise().maxCoeff();
        const int width = static_cast<int>(std::ceil((high.x() - low.x()) / options.texel_mm)) + 2;
        const int height = static_cast<int>(std::ceil((high.y() - low.y()) / options.texel_mm)) + 2;
        const Eigen::Vector2f origin(low.x() - options.texel_mm, low.y() - options.texel_mm);
        const Eigen::Matrix2Xf pixels = (seen.topRows<2>().colwise() - origin) / options.texel_mm;
        // Depth from a plane in front of everything, so that the z-buffer's 0 can mean "nothing here".
        const Eigen::RowVectorXf depth = seen.row(2).array() - (low.z() - 1.0f);
        const cv::Mat nearest = orthographic_zbuffer(pixels, std::span(depth.data(), static_cast<std::size_t>(depth.size())), mesh_triangles, width, height);
        for (Eigen::Index p = 0; p < count; ++p) {
            const float weight = normals.col(p).dot(toward);
            if (!(weight > 0)) continue;
            total[p] += weight;
            const Eigen::Vector3f q = view * points.col(p);
            const int x = static_cast<int>(std::lround((q.x() - origin.x()) / options.texel_mm));
            const int y = static_cast<int>(std::lround((q.y() - origin.y()) / options.texel_mm));
            const float surface = x >= 0 && y >= 0 && x < width && y < height ? nearest.at<float>(y, x) : 0.0f;
            if (surface == 0.0f || q.z() - (low.z() - 1.0f) <= surface + options.bias_mm) open[p] += weight;
        }
    }
    Eigen::VectorXf visibility(count);
    for (Eigen::Index p = 0; p < count; ++p) visibility[p] = total[p] > 0 ? open[p] / total[p] : 1.0f;
    return visibility;
}

}  // namespace facesynth::render
