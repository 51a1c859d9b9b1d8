#pragma once
// Neck, shoulders, hair and clothing for a face model (synth's head.body, docs/synth.md "Head parts"):
// MakeHuman's CC0 meshes at its base shape (assets/head_parts.bin, made by tools/makehuman_parts.py),
// placed per sample on the sample's own face by a similarity transform between anchor points (eye
// centres, ears, nose tip, nasion), the neck bending so that the torso turns less than the head. The
// parts are appended to the rendered mesh only: the model, its 68 landmarks and its region labels stay
// as they are, and the parts never count as face for the jaw contour (they may occlude landmarks, as
// hair and collars do).
#include "morph/mesh.h"
#include "morph/model.h"
#include "morph/pose.h"
#include "morph/regions.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace facesynth::synth {

// kHead and kEars (the head behind a face, its ears) are worn by face-only models, which have none.
enum class HeadPartKind : std::uint8_t { kSkin = 0, kHair = 1, kClothing = 2, kHead = 3, kEars = 4 };

struct HeadPart {
    HeadPartKind kind = HeadPartKind::kSkin;
    std::string name;
    Eigen::Matrix3Xf vertices;  // mm, the asset's frame (x to the viewer's right, y up, z to the front)
    Eigen::Matrix2Xf uv;        // the source mesh's texture coordinates in [0, 1]
    Eigen::VectorXf head_weight;  // 1 = moves with the head, 0 = with the torso
    std::vector<morph::Triangle> triangles;
};

// Anchor order in the file and in head_anchor_points.
enum class HeadAnchor { kRightEye, kLeftEye, kRightEar, kLeftEar, kNoseTip, kNasion, kNeckJoint };
inline constexpr int kNumHeadAnchors = 7;

struct HeadParts {
    Eigen::Matrix3Xf anchors;  // 3 x kNumHeadAnchors, mm
    std::vector<HeadPart> parts;
    std::vector<int> skin, hair, clothing, head;  // indices into parts by kind (head: kHead and kEars); skin and clothing never empty
};

// The asset in the source tree (assets/head_parts.bin).
[[nodiscard]] std::filesystem::path default_head_parts_file();
// Throws core::Error naming the file when it is missing, truncated or not a parts file.
[[nodiscard]] HeadParts read_head_parts(const std::filesystem::path& file);
// The indices (into parts.parts, in parts.hair's order) of the hair meshes named in a comma-separated
// list (synth's head.hair_styles); core::Error naming the key and the styles there are for an unknown
// name or an empty list.
[[nodiscard]] std::vector<int> hair_parts_named(const HeadParts& parts, const std::string& names);

// What one sample wears (drawn by sample_scene from the kHead stream; choices modulo the counts).
struct HeadPartsSpec {
    bool hair = false;               // a hair mesh (else the model's painted scalp shows)
    std::uint64_t hair_choice = 0;
    std::uint64_t clothing_choice = 0;
    Eigen::Vector3d hair_colour = Eigen::Vector3d::Zero();      // linear RGB; used without a hair colour from the texture
    bool hair_colour_from_texture = true;                         // with a texture: the colour of its scalp
    Eigen::Vector3d clothing_colour = Eigen::Vector3d::Zero();  // linear RGB
    Eigen::Vector3d clothing_colour2 = Eigen::Vector3d::Zero(); // second colour of stripes and checks
    int clothing_pattern = 0;        // 0 plain, 1 stripes, 2 checks
    double pattern_period = 0.05;    // uv units
    std::uint64_t pattern_seed = 0;  // fabric and hair-strand noise
    morph::EulerAngles torso;               // the torso's rotation, degrees (the head's is the sample's pose)
    // A shirt on the body's skin below a neckline: its height (mm, the asset's frame, where the neck
    // joint is at 589 and the shoulders near 520) and how far it dips at the front (a U or V neck).
    bool shirt = true;
    double neckline = 550;
    double neckline_dip = 20;
};

// Where a model's anchor points are, for one shape of it (3 x kNumHeadAnchors; the neck joint column
// is left at zero: the asset's neck joint is placed with the rest). Ears: the mean of the vertices
// labelled Region::kEars on each side; models without ears get them from the eyes and nasion with the
// asset's proportions.
class HeadPlacement {
public:
    HeadPlacement(const morph::MorphableModel& model, const HeadParts& parts);
    // Similarity (4 x 4, homogeneous) taking the asset's frame to the model's for `shape`.
    [[nodiscard]] Eigen::Matrix4f transform(const Eigen::Matrix3Xf& shape) const;
    // A face-only model (no vertices labelled ears): it wears the asset's head and ears too.
    [[nodiscard]] bool face_only() const { return right_ear_.empty() || left_ear_.empty(); }
    [[nodiscard]] const morph::MorphableModel& model() const { return *model_; }

private:
    const morph::MorphableModel* model_;
    Eigen::Matrix3Xf anchors_;  // the parts'
    std::vector<int> right_ear_, left_ear_;
};

// Ambient visibility (render/ambient_occlusion.h) of the skin parts' vertices at the asset's base shape:
// the model's mean face placed on the parts (with the asset's head for a face-only model) and the skin
// itself as the occluder, so that the neck under the chin and jaw is shaded as the sky it sees. One
// vector per part (parts.parts' order), empty for parts that are not skin.
[[nodiscard]] std::vector<Eigen::VectorXf> skin_ambient_visibility(const HeadParts& parts, const HeadPlacement& placement);

// Ambient occlusion on the parts' bare skin: each vertex's albedo times 1 - strength · (1 - visibility).
// Baked into the albedo, so it also dims the directional lights there (under the chin they are mostly
// shadowed anyway). An empty `visibility` or strength 0: no occlusion (the skin as before).
struct SkinOcclusion {
    std::span<const Eigen::VectorXf> visibility;  // skin_ambient_visibility
    double strength = 0;
};

// The vertices, uv, labels and colours one sample's parts add to its mesh, in the model's frame.
struct DressedParts {
    Eigen::Matrix3Xf vertices;
    Eigen::Matrix2Xf uv;  // into the atlas's part patches (make_parts_atlas)
    Eigen::Matrix3Xf colours;  // linear RGB, for renders without a texture
    std::vector<std::uint8_t> labels;
    std::vector<morph::Triangle> triangles;  // indices from 0 (the caller offsets them)
};

// `head_rotation` is the sample's pose rotation (model to camera, before the axis flip); the torso
// keeps spec.torso in the same terms, the neck blending between the two.
// `with_head`: add the head and ears parts (HeadPlacement::face_only).
void dress_head(const HeadParts& parts, const HeadPartsSpec& spec, const Eigen::Matrix4f& placement,
                const Eigen::Matrix3d& head_rotation, const Eigen::Vector3d& skin_colour, const Eigen::Vector3d& hair_colour,
                bool with_head, DressedParts& out, const SkinOcclusion& occlusion = {});

// The texture to render a textured face and its parts with: `face` (8-bit RGB, sRGB) on top and a
// strip below it with the patches the parts' uv point into (skin, hair strands, cloth); the face's
// own v coordinates must be multiplied by kAtlasFaceShare. `shaded_skin`: the skin patch darkens upward
// (its v carries dress_head's occlusion) instead of being even.
void make_parts_atlas(const cv::Mat& face, const HeadPartsSpec& spec, const Eigen::Vector3d& skin_colour,
                      const Eigen::Vector3d& hair_colour, cv::Mat& atlas, bool shaded_skin = false);
inline constexpr double kAtlasFaceShare = 0.8;

// The median linear colour of `texture` (8-bit RGB, sRGB) at the uv of the model vertices labelled
// `region` (of all its vertices when none is).
[[nodiscard]] Eigen::Vector3d texture_colour_of(const cv::Mat& texture, const morph::MorphableModel& model, morph::Region region);

}  // namespace facesynth::synth
