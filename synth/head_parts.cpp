#include "synth/head_parts.h"

#include "core/atomic_file.h"
#include "core/byte_io.h"
#include "core/error.h"
#include "core/random.h"
#include "morph/landmarks.h"
#include "morph/regions.h"
#include "core/srgb.h"
#include "render/ambient_occlusion.h"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>

namespace facesynth::synth {
namespace {

constexpr std::string_view kMagic = "FSPARTS1";
// The atlas: the face texture over a strip a quarter of its height, split into three patches.
constexpr double kFaceShare = kAtlasFaceShare;
constexpr int kPatches = 3;  // skin, cloth, hair: skin next to cloth, for triangles across a neckline
constexpr int kSkinPatch = 0, kClothPatch = 1, kHairPatch = 2;
constexpr double kPatchMargin = 0.04;  // of a patch, so that bilinear lookups stay inside it
// A shaded skin patch runs from this share of the skin's colour (v = 0) to all of it (v = 1).
constexpr double kDarkestShade = 0.2;

Eigen::Vector2f patch_uv(int patch, const Eigen::Vector2f& uv) {
    const auto inside = [](float x) { return static_cast<float>(kPatchMargin + (1 - 2 * kPatchMargin) * (x - std::floor(x))); };
    return {(static_cast<float>(patch) + inside(uv.x())) / kPatches, static_cast<float>(kFaceShare + (1 - kFaceShare) * inside(uv.y()))};
}

// sRGB encoding by table (the atlas's strip has tens of thousands of texels per sample).
class SrgbTable {
public:
    SrgbTable() {
        for (int i = 0; i <= kSteps; ++i) table_[static_cast<std::size_t>(i)] = cv::saturate_cast<uchar>(255 * core::srgb_encode(static_cast<double>(i) / kSteps));
    }
    [[nodiscard]] cv::Vec3b operator()(const Eigen::Vector3d& linear) const { return {at(linear.x()), at(linear.y()), at(linear.z())}; }

private:
    static constexpr int kSteps = 4096;
    [[nodiscard]] uchar at(double x) const { return table_[static_cast<std::size_t>(std::lround(std::clamp(x, 0.0, 1.0) * kSteps))]; }
    std::array<uchar, kSteps + 1> table_{};
};

// Hair cards and cloth are thin sheets seen from both sides: a copy of each vertex for the back side,
// with the winding reversed, so that back-face culling and the vertex normals hold for both.
void add_back_side(HeadPart& part) {
    const Eigen::Index n = part.vertices.cols();
    part.vertices.conservativeResize(3, 2 * n);
    part.vertices.rightCols(n) = part.vertices.leftCols(n);
    part.uv.conservativeResize(2, 2 * n);
    part.uv.rightCols(n) = part.uv.leftCols(n);
    part.head_weight.conservativeResize(2 * n);
    part.head_weight.tail(n) = part.head_weight.head(n);
    const std::size_t front = part.triangles.size();
    const int offset = static_cast<int>(n);
    for (std::size_t t = 0; t < front; ++t) {
        const morph::Triangle f = part.triangles[t];
        part.triangles.push_back({f[2] + offset, f[1] + offset, f[0] + offset});
    }
}

}  // namespace

std::filesystem::path default_head_parts_file() { return std::filesystem::path(FACESYNTH_ASSET_DIR) / "head_parts.bin"; }

std::vector<int> hair_parts_named(const HeadParts& parts, const std::string& names) {
    const auto name_of = [&](int h) -> const std::string& { return parts.parts[static_cast<std::size_t>(h)].name; };
    std::string available;
    for (int h : parts.hair) available += (available.empty() ? "" : ", ") + name_of(h);
    std::vector<std::string> wanted;
    std::stringstream list(names);
    for (std::string name; std::getline(list, name, ',');) {
        name.erase(0, name.find_first_not_of(' '));
        name.erase(name.find_last_not_of(' ') + 1);
        if (std::none_of(parts.hair.begin(), parts.hair.end(), [&](int h) { return name_of(h) == name; }))
            throw core::Error("head.hair_styles: no hair style '" + name + "' (there are: " + available + ")");
        wanted.push_back(name);
    }
    std::vector<int> chosen;
    for (int h : parts.hair)
        if (std::find(wanted.begin(), wanted.end(), name_of(h)) != wanted.end()) chosen.push_back(h);
    if (chosen.empty()) throw core::Error("head.hair_styles: no style named (there are: " + available + ")");
    return chosen;
}

HeadParts read_head_parts(const std::filesystem::path& file) {
    const std::string bytes = core::read_file(file);
    core::ByteReader in(bytes, file.string());
    std::string magic(kMagic.size(), '\0');
    in.read_bytes(magic.data(), magic.size(), "magic");
    if (magic != kMagic) throw core::file_error(file.string(), "not a head parts file (made by tools/makehuman_parts.py)");
    HeadParts parts;
    const std::size_t anchors = in.read_count(3 * sizeof(float), "anchor count");
    if (anchors != kNumHeadAnchors) throw core::file_error(file.string(), "expected " + std::to_string(kNumHeadAnchors) + " anchors, found " + std::to_string(anchors));
    parts.anchors.resize(3, kNumHeadAnchors);
    in.read_floats(parts.anchors, "anchors");
    const std::size_t count = in.read_count(1, "part count");
    for (std::size_t p = 0; p < count; ++p) {
        HeadPart part;
        const auto kind = in.read<std::uint8_t>("part kind");
        if (kind > 4) throw in.error("unknown part kind " + std::to_string(kind));
        part.kind = static_cast<HeadPartKind>(kind);
        part.name = in.read_string("part name");
        const auto vertices = static_cast<Eigen::Index>(in.read_count(6 * sizeof(float), "vertex count"));
        part.vertices.resize(3, vertices);
        in.read_floats(part.vertices, "vertices");
        part.uv.resize(2, vertices);
        in.read_floats(part.uv, "uv");
        part.head_weight.resize(vertices);
        in.read_floats(part.head_weight, "head weights");
        const std::size_t triangles = in.read_count(3 * sizeof(std::uint32_t), "triangle count");
        part.triangles.resize(triangles);
        for (auto& t : part.triangles)
            for (int& v : t) {
                const auto index = in.read<std::uint32_t>("triangles");
                if (index >= static_cast<std::uint32_t>(vertices)) throw in.error("part " + part.name + ": triangle index out of range");
                v = static_cast<int>(index);
            }
        if (part.kind == HeadPartKind::kHair || part.kind == HeadPartKind::kClothing) add_back_side(part);
        const int index = static_cast<int>(parts.parts.size());
        switch (part.kind) {
            case HeadPartKind::kSkin: parts.skin.push_back(index); break;
            case HeadPartKind::kHair: parts.hair.push_back(index); break;
            case HeadPartKind::kClothing: parts.clothing.push_back(index); break;
            case HeadPartKind::kHead:
            case HeadPartKind::kEars: parts.head.push_back(index); break;
        }
        parts.parts.push_back(std::move(part));
    }
    if (!in.at_end()) throw in.error("trailing bytes after the last part");
    if (parts.skin.empty() || parts.clothing.empty()) throw core::file_error(file.string(), "needs at least one skin and one clothing part");
    return parts;
}

HeadPlacement::HeadPlacement(const morph::MorphableModel& model, const HeadParts& parts) : model_(&model), anchors_(parts.anchors) {
    if (model.landmarks.size() < 68) throw core::Error("head.body: model '" + model.name + "' has no 68 landmarks to place the head parts by");
    const Eigen::Matrix3Xf mean = model.shape_instance({}, {});
    for (int v = 0; v < static_cast<int>(model.vertex_labels.size()); ++v)
        if (model.vertex_labels[static_cast<std::size_t>(v)] == static_cast<std::uint8_t>(morph::Region::kEars)) (mean(0, v) < 0 ? right_ear_ : left_ear_).push_back(v);
}

Eigen::Matrix4f HeadPlacement::transform(const Eigen::Matrix3Xf& shape) const {
    const Eigen::Matrix3Xf l = model_->landmark_positions(shape);
    const auto mean_of = [&](int first, int last) { return Eigen::Vector3f(l.middleCols(first, last - first + 1).rowwise().mean()); };
    Eigen::Matrix3Xf target(3, kNumHeadAnchors - 1);
    target.col(static_cast<int>(HeadAnchor::kRightEye)) = mean_of(36, 41);
    target.col(static_cast<int>(HeadAnchor::kLeftEye)) = mean_of(42, 47);
    target.col(static_cast<int>(HeadAnchor::kNoseTip)) = l.col(morph::kNoseTipLandmark);
    target.col(static_cast<int>(HeadAnchor::kNasion)) = l.col(27);
    Eigen::Matrix3Xf source = anchors_.leftCols(kNumHeadAnchors - 1);
    if (!right_ear_.empty() && !left_ear_.empty()) {
        const auto centre = [&](const std::vector<int>& ids) {
            Eigen::Vector3f sum = Eigen::Vector3f::Zero();
            for (const int v : ids) sum += shape.col(v);
            return Eigen::Vector3f(sum / static_cast<float>(ids.size()));
        };
        target.col(static_cast<int>(HeadAnchor::kRightEar)) = centre(right_ear_);
        target.col(static_cast<int>(HeadAnchor::kLeftEar)) = centre(left_ear_);
    } else {
        // No ears (a face-only model): the four face anchors alone.
        const std::array<int, 4> face{static_cast<int>(HeadAnchor::kRightEye), static_cast<int>(HeadAnchor::kLeftEye),
                                      static_cast<int>(HeadAnchor::kNoseTip), static_cast<int>(HeadAnchor::kNasion)};
        Eigen::Matrix3Xf s(3, 4), t(3, 4);
        for (int i = 0; i < 4; ++i) s.col(i) = source.col(face[static_cast<std::size_t>(i)]), t.col(i) = target.col(face[static_cast<std::size_t>(i)]);
        source = s;
        target = t;
    }
    return Eigen::umeyama(source, target, true);
}

void dress_head(const HeadParts& parts, const HeadPartsSpec& spec, const Eigen::Matrix4f& placement, const Eigen::Matrix3d& head_rotation,
                const Eigen::Vector3d& skin_colour, const Eigen::Vector3d& hair_colour, bool with_head, DressedParts& out, const SkinOcclusion& occlusion) {
    const bool occluded = occlusion.strength > 0 && !occlusion.visibility.empty();
    std::vector<const HeadPart*> worn;
    for (const int p : parts.skin) worn.push_back(&parts.parts[static_cast<std::size_t>(p)]);
    if (with_head)
        for (const int p : parts.head) worn.push_back(&parts.parts[static_cast<std::size_t>(p)]);
    worn.push_back(&parts.parts[static_cast<std::size_t>(parts.clothing[spec.clothing_choice % parts.clothing.size()])]);
    if (spec.hair && !parts.hair.empty()) worn.push_back(&parts.parts[static_cast<std::size_t>(parts.hair[spec.hair_choice % parts.hair.size()])]);
    Eigen::Index total = 0;
    std::size_t triangles = 0;
    for (const HeadPart* part : worn) total += part->vertices.cols(), triangles += part->triangles.size();
    out.vertices.resize(3, total);
    out.uv.resize(2, total);
    out.colours.resize(3, total);
    out.labels.resize(static_cast<std::size_t>(total));
    out.triangles.clear();
    out.triangles.reserve(triangles);

    // The torso's rotation in the head's (model) frame: rendered through the head's pose it has its own.
    const Eigen::AngleAxisf twist(Eigen::Matrix3f((head_rotation.transpose() * morph::rotation_from_euler(spec.torso)).cast<float>()));
    const Eigen::Matrix3f linear = placement.topLeftCorner<3, 3>();
    const Eigen::Vector3f shift = placement.topRightCorner<3, 1>();
    const Eigen::Vector3f pivot = linear * parts.anchors.col(static_cast<int>(HeadAnchor::kNeckJoint)) + shift;
    Eigen::Index first = 0;
    for (const HeadPart* part : worn) {
        const bool skin = part->kind == HeadPartKind::kSkin, hair = part->kind == HeadPartKind::kHair;
        const bool head = part->kind == HeadPartKind::kHead || part->kind == HeadPartKind::kEars;
        const morph::Region head_region = part->kind == HeadPartKind::kEars ? morph::Region::kEars : morph::Region::kSkin;
        // This skin part's ambient visibility when it is shaded (one per vertex), else none.
        const Eigen::VectorXf* visibility = nullptr;
        if (const auto index = static_cast<std::size_t>(part - parts.parts.data());
            occluded && skin && index < occlusion.visibility.size() && occlusion.visibility[index].size() == part->vertices.cols())
            visibility = &occlusion.visibility[index];
        for (Eigen::Index v = 0; v < part->vertices.cols(); ++v) {
            const Eigen::Vector3f p = part->vertices.col(v);
            // The shirt: the skin below the neckline, lower at the front by up to the dip.
            const double front = std::clamp(static_cast<double>(p.z()) / 80.0, 0.0, 1.0) * std::max(0.0, 1.0 - std::abs(p.x()) / 70.0);
            const bool covered = skin && spec.shirt && p.y() < spec.neckline - spec.neckline_dip * front;
            const bool bare = head || (skin && !covered);
            const int patch = hair ? kHairPatch : bare ? kSkinPatch : kClothPatch;
            const morph::Region region = hair ? morph::Region::kHair : head ? head_region : bare ? morph::Region::kNeck : morph::Region::kClothing;
            Eigen::Vector3d colour = hair ? hair_colour : bare ? skin_colour : spec.clothing_colour;
            // The skin's shade as a v in the shaded skin patch (make_parts_atlas), kept off its wrap at 1.
            std::optional<float> shade_v;
            if (visibility && bare) {
                const double shade = 1 - occlusion.strength * (1 - std::clamp(static_cast<double>((*visibility)[v]), 0.0, 1.0));
                colour *= shade;
                shade_v = static_cast<float>(std::min(0.999, (std::max(shade, kDarkestShade) - kDarkestShade) / (1 - kDarkestShade)));
            }
            const Eigen::Vector3f on_head = linear * p + shift;
            // The neck turns by a share of the torso's rotation that grows toward the shoulders
            // (blending rotations, not positions, which would pinch a twisted neck).
            const float w = part->head_weight[v];
            const Eigen::Matrix3f turn = w >= 1 ? Eigen::Matrix3f::Identity() : Eigen::AngleAxisf((1 - w) * twist.angle(), twist.axis()).toRotationMatrix();
            out.vertices.col(first + v) = turn * (on_head - pivot) + pivot;
            out.uv.col(first + v) = patch_uv(patch, shade_v ? Eigen::Vector2f(part->uv(0, v), *shade_v) : Eigen::Vector2f(part->uv.col(v)));
            out.colours.col(first + v) = colour.cast<float>();
            out.labels[static_cast<std::size_t>(first + v)] = static_cast<std::uint8_t>(region);
        }
        for (const morph::Triangle& t : part->triangles)
            out.triangles.push_back({t[0] + static_cast<int>(first), t[1] + static_cast<int>(first), t[2] + static_cast<int>(first)});
        first += part->vertices.cols();
    }
}

std::vector<Eigen::VectorXf> skin_ambient_visibility(const HeadParts& parts, const HeadPlacement& placement) {
    // The occluder in the asset's frame: the model's mean face (placed as dress_head places the parts,
    // inverted), the skin parts and, for a face-only model, the asset's head and ears.
    const morph::MorphableModel& model = placement.model();
    const Eigen::Matrix3Xf mean = model.shape_instance({}, {});
    const Eigen::Matrix4f to_asset = placement.transform(mean).inverse();
    std::vector<const HeadPart*> occluders;
    for (const int p : parts.skin) occluders.push_back(&parts.parts[static_cast<std::size_t>(p)]);
    if (placement.face_only())
        for (const int p : parts.head) occluders.push_back(&parts.parts[static_cast<std::size_t>(p)]);
    Eigen::Index total = mean.cols();
    for (const HeadPart* part : occluders) total += part->vertices.cols();
    Eigen::Matrix3Xf vertices(3, total);
    vertices.leftCols(mean.cols()) = (to_asset.topLeftCorner<3, 3>() * mean).colwise() + to_asset.topRightCorner<3, 1>();
    std::vector<morph::Triangle> triangles = model.triangles;
    Eigen::Index first = mean.cols();
    for (const HeadPart* part : occluders) {
        vertices.middleCols(first, part->vertices.cols()) = part->vertices;
        for (const morph::Triangle& t : part->triangles)
            triangles.push_back({t[0] + static_cast<int>(first), t[1] + static_cast<int>(first), t[2] + static_cast<int>(first)});
        first += part->vertices.cols();
    }
    std::vector<Eigen::VectorXf> visibility(parts.parts.size());
    for (const int p : parts.skin) {
        const HeadPart& part = parts.parts[static_cast<std::size_t>(p)];
        visibility[static_cast<std::size_t>(p)] = render::ambient_visibility(vertices, triangles, part.vertices, morph::vertex_normals(part.vertices, part.triangles));
    }
    return visibility;
}

void make_parts_atlas(const cv::Mat& face, const HeadPartsSpec& spec, const Eigen::Vector3d& skin_colour, const Eigen::Vector3d& hair_colour,
                      cv::Mat& atlas, bool shaded_skin) {
    const int strip = static_cast<int>(std::lround(face.rows * (1 - kFaceShare) / kFaceShare));
    atlas.create(face.rows + strip, face.cols, CV_8UC3);
    face.copyTo(atlas.rowRange(0, face.rows));
    core::Rng rng(spec.pattern_seed, 0, 0);
    const SrgbTable encoded;
    const int width = face.cols;
    const auto patch = [&](int k) {
        const int x0 = k * width / kPatches, x1 = (k + 1) * width / kPatches;
        return atlas(cv::Rect(x0, face.rows, x1 - x0, strip));
    };
    // Skin: the face's own colour with faint mottling; shaded, darker toward v = 0 as patch_uv maps v.
    {
        cv::Mat p = patch(kSkinPatch);
        for (int y = 0; y < p.rows; ++y) {
            const double v = std::clamp(((y + 0.5) / p.rows - kPatchMargin) / (1 - 2 * kPatchMargin), 0.0, 1.0);
            const double shade = shaded_skin ? kDarkestShade + (1 - kDarkestShade) * v : 1.0;
            for (int x = 0; x < p.cols; ++x) p.at<cv::Vec3b>(y, x) = encoded(skin_colour * (shade * rng.uniform(0.96, 1.04)));
        }
    }
    // Hair: strands along v (MakeHuman's hair uv runs along the strands), bright and dark by column.
    {
        cv::Mat p = patch(kHairPatch);
        std::vector<double> column(static_cast<std::size_t>(p.cols));
        for (auto& c : column) c = rng.uniform(0.55, 1.45);
        for (int y = 0; y < p.rows; ++y)
            for (int x = 0; x < p.cols; ++x) {
                const double along = 1 + 0.1 * std::sin(0.2 * y + static_cast<double>(x));
                p.at<cv::Vec3b>(y, x) = encoded(hair_colour * column[static_cast<std::size_t>(x)] * along);
            }
        cv::GaussianBlur(p, p, cv::Size(1, 5), 0, 2.0);
    }
    // Cloth: plain, stripes or checks, with a weave's fine noise.
    {
        cv::Mat p = patch(kClothPatch);
        const double period = std::max(2.0, spec.pattern_period * p.cols);
        for (int y = 0; y < p.rows; ++y)
            for (int x = 0; x < p.cols; ++x) {
                const bool stripe = std::fmod(x / period, 1.0) < 0.5;
                const bool check = stripe != (std::fmod(y * static_cast<double>(p.cols) / p.rows / period, 1.0) < 0.5);
                const bool second = spec.clothing_pattern == 1 ? stripe : spec.clothing_pattern == 2 ? check : false;
                const Eigen::Vector3d c = second ? spec.clothing_colour2 : spec.clothing_colour;
                p.at<cv::Vec3b>(y, x) = encoded(c * rng.uniform(0.9, 1.1));
            }
    }
}

Eigen::Vector3d texture_colour_of(const cv::Mat& texture, const morph::MorphableModel& model, morph::Region region) {
    // Medians of the 8-bit values by histogram; decoding is monotonic, so it commutes with the median.
    std::array<std::array<int, 256>, 3> histogram{};
    int count = 0;
    const bool labelled = std::find(model.vertex_labels.begin(), model.vertex_labels.end(), static_cast<std::uint8_t>(region)) != model.vertex_labels.end();
    for (int v = 0; v < model.uv.cols(); ++v) {
        if (labelled && model.vertex_labels[static_cast<std::size_t>(v)] != static_cast<std::uint8_t>(region)) continue;
        const int x = std::clamp(static_cast<int>(model.uv(0, v) * static_cast<float>(texture.cols)), 0, texture.cols - 1);
        const int y = std::clamp(static_cast<int>(model.uv(1, v) * static_cast<float>(texture.rows)), 0, texture.rows - 1);
        const cv::Vec3b t = texture.at<cv::Vec3b>(y, x);
        for (int c = 0; c < 3; ++c) ++histogram[static_cast<std::size_t>(c)][t[c]];
        ++count;
    }
    Eigen::Vector3d median(0.5, 0.5, 0.5);
    if (count == 0) return median;
    for (int c = 0; c < 3; ++c) {
        int below = 0, level = 0;
        while (level < 255 && (below += histogram[static_cast<std::size_t>(c)][static_cast<std::size_t>(level)]) <= count / 2) ++level;
        median[c] = core::srgb_decode(level / 255.0);
    }
    return median;
}

}  // namespace facesynth::synth
