#include "train/regressor.h"

#include "train/dlib_baseline.h"
#include "train/lbf_baseline.h"
#include "train/model_file.h"
#include "train/sdm.h"

namespace facesynth::train {
namespace {

class SdmRegressor final : public LandmarkRegressor {
public:
    // mean_only: the model's mean shape placed in the box, no stages (the initialisation baseline).
    SdmRegressor(const std::string& path, bool mean_only)
        : LandmarkRegressor((mean_only ? "mean:" : "sdm:") + path), model_(read_sdm_model(path)) {
        if (mean_only) model_.stages.clear();
    }
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override { return sdm_detect(model_, gray, box); }

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
    if (spec.rfind("sdm:", 0) == 0) return std::make_unique<SdmRegressor>(spec.substr(4), false);
    if (spec.rfind("mean:", 0) == 0) return std::make_unique<SdmRegressor>(spec.substr(5), true);
    return std::make_unique<SdmRegressor>(spec, false);
}

}  // namespace facesynth::train
