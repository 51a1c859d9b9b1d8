#include "synth/neck.h"

#include "morph/regions.h"

#include <cmath>
#include <numbers>

namespace facesynth::synth {
namespace {

// The neck's shape for one face shape, from its landmarks (model space, mm, +y up, +z to the front).
struct NeckFrame {
    float centre_x = 0, centre_z = 0, radius_x = 0, radius_z = 0, top_y = 0, bottom_y = 0;
};

NeckFrame neck_frame(const morph::MorphableModel& model, const Eigen::Matrix3Xf& shape) {
    const Eigen::Matrix3Xf l = model.landmark_positions(shape);
    const Eigen::Vector3f chin = l.col(8);                   // iBUG 9
    const float face_height = l(1, 27) - chin.y();           // nose bridge (iBUG 28) to chin
    const float jaw_width = (l.col(16) - l.col(0)).norm();   // iBUG 1 to 17
    NeckFrame f;
    f.radius_x = 0.38f * jaw_width;
    f.radius_z = 0.85f * f.radius_x;
    f.centre_x = 0.5f * (l(0, 0) + l(0, 16));
    f.centre_z = chin.z() - 0.38f * face_height - f.radius_z;
    f.top_y = chin.y() + 0.35f * face_height;  // inside the head, behind the jaw
    f.bottom_y = chin.y() - 1.1f * face_height;
    return f;
}

Eigen::Vector3f neck_point(const NeckFrame& f, float angle, float y) {
    return {f.centre_x + f.radius_x * std::sin(angle), y, f.centre_z + f.radius_z * std::cos(angle)};
}

}  // namespace

std::optional<NeckTemplate> make_neck_template(const morph::MorphableModel& model) {
    if (model.landmarks.size() < 68 || model.num_vertices() == 0) return std::nullopt;
    NeckTemplate neck;
    neck.first_vertex = model.num_vertices();
    const int rings = neck.rings, segments = neck.segments;
    const auto index = [&](int ring, int segment) { return neck.first_vertex + ring * segments + (segment % segments); };
    for (int r = 0; r + 1 < rings; ++r)
        for (int k = 0; k < segments; ++k) {
            neck.triangles.push_back({index(r, k), index(r + 1, k), index(r, k + 1)});
            neck.triangles.push_back({index(r, k + 1), index(r + 1, k), index(r + 1, k + 1)});
        }
    // Each neck vertex takes the look of the model vertex under the chin nearest in angle round the
    // neck: among the vertices below the mouth, the lowest one in each angular sector of the mean face.
    const Eigen::Matrix3Xf mean = morph::as_points(model.shape.mean);
    const NeckFrame f = neck_frame(model, mean);
    const float mouth_y = model.landmark_positions(mean)(1, 57);  // iBUG 58
    std::vector<int> lowest(static_cast<std::size_t>(segments), -1);
    const float step = 2 * std::numbers::pi_v<float> / static_cast<float>(segments);
    for (int v = 0; v < model.num_vertices(); ++v) {
        const Eigen::Vector3f p = mean.col(v);
        if (!(p.y() < mouth_y)) continue;
        float angle = std::atan2((p.x() - f.centre_x) / f.radius_x, (p.z() - f.centre_z) / f.radius_z);
        // Only the front of the neck takes colours from under the chin (the sides of a head mesh show
        // hair or ears there); the other sectors take the nearest front one's below.
        if (std::abs(angle) > 0.35f * std::numbers::pi_v<float>) continue;
        if (angle < 0) angle += 2 * std::numbers::pi_v<float>;
        const auto sector = static_cast<std::size_t>(std::lround(angle / step)) % static_cast<std::size_t>(segments);
        if (lowest[sector] < 0 || p.y() < mean(1, lowest[sector])) lowest[sector] = v;
    }
    // Sectors without a vertex (the back of a face-only model) take the nearest sector that has one.
    bool any = false;
    for (int v : lowest) any |= v >= 0;
    if (!any) return std::nullopt;
    std::vector<int> filled(lowest.size());
    for (int k = 0; k < segments; ++k)
        for (int d = 0; d <= segments / 2; ++d) {
            const int a = lowest[static_cast<std::size_t>((k + d) % segments)], b = lowest[static_cast<std::size_t>((k - d + segments) % segments)];
            if (a >= 0 || b >= 0) {
                filled[static_cast<std::size_t>(k)] = a >= 0 ? a : b;
                break;
            }
        }
    for (int r = 0; r < rings; ++r)
        for (int k = 0; k < segments; ++k) neck.source.push_back(filled[static_cast<std::size_t>(k)]);
    return neck;
}

void append_neck_vertices(const NeckTemplate& neck, const morph::MorphableModel& model, morph::Mesh& mesh) {
    const NeckFrame f = neck_frame(model, mesh.vertices.leftCols(neck.first_vertex));
    mesh.vertices.conservativeResize(3, neck.first_vertex + neck.rings * neck.segments);
    const float step = 2 * std::numbers::pi_v<float> / static_cast<float>(neck.segments);
    for (int r = 0; r < neck.rings; ++r) {
        const float y = f.top_y + (f.bottom_y - f.top_y) * static_cast<float>(r) / static_cast<float>(neck.rings - 1);
        for (int k = 0; k < neck.segments; ++k) mesh.vertices.col(neck.first_vertex + r * neck.segments + k) = neck_point(f, step * static_cast<float>(k), y);
    }
}

std::vector<morph::Triangle> mesh_triangles_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck) {
    std::vector<morph::Triangle> triangles = model.triangles;
    triangles.insert(triangles.end(), neck.triangles.begin(), neck.triangles.end());
    return triangles;
}

Eigen::Matrix2Xf uv_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck) {
    if (model.uv.cols() != model.num_vertices()) return {};
    Eigen::Matrix2Xf uv(2, neck.first_vertex + static_cast<int>(neck.source.size()));
    uv.leftCols(neck.first_vertex) = model.uv;
    for (std::size_t i = 0; i < neck.source.size(); ++i) uv.col(neck.first_vertex + static_cast<int>(i)) = model.uv.col(neck.source[i]);
    return uv;
}

std::vector<std::uint8_t> labels_with_neck(const morph::MorphableModel& model, const NeckTemplate& neck) {
    if (model.vertex_labels.empty()) return {};
    std::vector<std::uint8_t> labels = model.vertex_labels;
    labels.resize(labels.size() + neck.source.size(), static_cast<std::uint8_t>(morph::Region::kNeck));
    return labels;
}

Eigen::Matrix3Xf colours_with_neck(const Eigen::Matrix3Xf& colours, const NeckTemplate& neck, float shade) {
    Eigen::Matrix3Xf out(3, neck.first_vertex + static_cast<int>(neck.source.size()));
    out.leftCols(neck.first_vertex) = colours.leftCols(neck.first_vertex);
    for (std::size_t i = 0; i < neck.source.size(); ++i) out.col(neck.first_vertex + static_cast<int>(i)) = shade * colours.col(neck.source[i]);
    return out;
}

}  // namespace facesynth::synth
