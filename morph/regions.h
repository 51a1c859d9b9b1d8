#pragma once
// Semantic face regions: the per-vertex labels a model may carry (MorphableModel::vertex_labels),
// which the renderer turns into a label image (render::Frame::labels, synth's labels/).
#include <cstdint>
#include <string_view>

namespace facesynth::morph {

enum class Region : std::uint8_t {
    kBackground = 0, kSkin = 1, kBrows = 2, kEyes = 3, kLips = 4, kNose = 5, kMouthInterior = 6,
    kHair = 7, kEars = 8, kNeck = 9, kClothing = 10,
};
inline constexpr int kNumRegions = 11;

// "background", "skin", "brows", "eyes", "lips", "nose", "mouth_interior", "hair", "ears", "neck", "clothing".
[[nodiscard]] constexpr std::string_view region_name(Region region) {
    constexpr std::string_view names[kNumRegions] = {"background", "skin", "brows", "eyes", "lips",
                                                     "nose", "mouth_interior", "hair", "ears", "neck", "clothing"};
    const auto i = static_cast<int>(region);
    return i < kNumRegions ? names[i] : std::string_view("unknown");
}

// A display colour per region (sRGB, 8 bit) for previews; the label images themselves hold the ids.
struct RegionColour {
    std::uint8_t r, g, b;
};
[[nodiscard]] constexpr RegionColour region_colour(Region region) {
    constexpr RegionColour colours[kNumRegions] = {{0, 0, 0},       {230, 180, 150}, {120, 70, 20},  {255, 255, 255},
                                                   {220, 30, 60},   {255, 140, 0},   {90, 0, 120},   {70, 50, 40},
                                                   {40, 160, 220},  {100, 200, 90},  {60, 90, 200}};
    const auto i = static_cast<int>(region);
    return i < kNumRegions ? colours[i] : RegionColour{255, 0, 255};
}

}  // namespace facesynth::morph
