#pragma once
// A contact sheet of dataset samples with their landmarks drawn, for a person to check at a glance.
#include <opencv2/core.hpp>

#include <filesystem>

namespace facesynth::synth {

struct SheetOptions {
    int count = 64;     // samples, the first ones in index order
    int columns = 8;
    int tile = 160;     // px per tile side
    // Photographs with 68-point .pts beside them (IMAGE.pts), the first ones in name order: with a
    // folder, rows of renders alternate with rows of these photographs, and every tile (render or
    // photograph) is cropped to the same framing of its face, so that the two compare at a glance.
    std::filesystem::path photos;
};

// RGB image: each tile is a sample with its .pts-mode landmarks (green visible, red self-occluded,
// orange covered by an occluder) and its key and yaw; with `options.photos`, photographs with their
// annotated landmarks (white) in the rows between. Reads meta/ and images/; throws core::Error naming
// the file on failure, when the dataset folder has no samples or the photo folder no annotated photograph.
[[nodiscard]] cv::Mat contact_sheet(const std::filesystem::path& dataset, const SheetOptions& options = {});

}  // namespace facesynth::synth
