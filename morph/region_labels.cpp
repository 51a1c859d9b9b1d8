#include "morph/region_labels.h"

#include "morph/landmarks.h"
#include "morph/polygon.h"
#include "morph/regions.h"

#include <algorithm>
#include <initializer_list>
#include <limits>
#include <optional>

namespace facesynth::morph {
namespace {

// The landmarks of the mean shape in the frontal view (x, y) and their depth z, with the sizes the
// regions are built from.
struct FrontalLandmarks {
    Eigen::Matrix3Xf points;  // 3 x 68, model space of the mean shape
    float iod = 0;            // outer eye corners' distance in the frontal view

    [[nodiscard]] Eigen::Vector2f at(int id) const { return points.col(id).head<2>(); }
    [[nodiscard]] std::vector<Eigen::Vector2f> polygon(int first, int last) const {
        std::vector<Eigen::Vector2f> out;
        for (int id = first; id <= last; ++id) out.push_back(at(id));
        return out;
    }
    [[nodiscard]] float min_z(int first, int last) const {
        return points.block(2, first, 1, last - first + 1).minCoeff();
    }
};

bool within(const Eigen::Vector2f& q, const std::vector<Eigen::Vector2f>& polygon, float margin) {
    if (inside_polygon(q, polygon)) return true;
    for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
        if (segment_distance(q, polygon[j], polygon[i]) <= margin) return true;
    return false;
}

float polyline_distance(const Eigen::Vector2f& q, const FrontalLandmarks& l, int first, int last) {
    float best = std::numeric_limits<float>::max();
    for (int id = first; id < last; ++id) best = std::min(best, segment_distance(q, l.at(id), l.at(id + 1)));
    return best;
}

// The nose seen from the front: the bridge from iBUG 28 down, widening to the alae beside the
// nostrils (iBUG 32 and 36 pushed out by 30 % from the base centre, iBUG 34), closed by the base.
std::vector<Eigen::Vector2f> nose_polygon(const FrontalLandmarks& l) {
    const Eigen::Vector2f top = l.at(27), middle = l.at(29), tip = l.at(30), base = l.at(33);
    const float bridge = 0.08f * l.iod, dorsum = 0.11f * l.iod;
    const Eigen::Vector2f right_ala(base.x() + 1.3f * (l.at(31).x() - base.x()), l.at(31).y());
    const Eigen::Vector2f left_ala(base.x() + 1.3f * (l.at(35).x() - base.x()), l.at(35).y());
    return {{top.x() - bridge, top.y()}, {middle.x() - dorsum, middle.y()}, {right_ala.x(), tip.y()}, right_ala,
            l.at(32), base, l.at(34), left_ala, {left_ala.x(), tip.y()}, {middle.x() + dorsum, middle.y()},
            {top.x() + bridge, top.y()}};
}

// The height of the lower jaw line (iBUG 4-14, the mandible's lower border in the frontal view) at
// x, or nothing beside it.
std::optional<float> lower_jaw_height(const FrontalLandmarks& l, float x) {
    std::optional<float> lowest;
    for (int id = 3; id < 13; ++id) {
        const Eigen::Vector2f a = l.at(id), b = l.at(id + 1);
        if (a.x() == b.x() || x < std::min(a.x(), b.x()) || x > std::max(a.x(), b.x())) continue;
        const float y = a.y() + (x - a.x()) / (b.x() - a.x()) * (b.y() - a.y());
        lowest = lowest ? std::min(*lowest, y) : y;
    }
    return lowest;
}

}  // namespace

std::vector<std::uint8_t> derive_region_labels(const MorphableModel& model) {
    if (model.landmarks.size() != static_cast<std::size_t>(kNumIbugLandmarks) || model.shape.empty()) return {};
    const int v = model.num_vertices();
    for (const SurfacePoint& p : model.landmarks)
        for (int id : p.vertices)
            if (id < 0 || id >= v) return {};
    const Eigen::Matrix3Xf mean = as_points(model.shape.mean);
    FrontalLandmarks l{model.landmark_positions(mean), 0.0f};
    l.iod = (l.at(kRightEyeOuterCorner) - l.at(kLeftEyeOuterCorner)).norm();
    if (!(l.iod > 0.0f)) return {};

    // 0-based iBUG ids: brows 17-21 / 22-26, nose 27-35, eyes 36-41 / 42-47, outer lips 48-59,
    // inner lips 60-67.
    const auto right_eye = l.polygon(36, 41), left_eye = l.polygon(42, 47);
    const auto outer_lips = l.polygon(48, 59), inner_lips = l.polygon(60, 67);
    const auto nose = nose_polygon(l);
    // Margins make the polygons take in the vertices their landmarks are made of (the eyelid
    // margins, the vermilion border); the brows are a band around their landmark line.
    const float feature_margin = 0.02f * l.iod, brow_half_width = 0.07f * l.iod;
    // A feature's polygon counts only on the face's front, near its landmarks' depth: not on the back
    // of a whole head that projects into the same place.
    const float front_depth = 0.25f * l.iod;
    const float mouth_depth = 0.6f * l.iod;  // the mouth's cavity reaches further back
    const float brow_z = l.min_z(17, 26) - front_depth, eye_z = l.min_z(36, 47) - front_depth;
    const float lips_z = l.min_z(48, 67) - front_depth, mouth_z = l.min_z(60, 67) - mouth_depth;
    const float nose_z = l.min_z(27, 35) - front_depth;
    const float jaw_margin = 0.01f * l.iod, neck_depth = 0.3f * l.iod;

    std::vector<std::uint8_t> labels(static_cast<std::size_t>(v), static_cast<std::uint8_t>(Region::kSkin));
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = mean.col(i);
        const Eigen::Vector2f q = p.head<2>();
        Region region = Region::kSkin;
        if (const auto jaw = lower_jaw_height(l, q.x())) {
            if (q.y() < *jaw - jaw_margin) region = Region::kNeck;
        } else {
            // Beside the face (a whole head): below the jaw's angle (iBUG 4 / 14) and well behind it;
            // the side of the face between the jaw line and the ear stays skin.
            const Eigen::Vector3f jaw_angle = l.points.col(q.x() < 0 ? 3 : 13);
            if (q.y() < jaw_angle.y() && p.z() < jaw_angle.z() - neck_depth) region = Region::kNeck;
        }
        if (p.z() >= nose_z && within(q, nose, feature_margin)) region = Region::kNose;
        if (p.z() >= brow_z && std::min(polyline_distance(q, l, 17, 21), polyline_distance(q, l, 22, 26)) <= brow_half_width)
            region = Region::kBrows;
        if (p.z() >= lips_z && within(q, outer_lips, feature_margin)) region = Region::kLips;
        if (p.z() >= eye_z && (within(q, right_eye, feature_margin) || within(q, left_eye, feature_margin)))
            region = Region::kEyes;
        if (p.z() >= mouth_z && inside_polygon(q, inner_lips)) region = Region::kMouthInterior;
        labels[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(region);
    }
    return labels;
}

}  // namespace facesynth::morph
