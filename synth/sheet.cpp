#include "synth/sheet.h"

#include "morph/atomic_file.h"
#include "morph/error.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <vector>

namespace facesynth::synth {

cv::Mat contact_sheet(const std::filesystem::path& dataset, const SheetOptions& options) {
    std::vector<std::filesystem::path> metas;
    const auto meta_dir = dataset / "meta";
    if (!std::filesystem::is_directory(meta_dir)) throw file_error(dataset.string(), "no meta/ folder (not a facesynth dataset with the folder format)");
    for (const auto& entry : std::filesystem::directory_iterator(meta_dir))
        if (entry.path().extension() == ".json") metas.push_back(entry.path());
    std::sort(metas.begin(), metas.end());
    if (metas.empty()) throw file_error(dataset.string(), "no samples in meta/");
    metas.resize(std::min<std::size_t>(metas.size(), static_cast<std::size_t>(std::max(options.count, 1))));

    const int columns = std::max(1, options.columns);
    const int rows = static_cast<int>((metas.size() + static_cast<std::size_t>(columns) - 1) / static_cast<std::size_t>(columns));
    cv::Mat sheet(rows * options.tile, columns * options.tile, CV_8UC3, cv::Scalar(30, 30, 30));
    for (std::size_t n = 0; n < metas.size(); ++n) {
        nlohmann::json meta;
        try {
            meta = nlohmann::json::parse(read_file(metas[n]));
        } catch (const nlohmann::json::exception& e) {
            throw file_error(metas[n].string(), std::string("invalid JSON: ") + e.what());
        }
        const std::string key = meta.at("key");
        auto image_path = dataset / "images" / (key + ".png");
        if (!std::filesystem::exists(image_path)) image_path = dataset / "images" / (key + ".jpg");
        const cv::Mat bgr = cv::imread(image_path.string(), cv::IMREAD_COLOR);
        if (bgr.empty()) throw file_error(image_path.string(), "cannot read image");
        cv::Mat tile;
        const double scale = static_cast<double>(options.tile) / std::max(bgr.cols, bgr.rows);
        cv::resize(bgr, tile, cv::Size(), scale, scale, cv::INTER_AREA);
        const auto& points = meta.at("landmarks");
        const auto& visible = meta.at("visibility");
        const auto& occluded = meta.at("occluded");
        for (std::size_t p = 0; p < points.size(); ++p) {
            const cv::Point2d centre((points[p][0].get<double>() + 0.5) * scale - 0.5, (points[p][1].get<double>() + 0.5) * scale - 0.5);
            const cv::Scalar colour = occluded[p].get<int>() ? cv::Scalar(0, 150, 255) : visible[p].get<int>() ? cv::Scalar(0, 230, 0) : cv::Scalar(0, 0, 255);
            cv::circle(tile, cv::Point(cvRound(centre.x * 4), cvRound(centre.y * 4)), 4, colour, cv::FILLED, cv::LINE_AA, 2);
        }
        char label[64];
        std::snprintf(label, sizeof label, "%s y%+.0f", key.c_str(), meta.at("yaw").get<double>());
        cv::putText(tile, label, cv::Point(3, tile.rows - 4), cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
        const int column = static_cast<int>(n % static_cast<std::size_t>(columns)), row = static_cast<int>(n / static_cast<std::size_t>(columns));
        tile.copyTo(sheet(cv::Rect(column * options.tile, row * options.tile, tile.cols, tile.rows)));
    }
    cv::Mat rgb;
    cv::cvtColor(sheet, rgb, cv::COLOR_BGR2RGB);
    return rgb;
}

}  // namespace facesynth::synth
