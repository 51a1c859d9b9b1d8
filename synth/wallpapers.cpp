#include "synth/wallpapers.h"

#include "core/error.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <utility>

namespace facesynth::synth {

std::vector<WallpaperPhoto> debian_wallpaper_photos(const std::filesystem::path& root) {
    // Chosen by looking at every image of the three packages: photographs of scenes, objects and
    // nature are in; illustrations, renders, gradients and abstract patterns are out.
    constexpr std::array kMate = {"Aqua.jpg", "Blinds.jpg", "Dune.jpg", "FreshFlower.jpg", "Garden.jpg", "GreenMeadow.jpg",
                                  "LadyBird.jpg", "RainDrops.jpg", "Storm.jpg", "TwoWings.jpg", "Wood.jpg", "YellowFlower.jpg"};
    constexpr std::array kPlasma = {"BytheWater", "ColdRipple", "ColorfulCups", "DarkestHour", "EveningGlow", "FallenLeaf",
                                    "Kite", "OneStandsOut", "Path", "Volna", "summer_1am"};
    constexpr std::array kLomiri = {"Bridge_by_Sander_Klootwijk.jpg", "Dragonfly_by_Bolly.jpg", "Picture_0B_by_freespace.jpg",
                                    "Picture_1A_by_freespace.jpg", "Wine_by_Jakkub_Mede.jpg", "aitzgorri_by_Aitzol_Berasategi.jpg",
                                    "free_by_Peter_Nerlich.jpg", "friends_by_Aitzol_Berasategi.jpg", "greentock_by_Peter_Nerlich.jpg",
                                    "life_by_Aitzol_Berasategi.jpg", "picosdeeuropa_by_Aitzol_Berasategi.jpg",
                                    "seeding_by_Clements_Engelhardt.jpg", "sunset_by_Aitzol_Berasategi.jpg"};
    std::vector<WallpaperPhoto> photos;
    photos.reserve(kMate.size() + kPlasma.size() + kLomiri.size());
    for (const char* name : kMate) photos.push_back({root / "usr/share/backgrounds/mate/nature" / name, "mate-backgrounds"});
    // Plasma ships each wallpaper at several sizes; the largest landscape one is found when loading.
    for (const char* name : kPlasma)
        photos.push_back({root / "usr/share/wallpapers" / name / "contents" / "images", "plasma-workspace-wallpapers"});
    for (const char* name : kLomiri) photos.push_back({root / "usr/share/backgrounds" / name, "lomiri-wallpapers-16.04"});
    return photos;
}

namespace {

// A plasma wallpaper folder holds WxH.{jpg,png} files: the widest landscape one (ties: the file name).
std::filesystem::path largest_landscape(const std::filesystem::path& folder) {
    std::filesystem::path best;
    long best_width = -1;
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
        const std::string stem = entry.path().stem().string();
        const auto x = stem.find('x');
        if (x == std::string::npos) continue;
        long width = 0, height = 0;
        try {
            width = std::stol(stem.substr(0, x));
            height = std::stol(stem.substr(x + 1));
        } catch (const std::exception&) {
            continue;
        }
        if (width < height) continue;
        if (width > best_width || (width == best_width && entry.path() < best)) {
            best_width = width;
            best = entry.path();
        }
    }
    return best;
}

}  // namespace

ImageLibrary load_wallpaper_photos(int max_side, const std::filesystem::path& root) {
    std::vector<cv::Mat> images;
    std::vector<std::string> names;
    for (const WallpaperPhoto& photo : debian_wallpaper_photos(root)) {
        std::error_code error;
        std::filesystem::path file = photo.file;
        if (std::filesystem::is_directory(file, error)) file = largest_landscape(file);
        const std::string hint = " (background.type = \"wallpapers\" needs the Debian package " + photo.package + "; tools/install-deps.sh installs it)";
        if (file.empty() || !std::filesystem::is_regular_file(file, error)) throw core::file_error(photo.file.string(), "wallpaper photograph not found" + hint);
        cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
        if (bgr.empty()) throw core::file_error(file.string(), "cannot read the wallpaper photograph" + hint);
        const double scale = static_cast<double>(max_side) / std::max(bgr.cols, bgr.rows);
        if (scale < 1) cv::resize(bgr, bgr, cv::Size(), scale, scale, cv::INTER_AREA);
        cv::Mat rgb;
        cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
        images.push_back(std::move(rgb));
        names.push_back(file.string());
    }
    return {std::move(images), std::move(names)};
}

}  // namespace facesynth::synth
