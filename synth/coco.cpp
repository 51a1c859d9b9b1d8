// COCO keypoints from a dataset's meta files (synth/dataset.h coco_from_meta).
#include "synth/dataset.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "synth/dataset_layout.h"
#include "synth/scene.h"

namespace facesynth::synth {
namespace fs = std::filesystem;

nlohmann::json coco_from_meta(const fs::path& dataset, const std::vector<std::int64_t>& indices, const std::string& image_extension,
                              const std::string& description) {
    nlohmann::json names = nlohmann::json::array();
    for (int i = 1; i <= morph::kNumIbugLandmarks; ++i) names.push_back("ibug_" + std::to_string(i));
    // 1-based COCO skeleton along the iBUG contours: jaw, brows, nose bridge and base, eyes, lips.
    nlohmann::json skeleton = nlohmann::json::array();
    const auto chain = [&](int first, int last, bool closed) {
        for (int i = first; i < last; ++i) skeleton.push_back({i, i + 1});
        if (closed) skeleton.push_back({last, first});
    };
    chain(1, 17, false);
    chain(18, 22, false);
    chain(23, 27, false);
    chain(28, 31, false);
    chain(32, 36, false);
    chain(37, 42, true);
    chain(43, 48, true);
    chain(49, 60, true);
    chain(61, 68, true);
    nlohmann::json images = nlohmann::json::array(), annotations = nlohmann::json::array();
    for (const auto index : indices) {
        const std::string key = sample_key(index);
        const fs::path meta_path = dataset / "meta" / (key + ".json");
        const nlohmann::json meta = read_json_file(meta_path);
        // A meta file edited or damaged by hand: every access is checked (at()), and a wrong key,
        // type or length is reported against the file.
        try {
            const auto side = [&](const char* name) {  // checked as a double: a huge value must not overflow int
                const double v = meta.at(name).get<double>();
                if (!(v >= 1 && v <= 1e6)) throw core::file_error(meta_path.string(), std::string(name) + " out of range");
                return static_cast<int>(v);
            };
            const int width = side("image_width"), height = side("image_height");
            images.push_back({{"id", index + 1}, {"file_name", "images/" + key + image_extension}, {"width", width}, {"height", height}});
            nlohmann::json keypoints = nlohmann::json::array();
            int labelled = 0;
            const auto& points = meta.at("landmarks");
            const auto& visibility = meta.at("visibility");
            const auto& occluded = meta.at("occluded");
            for (std::size_t p = 0; p < points.size(); ++p) {
                const double x = points.at(p).at(0), y = points.at(p).at(1);
                const bool inside = x >= -0.5 && y >= -0.5 && x < width - 0.5 && y < height - 0.5;
                int v = 0;
                if (inside) v = visibility.at(p).get<double>() != 0 && occluded.at(p).get<double>() == 0 ? 2 : 1;
                keypoints.push_back(inside ? x : 0.0);
                keypoints.push_back(inside ? y : 0.0);
                keypoints.push_back(v);
                labelled += v > 0;
            }
            const auto& box = meta.at("bbox");
            annotations.push_back({{"id", index + 1}, {"image_id", index + 1}, {"category_id", 1}, {"iscrowd", 0},
                                   {"bbox", box}, {"area", box.at(2).get<double>() * box.at(3).get<double>()},
                                   {"num_keypoints", labelled}, {"keypoints", keypoints}});
        } catch (const nlohmann::json::exception& e) {
            throw core::file_error(meta_path.string(), std::string("not a facesynth meta file: ") + e.what());
        }
    }
    return {{"info", {{"description", description}, {"version", "1"}}},
            {"images", images},
            {"annotations", annotations},
            {"categories", nlohmann::json::array({{{"id", 1}, {"name", "face"}, {"supercategory", "face"}, {"keypoints", names}, {"skeleton", skeleton}}})}};
}

}  // namespace facesynth::synth
