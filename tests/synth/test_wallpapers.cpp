// Background photographs from Debian's wallpaper packages (synth/wallpapers.h), which
// tools/install-deps.sh installs: every listed photograph loads, reduced, and synth draws from them;
// a missing one is an error naming the file and its package.
#include "common/test_data.h"
#include "core/error.h"
#include "synth/config.h"
#include "synth/wallpapers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <set>
#include <string>

namespace facesynth::synth {
namespace {

TEST(Wallpapers, EveryListedPhotographLoadsReducedAndDistinct) {
    const auto listed = debian_wallpaper_photos();
    ASSERT_EQ(listed.size(), 36u);
    std::set<std::string> packages;
    for (const auto& photo : listed) packages.insert(photo.package);
    EXPECT_EQ(packages.size(), 3u);
    const ImageLibrary library = load_wallpaper_photos(512);
    ASSERT_EQ(library.size(), listed.size());
    std::set<std::string> names;
    for (std::size_t i = 0; i < library.size(); ++i) {
        const cv::Mat& image = library.image(i);
        EXPECT_EQ(image.type(), CV_8UC3) << library.name(i);
        EXPECT_EQ(std::max(image.cols, image.rows), 512) << library.name(i);  // every wallpaper is larger
        cv::Scalar mean, stddev;
        cv::meanStdDev(image, mean, stddev);
        EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 15.0) << library.name(i);  // a picture, not a flat colour
        names.insert(library.name(i));
    }
    EXPECT_EQ(names.size(), listed.size());
}

TEST(Wallpapers, AMissingPhotographNamesTheFileAndItsPackage) {
    const auto root = testkit::fresh_temp_dir("wallpapers_missing");
    const std::string message = testkit::error_message_of([&] { (void)load_wallpaper_photos(512, root); });
    EXPECT_NE(message.find("Aqua.jpg"), std::string::npos) << message;
    EXPECT_NE(message.find("mate-backgrounds"), std::string::npos) << message;
    SynthConfig config;
    config.background.type = "wallpaper";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("\"wallpapers\""), std::string::npos);
    config.background.type = "wallpapers";
    validate(config);
}

}  // namespace
}  // namespace facesynth::synth
