#pragma once
// Licence-clean background photographs that need no user data: the photographs among the wallpapers of
// three Debian packages (mate-backgrounds, plasma-workspace-wallpapers, lomiri-wallpapers-16.04), which
// tools/install-deps.sh installs. The packages hold illustrations and abstract art too; only the 36
// photographs are listed (docs/synth.md, "Background"). Used by background.type = "wallpapers".
#include "synth/sample.h"

#include <filesystem>
#include <string>
#include <vector>

namespace facesynth::synth {

struct WallpaperPhoto {
    std::filesystem::path file;
    std::string package;  // the Debian package that installs it
};

// The listed photographs, in a fixed order (the order fixes which image a sample draws), under `root`
// (the file system's root; tests give another).
[[nodiscard]] std::vector<WallpaperPhoto> debian_wallpaper_photos(const std::filesystem::path& root = "/");

// Reads every listed photograph, RGB, its longer side reduced to at most `max_side` pixels (a background
// crop needs no more, and 36 full-size wallpapers would take 300 MB). Throws core::Error naming the
// first missing or unreadable file and its package, so that a dataset never depends on which of the
// packages happen to be installed.
[[nodiscard]] ImageLibrary load_wallpaper_photos(int max_side = 1024, const std::filesystem::path& root = "/");

}  // namespace facesynth::synth
