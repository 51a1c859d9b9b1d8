#include "train/lbf_baseline.h"

#include "morph/atomic_file.h"
#include "morph/error.h"
#include "train/face_box.h"

#include <opencv2/face.hpp>

namespace facesynth::train {
namespace {

cv::Rect canonical_rect() {
    const int side = static_cast<int>(kCanonicalBoxWidth);
    const int origin = (kCanonicalCropSide - side) / 2;
    return {origin, origin, side, side};
}

bool canonical_box_detector(cv::InputArray, cv::OutputArray faces, void*) {
    std::vector<cv::Rect> boxes = {canonical_rect()};
    cv::Mat(boxes).copyTo(faces);
    return true;
}

cv::Ptr<cv::face::FacemarkLBF> make_lbf(cv::face::FacemarkLBF::Params params) {
    auto lbf = cv::face::FacemarkLBF::create(params);
    lbf->setFaceDetector(canonical_box_detector, nullptr);
    return lbf;
}

}  // namespace

void train_lbf(std::span<const TrainingFace> faces, const LbfTrainOptions& options, const std::filesystem::path& out) {
    if (faces.empty()) throw Error("LBF training needs at least one face");
    const auto temp = temporary_path_for(out);
    cv::face::FacemarkLBF::Params params;
    params.n_landmarks = 68;
    params.initShape_n = options.augment;
    params.stages_n = options.stages;
    params.model_filename = temp.string() + ".yaml";
    params.save_model = true;
    params.verbose = false;
    params.seed = static_cast<unsigned>(options.seed);
    auto lbf = make_lbf(params);
    for (const auto& face : faces) {
        std::vector<cv::Point2f> points;
        for (Eigen::Index i = 0; i < face.truth.cols(); ++i)
            points.emplace_back(static_cast<float>(face.truth(0, i)), static_cast<float>(face.truth(1, i)));
        lbf->addTrainingSample(face.crop, points);
    }
    try {
        lbf->training();
    } catch (const cv::Exception& e) {
        std::filesystem::remove(params.model_filename);
        throw Error(std::string("OpenCV LBF training failed: ") + e.what());
    }
    std::filesystem::rename(params.model_filename, temp);
    commit_temporary_file(temp, out);
}

struct LbfPredictor::Impl {
    cv::Ptr<cv::face::FacemarkLBF> lbf;
};

LbfPredictor::LbfPredictor(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
    if (!std::filesystem::exists(path)) throw file_error(path.string(), "LBF model not found");
    impl_->lbf = make_lbf(cv::face::FacemarkLBF::Params());
    try {
        impl_->lbf->loadModel(path.string());
    } catch (const cv::Exception& e) {
        throw file_error(path.string(), std::string("not an OpenCV LBF model: ") + e.what());
    }
}

LbfPredictor::~LbfPredictor() = default;
LbfPredictor::LbfPredictor(LbfPredictor&&) noexcept = default;
LbfPredictor& LbfPredictor::operator=(LbfPredictor&&) noexcept = default;

Eigen::Matrix2Xd LbfPredictor::predict(const cv::Mat& crop) const {
    std::vector<cv::Rect> boxes = {canonical_rect()};
    std::vector<std::vector<cv::Point2f>> shapes;
    if (!impl_->lbf->fit(crop, boxes, shapes) || shapes.empty() || shapes[0].empty())
        throw Error("OpenCV LBF fit failed");
    Eigen::Matrix2Xd points(2, static_cast<Eigen::Index>(shapes[0].size()));
    for (std::size_t i = 0; i < shapes[0].size(); ++i) points.col(static_cast<Eigen::Index>(i)) << shapes[0][i].x, shapes[0][i].y;
    return points;
}

}  // namespace facesynth::train
