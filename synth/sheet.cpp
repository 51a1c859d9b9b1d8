#include "synth/sheet.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"
#include "synth/dataset.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace facesynth::synth {
namespace {

enum class PointState { kVisible, kSelfOccluded, kCovered, kPhotograph };

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

cv::Mat read_image(const std::filesystem::path& path) {
    core::check_image_not_too_large(path);
    cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (bgr.empty()) throw core::file_error(path.string(), "cannot read image");
    return bgr;
}

cv::Mat read_sample_image(const std::filesystem::path& dataset, const std::string& key, const std::filesystem::path& meta_path) {
    auto image_path = dataset / "images" / (key + ".png");
    if (!std::filesystem::exists(image_path)) image_path = dataset / "images" / (key + ".jpg");
    if (!std::filesystem::exists(image_path))
        throw core::file_error((dataset / "images" / (key + ".png")).string(), "missing (no .png or .jpg for " + meta_path.string() + ")");
    return read_image(image_path);
}

cv::Scalar colour_of(PointState state) {
    switch (state) {
        case PointState::kCovered: return {0, 150, 255};     // orange (BGR)
        case PointState::kSelfOccluded: return {0, 0, 255};  // red
        case PointState::kPhotograph: return {255, 255, 255};
        case PointState::kVisible: break;
    }
    return {0, 230, 0};  // green
}

// The first `count` photographs of `folder` (name order) that have a .pts beside them.
std::vector<std::filesystem::path> annotated_photos(const std::filesystem::path& folder, std::size_t count) {
    if (!std::filesystem::is_directory(folder)) throw core::file_error(folder.string(), "photo folder not found");
    std::vector<std::filesystem::path> photos;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
        if (core::is_image_file(entry.path()) && std::filesystem::exists(std::filesystem::path(entry.path()).replace_extension(".pts")))
            photos.push_back(entry.path());
    }
    std::sort(photos.begin(), photos.end());
    if (photos.empty()) throw core::file_error(folder.string(), "no photograph with a .pts beside it");
    photos.resize(std::min(photos.size(), count));
    return photos;
}

SheetItem read_photo_item(const std::filesystem::path& photo) {
    const Eigen::Matrix2Xd landmarks = morph::read_pts(std::filesystem::path(photo).replace_extension(".pts"));
    SheetItem item;
    item.key = photo.stem().string();
    for (Eigen::Index p = 0; p < landmarks.cols(); ++p) item.points.push_back({landmarks(0, p), landmarks(1, p), PointState::kPhotograph});
    return item;
}

// A tile of `side` px: the whole image, or with `face_framing` a square 1.6 times the landmarks' box
// around their centre (outside the image: dark grey); the points drawn, the label in the corner.
cv::Mat make_tile(const cv::Mat& bgr, const SheetItem& item, int side, bool face_framing, const std::string& label) {
    cv::Mat tile;
    std::function<cv::Point2d(const SheetPoint&)> to_tile;
    if (face_framing && !item.points.empty()) {
        double x0 = item.points.front().x, x1 = x0, y0 = item.points.front().y, y1 = y0;
        for (const SheetPoint& p : item.points) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
        const double scale = side / (1.6 * std::max({x1 - x0, y1 - y0, 1.0}));
        // Shrinking: area averaging first (warpAffine has none), then a shift; enlarging: one bilinear warp.
        const bool shrink = scale < 1;
        cv::Mat source = bgr;
        if (shrink) cv::resize(bgr, source, cv::Size(), scale, scale, cv::INTER_AREA);
        const double o = shrink ? 0.5 : 0.0;  // cv::resize maps pixel centres: p -> (p + 0.5) * scale - 0.5
        const auto scaled = [=](double v) { return (v + o) * scale - o; };
        const double tx = 0.5 * (side - 1) - scaled(0.5 * (x0 + x1)), ty = 0.5 * (side - 1) - scaled(0.5 * (y0 + y1));
        const double warp = shrink ? 1.0 : scale;
        const cv::Mat affine = (cv::Mat_<double>(2, 3) << warp, 0, tx, 0, warp, ty);
        cv::warpAffine(source, tile, affine, cv::Size(side, side), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(30, 30, 30));
        to_tile = [=](const SheetPoint& p) { return cv::Point2d(scaled(p.x) + tx, scaled(p.y) + ty); };
    } else {
        const double scale = static_cast<double>(side) / std::max(bgr.cols, bgr.rows);
        cv::resize(bgr, tile, cv::Size(), scale, scale, cv::INTER_AREA);
        to_tile = [=](const SheetPoint& p) { return cv::Point2d((p.x + 0.5) * scale - 0.5, (p.y + 0.5) * scale - 0.5); };
    }
    // Points far outside the tile are clamped just outside it, so that cvRound stays in range.
    const auto subpixel = [](double v, int limit) { return cvRound(std::clamp(v * 4, -64.0, 4.0 * (limit + 16))); };
    for (const auto& point : item.points) {
        const cv::Point2d q = to_tile(point);
        cv::circle(tile, cv::Point(subpixel(q.x, tile.cols), subpixel(q.y, tile.rows)), 4, colour_of(point.state), cv::FILLED, cv::LINE_AA, 2);
    }
    cv::putText(tile, label, cv::Point(3, tile.rows - 4), cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    return tile;
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
    const bool with_photos = !options.photos.empty();
    const std::vector<std::filesystem::path> photos = with_photos ? annotated_photos(options.photos, metas.size()) : std::vector<std::filesystem::path>{};

    const int columns = std::max(1, options.columns);
    const int tile_side = std::max(1, options.tile);
    const auto columns_z = static_cast<std::size_t>(columns);
    const auto render_rows = static_cast<std::int64_t>((metas.size() + columns_z - 1) / columns_z);
    const auto photo_rows = static_cast<std::int64_t>((photos.size() + columns_z - 1) / columns_z);
    // Photo row q (there are never more than render rows) follows render row q: sheet row 2q + 1; the
    // render rows after the last photo row follow each other.
    const auto sheet_row = [&](std::int64_t row, bool photo) { return photo ? 2 * row + 1 : row + std::min(row, photo_rows); };
    const std::int64_t rows = render_rows + photo_rows;
    if (rows * tile_side * static_cast<std::int64_t>(std::min<std::size_t>(metas.size(), columns_z)) * tile_side > core::kMaxImagePixels)
        throw core::Error("synth sheet: " + std::to_string(metas.size() + photos.size()) + " tiles of " + std::to_string(tile_side) +
                    " px make a sheet over " + std::to_string(core::kMaxImagePixels / 1'000'000) + " megapixels (lower --count or --tile)");
    cv::Mat sheet(static_cast<int>(rows) * tile_side, columns * tile_side, CV_8UC3, cv::Scalar(30, 30, 30));
    const auto place = [&](const cv::Mat& tile, std::size_t n, bool photo) {
        const int column = static_cast<int>(n % columns_z), row = static_cast<int>(sheet_row(static_cast<std::int64_t>(n / columns_z), photo));
        tile.copyTo(sheet(cv::Rect(column * tile_side, row * tile_side, tile.cols, tile.rows)));
    };
    for (std::size_t n = 0; n < metas.size(); ++n) {
        const SheetItem item = read_sheet_item(metas[n]);
        char label[64];
        std::snprintf(label, sizeof label, "%s y%+.0f", item.key.c_str(), item.yaw);
        place(make_tile(read_sample_image(dataset, item.key, metas[n]), item, tile_side, with_photos, label), n, false);
    }
    for (std::size_t n = 0; n < photos.size(); ++n) {
        const SheetItem item = read_photo_item(photos[n]);
        place(make_tile(read_image(photos[n]), item, tile_side, true, item.key.substr(0, 20)), n, true);
    }
    cv::Mat rgb;
    cv::cvtColor(sheet, rgb, cv::COLOR_BGR2RGB);
    return rgb;
}

}  // namespace facesynth::synth
