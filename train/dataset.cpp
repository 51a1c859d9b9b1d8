#include "train/dataset.h"

#include "core/error.h"
#include "core/atomic_file.h"
#include "core/image_header.h"

#include "morph/landmarks.h"
#include "train/face_box.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <sstream>

namespace facesynth::train {
namespace {

void collect(const std::filesystem::path& image_dir, const std::filesystem::path& pts_dir, const std::string& prefix,
             std::vector<LabelledImage>& out) {
    const bool photographs = image_dir == pts_dir;
    std::vector<std::filesystem::path> images;
    for (const auto& entry : std::filesystem::directory_iterator(image_dir))
        if (entry.is_regular_file() && core::is_image_file(entry.path())) images.push_back(entry.path());
    std::sort(images.begin(), images.end());
    for (const auto& image : images) {
        auto pts = pts_dir / image.filename();
        pts.replace_extension(".pts");
        if (std::filesystem::exists(pts)) out.push_back({prefix + "/" + image.stem().string(), image, pts, photographs});
    }
}

}  // namespace

std::vector<LabelledImage> list_labelled_images(const std::vector<std::filesystem::path>& folders) {
    std::vector<LabelledImage> all;
    for (const auto& folder : folders) {
        if (!std::filesystem::is_directory(folder)) throw core::file_error(folder.string(), "not a folder");
        const std::string prefix = (folder.filename().empty() ? folder.parent_path() : folder).filename().string();
        std::vector<LabelledImage> found;
        if (std::filesystem::is_directory(folder / "images") && std::filesystem::is_directory(folder / "landmarks"))
            collect(folder / "images", folder / "landmarks", prefix, found);
        collect(folder, folder, prefix, found);
        if (found.empty())
            throw core::file_error(folder.string(), "no images with same-stem .pts files (side by side, or images/ + landmarks/)");
        all.insert(all.end(), found.begin(), found.end());
    }
    return all;
}

std::vector<std::filesystem::path> split_folder_list(const std::string& comma_separated) {
    std::vector<std::filesystem::path> folders;
    std::stringstream stream(comma_separated);
    std::string part;
    while (std::getline(stream, part, ','))
        if (!part.empty()) folders.emplace_back(part);
    return folders;
}

// "yaw" at the top level or under "pose" of DIR/meta/<stem>.json.
std::optional<double> read_meta_yaw(const LabelledImage& image) {
    const auto meta = image.pts.parent_path().parent_path() / "meta" / (image.pts.stem().string() + ".json");
    if (!std::filesystem::exists(meta)) return std::nullopt;
    try {
        const auto json = nlohmann::json::parse(core::read_file(meta));
        if (json.contains("yaw") && json["yaw"].is_number()) return json["yaw"].get<double>();
        if (json.contains("pose") && json["pose"].is_object() && json["pose"].contains("yaw") &&
            json["pose"]["yaw"].is_number())
            return json["pose"]["yaw"].get<double>();
    } catch (const std::exception&) {
    }
    return std::nullopt;
}

LoadedFace load_labelled_face(const LabelledImage& image) {
    LoadedFace face;
    face.truth = morph::read_pts(image.pts);
    if (face.truth.cols() != morph::kNumIbugLandmarks) throw core::file_error(image.pts.string(), "expected 68 points");
    core::check_image_not_too_large(image.image);
    const cv::Mat loaded = cv::imread(image.image.string(), cv::IMREAD_UNCHANGED);
    if (loaded.empty()) throw core::file_error(image.image.string(), "cannot read image");
    face.gray = to_gray8(loaded);
    return face;
}

}  // namespace facesynth::train
