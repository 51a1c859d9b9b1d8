#include "train/regressor.h"

#include "train/dlib_baseline.h"
#include "train/lbf_baseline.h"
#include "train/model_file.h"
#include "train/sdm.h"
#include "train/view_baselines.h"

#include "core/error.h"

#include <vector>

namespace facesynth::train {
namespace {

// One SDM model, or an ensemble's members (train/model_file.h) whose landmarks are averaged.
class SdmRegressor final : public LandmarkRegressor {
public:
    // Keeps the first `stages` stages of every member (all when negative); 0 is the mean shape placed in the box.
    SdmRegressor(std::string label, const std::string& path, int stages, SdmInference inference = {})
        : LandmarkRegressor(std::move(label)), members_(read_sdm_members(path)), inference_(inference) {
        if (stages < 0) return;
        for (SdmModel& model : members_) {
            if (stages > static_cast<int>(model.stages.size()))
                throw core::file_error(path, "has " + std::to_string(model.stages.size()) + " stages, asked for " +
                                                 std::to_string(stages));
            model.stages.resize(static_cast<std::size_t>(stages));
            if (model.profile) model.profile->stages.resize(static_cast<std::size_t>(stages));
        }
    }
    // One crop for all members; the crop-to-image map is affine, so averaging in the crop is the same.
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override {
        const FaceFrame frame{box};
        const cv::Mat crop = canonical_crop(gray, frame);
        Eigen::Matrix2Xd sum = sdm_refine_view(members_.front(), crop, box.view, inference_);
        for (std::size_t m = 1; m < members_.size(); ++m) sum += sdm_refine_view(members_[m], crop, box.view, inference_);
        return frame.to_image(sum / static_cast<double>(members_.size()));
    }
    std::optional<DetectorKind> trained_detector() const override { return members_.front().boxes.detector; }

private:
    std::vector<SdmModel> members_;
    SdmInference inference_;
};

class DlibRegressor final : public LandmarkRegressor {
public:
    DlibRegressor(std::string label, const std::filesystem::path& path) : LandmarkRegressor(std::move(label)), predictor_(path) {}
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override { return predictor_.predict(gray, box); }

private:
    DlibShapePredictor predictor_;
};

// A baseline that runs on our canonical crop: one model for all views (a plain dlib or LBF file), or
// a view-specific bundle (train/view_baselines.h) run by the detector box's view.
template <typename Predictor>
class CanonicalBaselineRegressor final : public LandmarkRegressor {
public:
    CanonicalBaselineRegressor(const std::string& prefix, const std::string& path, BaselineMethod method)
        : LandmarkRegressor(prefix + path) {
        if (!is_view_baseline_bundle(path)) {
            frontal_ = std::make_unique<Predictor>(path);
            return;
        }
        const ViewBaselineBundle bundle = read_view_baseline_bundle(path, method);
        detector_ = bundle.detector;
        const auto load = [&](const std::string& contents, const char* view) {
            const std::string label = path + " (" + view + " model)";
            const ScopedTemporaryFile file(contents, label);
            try {
                return std::make_unique<Predictor>(file.path());
            } catch (const core::Error& e) {
                throw core::file_error(label, e.what());
            }
        };
        frontal_ = load(bundle.frontal_model, "frontal");
        profile_ = load(bundle.profile_model, "profile");
    }
    Eigen::Matrix2Xd predict(const cv::Mat& gray, const FaceBox& box) const override {
        const FaceFrame frame{box};
        const cv::Mat crop = canonical_crop(gray, frame);
        if (!profile_) return frame.to_image(predict_canonical(*frontal_, crop));
        return frame.to_image(predict_by_view(
            crop, box.view, [&](const cv::Mat& c) { return predict_canonical(*frontal_, c); },
            [&](const cv::Mat& c) { return predict_canonical(*profile_, c); }));
    }
    std::optional<DetectorKind> trained_detector() const override { return detector_; }

private:
    static Eigen::Matrix2Xd predict_canonical(const DlibShapePredictor& p, const cv::Mat& crop) {
        return p.predict(crop, canonical_face_box());
    }
    static Eigen::Matrix2Xd predict_canonical(const LbfPredictor& p, const cv::Mat& crop) { return p.predict(crop); }

    std::unique_ptr<Predictor> frontal_, profile_;
    std::optional<DetectorKind> detector_;  // recorded in bundles only
};

}  // namespace

std::unique_ptr<LandmarkRegressor> open_regressor(const std::string& spec) {
    if (spec == "dlib") return std::make_unique<DlibRegressor>("dlib", default_dlib_predictor_path());
    if (spec.rfind("dlib:", 0) == 0) return std::make_unique<DlibRegressor>(spec, spec.substr(5));
    if (spec.rfind("ert:", 0) == 0)
        return std::make_unique<CanonicalBaselineRegressor<DlibShapePredictor>>("ert:", spec.substr(4), BaselineMethod::kErt);
    if (spec.rfind("lbf:", 0) == 0)
        return std::make_unique<CanonicalBaselineRegressor<LbfPredictor>>("lbf:", spec.substr(4), BaselineMethod::kLbf);
    if (spec.rfind("sdm:", 0) == 0) return std::make_unique<SdmRegressor>(spec, spec.substr(4), -1);
    if (spec.rfind("mean:", 0) == 0) return std::make_unique<SdmRegressor>(spec, spec.substr(5), 0);
    // Test-time modifiers of an SDM path, in either order (mirror:realign:F, realign:mirror:F).
    SdmInference inference;
    std::string path = spec;
    for (;;) {
        if (path.rfind("mirror:", 0) == 0) {
            inference.mirror = true;
            path.erase(0, 7);
        } else if (path.rfind("realign:", 0) == 0) {
            inference.realign = true;
            path.erase(0, 8);
        } else {
            break;
        }
    }
    if (inference.mirror || inference.realign) return std::make_unique<SdmRegressor>(spec, path, -1, inference);
    if (spec.rfind("sdm@", 0) == 0) {
        const auto colon = spec.find(':');
        int stages = -1;
        try {
            if (colon != std::string::npos) stages = std::stoi(spec.substr(4, colon - 4));
        } catch (const std::exception&) {
        }
        if (stages < 0) throw core::Error("regressor spec '" + spec + "': expected sdm@K:FILE with K >= 0 stages");
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
