#include "synth/sheet.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "synth/dataset.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace facesynth::synth {
namespace {

enum class PointState { kVisible, kSelfOccluded, kCovered };

struct SheetPoint {
    double x = 0, y = 0;
    PointState state = PointState::kVisible;
};

struct SheetItem {
    std::string key;
    double yaw = 0;
    std::vector<SheetPoint> points;
};

// One meta file as the sheet needs it. The file may have been edited, truncated or damaged by
// hand: every field is checked, and a missing key, wrong type or length is reported against it.
SheetItem read_sheet_item(const std::filesystem::path& meta_path) {
    const nlohmann::json meta = read_json_file(meta_path);
    try {
        SheetItem item;
        item.key = meta.at("key").get<std::string>();
        if (item.key != meta_path.stem().string())
            throw core::file_error(meta_path.string(), "key '" + item.key + "' does not match the file name");
        item.yaw = meta.at("yaw").get<double>();
        const auto& points = meta.at("landmarks");
        const auto& visible = meta.at("visibility");
        const auto& occluded = meta.at("occluded");
        if (!points.is_array() || !visible.is_array() || !occluded.is_array() || visible.size() != points.size() ||
            occluded.size() != points.size())
            throw core::file_error(meta_path.string(), "landmarks, visibility and occluded must be arrays of one length");
        for (std::size_t p = 0; p < points.size(); ++p) {
            SheetPoint point{points.at(p).at(0).get<double>(), points.at(p).at(1).get<double>()};
            if (!std::isfinite(point.x) || !std::isfinite(point.y) || !std::isfinite(item.yaw))
                throw core::file_error(meta_path.string(), "landmark " + std::to_string(p) + " or yaw is not a finite number");
            if (occluded.at(p).get<double>() != 0)
                point.state = PointState::kCovered;
            else if (visible.at(p).get<double>() == 0)
                point.state = PointState::kSelfOccluded;
            item.points.push_back(point);
        }
        return item;
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(meta_path.string(), std::string("not a facesynth meta file: ") + e.what());
    }
}

cv::Mat read_sample_image(const std::filesystem::path& dataset, const std::string& key, const std::filesystem::path& meta_path) {
    auto image_path = dataset / "images" / (key + ".png");
    if (!std::filesystem::exists(image_path)) image_path = dataset / "images" / (key + ".jpg");
    if (!std::filesystem::exists(image_path))
        throw core::file_error((dataset / "images" / (key + ".png")).string(), "missing (no .png or .jpg for " + meta_path.string() + ")");
    core::check_image_not_too_large(image_path);
    cv::Mat bgr = cv::imread(image_path.string(), cv::IMREAD_COLOR);
    if (bgr.empty()) throw core::file_error(image_path.string(), "cannot read image");
    return bgr;
}

cv::Scalar colour_of(PointState state) {
    switch (state) {
        case PointState::kCovered: return {0, 150, 255};     // orange (BGR)
        case PointState::kSelfOccluded: return {0, 0, 255};  // red
        case PointState::kVisible: break;
    }
    return {0, 230, 0};  // green
}

}  // namespace

cv::Mat contact_sheet(const std::filesystem::path& dataset, const SheetOptions& options) {
    std::vector<std::filesystem::path> metas;
    const auto meta_dir = dataset / "meta";
    if (!std::filesystem::is_directory(meta_dir)) throw core::file_error(dataset.string(), "no meta/ folder (not a facesynth dataset with the folder format)");
    for (const auto& entry : std::filesystem::directory_iterator(meta_dir))
        if (entry.path().extension() == ".json") metas.push_back(entry.path());
    std::sort(metas.begin(), metas.end());
    if (metas.empty()) throw core::file_error(dataset.string(), "no samples in meta/");
    metas.resize(std::min<std::size_t>(metas.size(), static_cast<std::size_t>(std::max(options.count, 1))));

    const int columns = std::max(1, options.columns);
    const int tile_side = std::max(1, options.tile);
    const auto rows = static_cast<std::int64_t>((metas.size() + static_cast<std::size_t>(columns) - 1) / static_cast<std::size_t>(columns));
    if (rows * tile_side * static_cast<std::int64_t>(std::min<std::size_t>(metas.size(), static_cast<std::size_t>(columns))) * tile_side > core::kMaxImagePixels)
        throw core::Error("synth sheet: " + std::to_string(metas.size()) + " tiles of " + std::to_string(tile_side) + " px make a sheet over " +
                    std::to_string(core::kMaxImagePixels / 1'000'000) + " megapixels (lower --count or --tile)");
    cv::Mat sheet(static_cast<int>(rows) * tile_side, columns * tile_side, CV_8UC3, cv::Scalar(30, 30, 30));
    for (std::size_t n = 0; n < metas.size(); ++n) {
        const SheetItem item = read_sheet_item(metas[n]);
        const cv::Mat bgr = read_sample_image(dataset, item.key, metas[n]);
        cv::Mat tile;
        const double scale = static_cast<double>(tile_side) / std::max(bgr.cols, bgr.rows);
        cv::resize(bgr, tile, cv::Size(), scale, scale, cv::INTER_AREA);
        // Points far outside the tile are clamped just outside it, so that cvRound stays in range.
        const auto subpixel = [&](double v, int limit) { return cvRound(std::clamp(((v + 0.5) * scale - 0.5) * 4, -64.0, 4.0 * (limit + 16))); };
        for (const auto& point : item.points)
            cv::circle(tile, cv::Point(subpixel(point.x, tile.cols), subpixel(point.y, tile.rows)), 4, colour_of(point.state), cv::FILLED, cv::LINE_AA, 2);
        char label[64];
        std::snprintf(label, sizeof label, "%s y%+.0f", item.key.c_str(), item.yaw);
        cv::putText(tile, label, cv::Point(3, tile.rows - 4), cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
        const int column = static_cast<int>(n % static_cast<std::size_t>(columns)), row = static_cast<int>(n / static_cast<std::size_t>(columns));
        tile.copyTo(sheet(cv::Rect(column * tile_side, row * tile_side, tile.cols, tile.rows)));
    }
    cv::Mat rgb;
    cv::cvtColor(sheet, rgb, cv::COLOR_BGR2RGB);
    return rgb;
}

}  // namespace facesynth::synth
