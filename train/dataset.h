#pragma once
// Folders of images with same-stem iBUG .pts files: either side by side (X.png + X.pts) or in the
// layout `facesynth synth` writes (DIR/images/<key>.png + DIR/landmarks/<key>.pts).
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::train {

struct LabelledImage {
    std::string key;                 // "<folder name>/<file stem>"
    std::filesystem::path image;
    std::filesystem::path pts;
    // Side by side with its .pts (a folder of photographs), not in a dataset's images/ + landmarks/
    // layout (renders from `facesynth synth` or `facesynth profile`).
    bool photograph = true;
};

// Every image (.png .jpg .jpeg .ppm .pgm .bmp .tif .tiff) with a same-stem .pts, sorted by path within
// each folder, folders in the order given. Throws core::Error for a folder that does not exist
// or holds no labelled image.
[[nodiscard]] std::vector<LabelledImage> list_labelled_images(const std::vector<std::filesystem::path>& folders);

// A labelled image read for evaluation: its 68 true landmarks (0-based pixels) and its pixels as 8-bit grey.
struct LoadedFace {
    Eigen::Matrix2Xd truth;
    cv::Mat gray;
};
// Throws core::Error naming the file: unreadable .pts, not 68 points, an image over the size limit
// (core/image_header.h) or one that cannot be decoded.
[[nodiscard]] LoadedFace load_labelled_face(const LabelledImage& image);

// The sample's true yaw in degrees from a `facesynth synth` meta file (DIR/meta/<stem>.json beside
// DIR/landmarks/), or nothing where there is none or it cannot be read.
[[nodiscard]] std::optional<double> read_meta_yaw(const LabelledImage& image);

// "a,b,c" -> {a, b, c} (empty parts dropped).
[[nodiscard]] std::vector<std::filesystem::path> split_folder_list(const std::string& comma_separated);

}  // namespace facesynth::train
