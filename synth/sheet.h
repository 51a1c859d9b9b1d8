#pragma once
// A contact sheet of dataset samples with their landmarks drawn, for a person to check at a glance.
#include <opencv2/core.hpp>

#include <filesystem>

namespace facesynth::synth {

struct SheetOptions {
    int count = 64;     // samples, the first ones in index order
    int columns = 8;
    int tile = 160;     // px per tile side
};

// RGB image: each tile is a sample with its .pts-mode landmarks (green visible, red self-occluded,
// orange covered by an occluder) and its key and yaw. Reads meta/ and images/; throws
// core::Error naming the file on failure or when the dataset folder has no samples.
[[nodiscard]] cv::Mat contact_sheet(const std::filesystem::path& dataset, const SheetOptions& options = {});

}  // namespace facesynth::synth
