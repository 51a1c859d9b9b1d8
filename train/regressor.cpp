#include "train/regressor.h"

#include "train/dlib_baseline.h"
#include "train/lbf_baseline.h"
#include "train/model_file.h"
#include "train/sdm.h"

#include "morph/error.h"

namespace facesynth::train {
namespace {

class SdmRegressor final : public LandmarkRegressor {
public:
    // Keeps the first `stages` stages (all when negative); 0 is the mean shape placed in the box.
    SdmRegressor(std::string label, const std::string& path, int stages)
        : LandmarkRegressor(std::move(label)), model_(read_sdm_model(path)) {
        if (stages > static_cast<int>(model_.stages.size()))
            throw file_error(path, "has " + std::to_string(model_.stages.size()) + " stages, asked for " +
                                       std::to_string(stages));
        if (stages >= 0) {
            model_.stages.resize(static_cast<std::size_t>(stages));
            if (model_.profile) model_.profile->stages.resize(static_cast<std::size_t>(stages));
        }
    }
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override { return sdm_detect(model_, gray, box); }
    std::optional<DetectorKind> trained_detector() const override { return model_.boxes.detector; }

private:
    SdmModel model_;
};

class DlibRegressor final : public LandmarkRegressor {
public:
    DlibRegressor(std::string label, const std::filesystem::path& path) : LandmarkRegressor(std::move(label)), predictor_(path) {}
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override { return predictor_.predict(gray, box); }

private:
    DlibShapePredictor predictor_;
};

class ErtRegressor final : public LandmarkRegressor {
public:
    explicit ErtRegressor(const std::string& path) : LandmarkRegressor("ert:" + path), predictor_(path) {}
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override {
        const FaceFrame frame{box};
        FaceBox canonical;
        canonical.centre = Eigen::Vector2d::Constant((kCanonicalCropSide - 1) / 2.0);
        canonical.width = kCanonicalBoxWidth;
        return frame.to_image(predictor_.predict(canonical_crop(gray, frame), canonical));
    }

private:
    DlibShapePredictor predictor_;
};

class LbfRegressor final : public LandmarkRegressor {
public:
    explicit LbfRegressor(const std::string& path) : LandmarkRegressor("lbf:" + path), predictor_(path) {}
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override {
        const FaceFrame frame{box};
        return frame.to_image(predictor_.predict(canonical_crop(gray, frame)));
    }

private:
    LbfPredictor predictor_;
};

}  // namespace

std::unique_ptr<LandmarkRegressor> open_regressor(const std::string& spec) {
    if (spec == "dlib") return std::make_unique<DlibRegressor>("dlib", default_dlib_predictor_path());
    if (spec.rfind("dlib:", 0) == 0) return std::make_unique<DlibRegressor>(spec, spec.substr(5));
    if (spec.rfind("ert:", 0) == 0) return std::make_unique<ErtRegressor>(spec.substr(4));
    if (spec.rfind("lbf:", 0) == 0) return std::make_unique<LbfRegressor>(spec.substr(4));
    if (spec.rfind("sdm:", 0) == 0) return std::make_unique<SdmRegressor>(spec, spec.substr(4), -1);
    if (spec.rfind("mean:", 0) == 0) return std::make_unique<SdmRegressor>(spec, spec.substr(5), 0);
    if (spec.rfind("sdm@", 0) == 0) {
        const auto colon = spec.find(':');
        int stages = -1;
        try {
            if (colon != std::string::npos) stages = std::stoi(spec.substr(4, colon - 4));
        } catch (const std::exception&) {
        }
        if (stages < 0) throw Error("regressor spec '" + spec + "': expected sdm@K:FILE with K >= 0 stages");
        return std::make_unique<SdmRegressor>(spec, spec.substr(colon + 1), stages);
    }
    return std::make_unique<SdmRegressor>("sdm:" + spec, spec, -1);
}

DetectorKind choose_detector(const std::string& option, std::span<const LandmarkRegressor* const> regressors) {
    if (option != "auto") return parse_detector_kind(option);
    for (const auto* r : regressors)
        if (const auto kind = r->trained_detector()) return *kind;
    return DetectorKind::kMultiView;
}

}  // namespace facesynth::train
