#include "fit/contour.h"

#include "core/error.h"
#include "morph/landmarks.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <limits>
#include <unordered_map>

namespace facesynth::fit {

std::vector<Edge> edge_topology(const std::vector<morph::Triangle>& triangles, int num_vertices) {
    std::unordered_map<long long, int> index;  // (a, b) -> position in `edges`
    index.reserve(triangles.size() * 2);
    std::vector<Edge> edges;
    edges.reserve(triangles.size() * 3 / 2 + 16);
    for (std::size_t t = 0; t < triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            int a = triangles[t][static_cast<std::size_t>(k)], b = triangles[t][static_cast<std::size_t>((k + 1) % 3)];
            if (a == b) continue;
            if (a > b) std::swap(a, b);
            const long long key = static_cast<long long>(a) * num_vertices + b;
            const auto [it, inserted] = index.try_emplace(key, static_cast<int>(edges.size()));
            if (inserted) {
                edges.push_back({a, b, static_cast<int>(t), -1});
            } else if (edges[static_cast<std::size_t>(it->second)].right < 0) {
                edges[static_cast<std::size_t>(it->second)].right = static_cast<int>(t);
            }  // a third triangle on one edge (non-manifold) is ignored
        }
    }
    return edges;
}

ContourFinder::ContourFinder(const morph::MorphableModel& model) : model_(model), region_(morph::jaw_contour_region(model)) {
    const int v = model.num_vertices();
    edges_ = edge_topology(model.triangles, v);
    const auto mean = morph::as_points(model.shape.mean);
    triangle_normals_.resize(3, static_cast<Eigen::Index>(model.triangles.size()));
    for (std::size_t t = 0; t < model.triangles.size(); ++t) {
        const auto& tri = model.triangles[t];
        const Eigen::Vector3f e1 = mean.col(tri[1]) - mean.col(tri[0]), e2 = mean.col(tri[2]) - mean.col(tri[0]);
        triangle_normals_.col(static_cast<Eigen::Index>(t)) = e1.cross(e2);
    }

    // The region's rows of the shape and expression models (a PCA expression's mean is an offset).
    const auto rows = static_cast<Eigen::Index>(3 * region_.vertices.size());
    const Eigen::MatrixXf shape_basis = model.shape.rescaled_basis();
    region_mean_.resize(rows);
    region_shape_basis_.resize(rows, shape_basis.cols());
    const morph::PcaModel* expression_pca = model.expression ? std::get_if<morph::PcaModel>(&*model.expression) : nullptr;
    const auto* blendshapes = model.expression ? std::get_if<std::vector<morph::Blendshape>>(&*model.expression) : nullptr;
    Eigen::MatrixXf expression_basis;
    if (expression_pca) expression_basis = expression_pca->rescaled_basis();
    if (blendshapes) {
        expression_basis.resize(3 * v, static_cast<Eigen::Index>(blendshapes->size()));
        for (std::size_t b = 0; b < blendshapes->size(); ++b) expression_basis.col(static_cast<Eigen::Index>(b)) = (*blendshapes)[b].offsets;
    }
    region_expression_basis_.resize(rows, expression_basis.cols());
    for (std::size_t r = 0; r < region_.vertices.size(); ++r) {
        const Eigen::Index from = 3 * region_.vertices[r], to = static_cast<Eigen::Index>(3 * r);
        region_mean_.segment<3>(to) = model.shape.mean.segment<3>(from);
        if (expression_pca) region_mean_.segment<3>(to) += expression_pca->mean.segment<3>(from);
        region_shape_basis_.middleRows<3>(to) = shape_basis.middleRows<3>(from);
        if (expression_basis.cols() > 0) region_expression_basis_.middleRows<3>(to) = expression_basis.middleRows<3>(from);
    }

    // The fallback's candidate region: the same jaw band as the shared definition (morph/jaw_contour.h).
    const morph::JawBand band = morph::jaw_band(model);
    side_.resize(static_cast<std::size_t>(v));
    in_face_region_.resize(static_cast<std::size_t>(v));
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = mean.col(i);
        side_[static_cast<std::size_t>(i)] = band.side(p);
        in_face_region_[static_cast<std::size_t>(i)] = band.contains(p);
    }
}

std::vector<int> ContourFinder::occluding_vertices(const Eigen::Matrix3d& rotation) const {
    // A triangle faces the camera when its rotated normal points to model-camera +z (the flip turns
    // it into camera -z, toward the viewer).
    const Eigen::RowVector3f view = rotation.row(2).cast<float>();
    const Eigen::RowVectorXf facing = view * triangle_normals_;
    std::vector<char> mark(static_cast<std::size_t>(model_.num_vertices()), 0);
    for (const auto& e : edges_) {
        const bool left_front = facing(e.left) > 0;
        const bool occluding = e.right < 0 ? left_front : left_front != (facing(e.right) > 0);
        if (occluding) mark[static_cast<std::size_t>(e.a)] = mark[static_cast<std::size_t>(e.b)] = 1;
    }
    std::vector<int> out;
    for (std::size_t i = 0; i < mark.size(); ++i)
        if (mark[i]) out.push_back(static_cast<int>(i));
    return out;
}

std::vector<int> ContourFinder::candidates(const Eigen::Matrix3d& rotation) const {
    std::vector<int> out;
    for (int id : occluding_vertices(rotation))
        if (in_face_region_[static_cast<std::size_t>(id)]) out.push_back(id);
    for (const auto* chain : {&model_.contour.right, &model_.contour.left}) out.insert(out.end(), chain->begin(), chain->end());
    return out;
}

template <class Project, class PositionOf>
std::vector<std::optional<morph::SurfacePoint>> ContourFinder::choose(const Eigen::Matrix2Xd& landmarks, const Eigen::Matrix3d& rotation,
                                                               Project&& project, const std::vector<int>& jaw_indices,
                                                               PositionOf&& position_of,
                                                               const Eigen::Matrix3Xf* region_positions) const {
    std::vector<std::optional<morph::SurfacePoint>> result(morph::kNumJawLandmarks);
    const int far = morph::far_side(rotation);
    auto fixed_defined = [&](int j) {
        if (j >= static_cast<int>(model_.landmarks.size())) return false;
        const morph::SurfacePoint& p = model_.landmarks[static_cast<std::size_t>(j)];
        for (int id : p.vertices)
            if (id < 0 || id >= model_.num_vertices()) return false;
        return p.weights[0] + p.weights[1] + p.weights[2] > 0.5f;
    };

    // The shared definition: far side on the face region's outline, near side on the fixed jaw line.
    Eigen::Matrix2Xd region_projected;
    std::vector<int> fallback;
    std::vector<morph::JawContourQuery> contour_queries;  // far-side points, searched together
    std::vector<int> contour_landmarks;
    for (int j : jaw_indices) {
        if (j < 0 || j >= morph::kNumJawLandmarks || j == morph::kChinLandmark) continue;
        if (!fixed_defined(j) || region_.vertices.empty()) {
            fallback.push_back(j);
            continue;
        }
        if (!morph::jaw_on_side(j, far)) {
            result[static_cast<std::size_t>(j)] = model_.landmarks[static_cast<std::size_t>(j)];
            continue;
        }
        if (region_projected.cols() == 0) {
            region_projected.resize(2, static_cast<Eigen::Index>(region_.vertices.size()));
            for (std::size_t r = 0; r < region_.vertices.size(); ++r)
                region_projected.col(static_cast<Eigen::Index>(r)) =
                    project(region_positions ? Eigen::Vector3d(region_positions->col(static_cast<Eigen::Index>(r)).cast<double>())
                                             : position_of(region_.vertices[r]));
        }
        // The face's horizontal image direction at the fixed point (the projected model x axis).
        const morph::SurfacePoint& fixed = model_.landmarks[static_cast<std::size_t>(j)];
        Eigen::Vector3d x = Eigen::Vector3d::Zero();
        for (int k = 0; k < 3; ++k) x += static_cast<double>(fixed.weights[static_cast<std::size_t>(k)]) * position_of(fixed.vertices[static_cast<std::size_t>(k)]);
        const Eigen::Vector2d toward_left = (project(Eigen::Vector3d(x + Eigen::Vector3d::UnitX())) - project(x)).normalized();
        contour_queries.push_back({landmarks.col(j), j < morph::kChinLandmark ? Eigen::Vector2d(-toward_left) : toward_left});
        contour_landmarks.push_back(j);
    }
    const auto hits = morph::jaw_contour_points(region_, region_projected, contour_queries);
    for (std::size_t q = 0; q < hits.size(); ++q) {
        const auto j = static_cast<std::size_t>(contour_landmarks[q]);
        result[j] = hits[q] ? hits[q]->point : model_.landmarks[j];
    }
    if (fallback.empty()) return result;

    // Models without fixed jaw points: the nearest candidate on the landmark's side (eos).
    const std::vector<int> cand = candidates(rotation);
    Eigen::Matrix2Xd projected(2, static_cast<Eigen::Index>(cand.size()));
    for (std::size_t c = 0; c < cand.size(); ++c) projected.col(static_cast<Eigen::Index>(c)) = project(position_of(cand[c]));
    for (int j : fallback) {
        const signed char wanted_side = j < morph::kChinLandmark ? -1 : 1;
        double best = std::numeric_limits<double>::max();
        for (std::size_t c = 0; c < cand.size(); ++c) {
            if (side_[static_cast<std::size_t>(cand[c])] != wanted_side) continue;
            const double d = (projected.col(static_cast<Eigen::Index>(c)) - landmarks.col(j)).squaredNorm();
            if (d < best) {
                best = d;
                result[static_cast<std::size_t>(j)] = morph::SurfacePoint::at_vertex(cand[c]);
            }
        }
    }
    return result;
}

std::vector<std::optional<morph::SurfacePoint>> ContourFinder::jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                    const Eigen::Matrix3Xf& vertices,
                                                    const std::vector<int>& jaw_indices) const {
    const Eigen::Matrix<double, 2, 3> m = camera.scale * (morph::model_to_camera_flip() * camera.rotation).topRows<2>();
    return choose(landmarks, camera.rotation, [&](const Eigen::Vector3d& x) -> Eigen::Vector2d { return m * x + camera.translation; },
                  jaw_indices, [&](int id) -> Eigen::Vector3d { return vertices.col(id).cast<double>(); });
}

std::function<Eigen::Vector3d(int)> ContourFinder::position_function(const std::vector<float>& alpha,
                                                                   const std::vector<float>& psi) const {
    const auto& shape = model_.shape;
    const int k = std::min<int>(static_cast<int>(alpha.size()), shape.num_components());
    Eigen::VectorXf scaled_alpha(k);
    for (int c = 0; c < k; ++c) scaled_alpha[c] = alpha[static_cast<std::size_t>(c)] * std::sqrt(shape.eigenvalues[c]);
    const morph::PcaModel* expression_pca = model_.expression ? std::get_if<morph::PcaModel>(&*model_.expression) : nullptr;
    const auto* blendshapes = model_.expression ? std::get_if<std::vector<morph::Blendshape>>(&*model_.expression) : nullptr;
    Eigen::VectorXf scaled_psi;
    if (expression_pca) {
        const int e = std::min<int>(static_cast<int>(psi.size()), expression_pca->num_components());
        scaled_psi.resize(e);
        for (int c = 0; c < e; ++c) scaled_psi[c] = psi[static_cast<std::size_t>(c)] * std::sqrt(expression_pca->eigenvalues[c]);
    }
    return [this, k, scaled_alpha, scaled_psi, expression_pca, blendshapes, psi](int id) -> Eigen::Vector3d {
        const morph::PcaModel& pca = model_.shape;
        Eigen::Vector3f p = pca.mean.segment<3>(3 * id) + pca.basis.block(3 * id, 0, 3, k) * scaled_alpha;
        if (expression_pca) {
            p += expression_pca->mean.segment<3>(3 * id) +
                 expression_pca->basis.block(3 * id, 0, 3, scaled_psi.size()) * scaled_psi;
        } else if (blendshapes) {
            for (std::size_t b = 0; b < blendshapes->size() && b < psi.size(); ++b)
                p += psi[b] * (*blendshapes)[b].offsets.segment<3>(3 * id);
        }
        return p.cast<double>();
    };
}

Eigen::Matrix3Xf ContourFinder::region_positions(const std::vector<float>& alpha, const std::vector<float>& psi) const {
    Eigen::VectorXf stacked = region_mean_;
    const auto k = std::min<Eigen::Index>(static_cast<Eigen::Index>(alpha.size()), region_shape_basis_.cols());
    if (k > 0) stacked.noalias() += region_shape_basis_.leftCols(k) * Eigen::Map<const Eigen::VectorXf>(alpha.data(), k);
    const auto e = std::min<Eigen::Index>(static_cast<Eigen::Index>(psi.size()), region_expression_basis_.cols());
    if (e > 0) stacked.noalias() += region_expression_basis_.leftCols(e) * Eigen::Map<const Eigen::VectorXf>(psi.data(), e);
    return Eigen::Map<const Eigen::Matrix3Xf>(stacked.data(), 3, stacked.size() / 3);
}

namespace {
Eigen::Matrix<double, 2, 3> affine_rows(const ScaledOrthographic& camera) {
    return camera.scale * (morph::model_to_camera_flip() * camera.rotation).topRows<2>();
}
}  // namespace

std::vector<std::optional<morph::SurfacePoint>> ContourFinder::jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const ScaledOrthographic& camera,
                                                    const std::vector<float>& alpha, const std::vector<float>& psi,
                                                    const std::vector<int>& jaw_indices) const {
    const Eigen::Matrix<double, 2, 3> m = affine_rows(camera);
    const Eigen::Matrix3Xf region = region_positions(alpha, psi);
    return choose(landmarks, camera.rotation, [&](const Eigen::Vector3d& x) -> Eigen::Vector2d { return m * x + camera.translation; },
                  jaw_indices, position_function(alpha, psi), &region);
}

std::vector<std::optional<morph::SurfacePoint>> ContourFinder::jaw_correspondences(const Eigen::Matrix2Xd& landmarks, const PinholeView& camera,
                                                    const std::vector<float>& alpha, const std::vector<float>& psi,
                                                    const std::vector<int>& jaw_indices) const {
    const Eigen::Matrix3d m = morph::model_to_camera_flip() * camera.rotation;
    const Eigen::Matrix3Xf region = region_positions(alpha, psi);
    return choose(landmarks, camera.rotation, [&](const Eigen::Vector3d& x) -> Eigen::Vector2d {
        const Eigen::Vector3d c = m * x + camera.translation;
        return Eigen::Vector2d(camera.focal * c.x() / c.z() + camera.cx, camera.focal * c.y() / c.z() + camera.cy);
    }, jaw_indices, position_function(alpha, psi), &region);
}

}  // namespace facesynth::fit
