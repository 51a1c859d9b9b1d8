#include "train/lbf_baseline.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "train/face_box.h"

#include <opencv2/face.hpp>

#include <cmath>
#include <string>

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

cv::Ptr<cv::face::FacemarkLBF> make_lbf(const cv::face::FacemarkLBF::Params& params) {
    auto lbf = cv::face::FacemarkLBF::create(params);
    lbf->setFaceDetector(canonical_box_detector, nullptr);
    return lbf;
}

}  // namespace

void check_lbf_options(const LbfTrainOptions& o) {
    const auto require = [](bool ok, const std::string& what) {
        if (!ok) throw core::Error("LBF option " + what);
    };
    require(o.augment >= 1, "augment must be at least 1");
    require(o.stages >= 1 && o.stages <= 20, "stages must lie in 1-20");
    require(o.trees >= 1 && o.trees <= 100, "trees must lie in 1-100");
    require(o.depth >= 2 && o.depth <= 12, "depth must lie in 2-12");
    require(std::ssize(o.features) >= o.stages,
            "features lists " + std::to_string(o.features.size()) + " values for " + std::to_string(o.stages) + " stages");
    require(std::ssize(o.radii) >= o.stages,
            "radii lists " + std::to_string(o.radii.size()) + " values for " + std::to_string(o.stages) + " stages");
    for (int f : o.features) require(f >= 1, "features must be positive");
    for (double r : o.radii) require(r > 0 && r <= 2, "radii must lie in (0, 2] box half-widths");
}

namespace {

// OpenCV's getBBox test for a training face against its detector box (facemarkLBF.cpp): faces that
// fail it are dropped without a word, so we apply it first and count them.
bool fits_lbf_box_test(const Eigen::Matrix2Xd& truth) {
    const cv::Rect box = canonical_rect();
    const Eigen::Vector2d low = truth.rowwise().minCoeff(), high = truth.rowwise().maxCoeff();
    const Eigen::Vector2d centre = truth.rowwise().mean();
    if (high.x() - low.x() > box.width * 1.5 || high.y() - low.y() > box.height * 1.5) return false;
    // Integer halves, as in OpenCV's own test.
    const int box_centre_x = box.x + box.width / 2, box_centre_y = box.y + box.height / 2;
    const int half_width = box.width / 2, half_height = box.height / 2;
    return std::abs(centre.x() - box_centre_x) <= half_width && std::abs(centre.y() - box_centre_y) <= half_height;
}

std::vector<cv::Point2f> to_points(const Eigen::Matrix2Xd& points) {
    std::vector<cv::Point2f> result;
    for (Eigen::Index i = 0; i < points.cols(); ++i)
        result.emplace_back(static_cast<float>(points(0, i)), static_cast<float>(points(1, i)));
    return result;
}

Eigen::Matrix2Xd fit_canonical(cv::face::FacemarkLBF& lbf, const cv::Mat& crop) {
    std::vector<cv::Rect> boxes = {canonical_rect()};
    std::vector<std::vector<cv::Point2f>> shapes;
    if (!lbf.fit(crop, boxes, shapes) || shapes.empty() || shapes[0].empty()) throw core::Error("OpenCV LBF fit failed");
    Eigen::Matrix2Xd points(2, static_cast<Eigen::Index>(shapes[0].size()));
    for (std::size_t i = 0; i < shapes[0].size(); ++i) points.col(static_cast<Eigen::Index>(i)) << shapes[0][i].x, shapes[0][i].y;
    return points;
}

}  // namespace

LbfTrainReport train_lbf(std::span<const TrainingFace> faces, const LbfTrainOptions& options,
                         const std::filesystem::path& out) {
    check_lbf_options(options);
    const auto temp = core::temporary_path_for(out);
    cv::face::FacemarkLBF::Params params;
    params.n_landmarks = 68;
    params.initShape_n = options.augment;
    params.stages_n = options.stages;
    params.tree_n = options.trees;
    params.tree_depth = options.depth;
    params.feats_m = options.features;
    params.radius_m = options.radii;
    // Newer OpenCV refuses to train without a cascade file name even when a detector function is set;
    // ours (the canonical box) is what is used.
    params.cascade_face = default_face_cascade_path().string();
    params.model_filename = temp.string() + ".yaml";
    params.save_model = true;
    params.verbose = options.verbose;
    params.seed = static_cast<unsigned>(options.seed);
    auto lbf = make_lbf(params);
    LbfTrainReport report;
    std::vector<const TrainingFace*> used;
    for (const auto& face : faces) {
        if (face.truth.cols() != 68) throw core::Error("LBF training needs 68 landmarks per face");
        if (!fits_lbf_box_test(face.truth)) {
            ++report.faces_outside_box;
            continue;
        }
        std::vector<cv::Point2f> points = to_points(face.truth);
        lbf->addTrainingSample(face.crop, points);
        used.push_back(&face);
    }
    // OpenCV draws each initial shape from another face, so it needs two.
    if (used.size() < 2)
        throw core::Error("LBF training needs at least 2 faces that pass its box test (" + std::to_string(used.size()) +
                    " of " + std::to_string(faces.size()) + ")");
    try {
        lbf->training();
    } catch (const cv::Exception& e) {
        std::filesystem::remove(params.model_filename);
        throw core::Error(std::string("OpenCV LBF training failed: ") + e.what());
    }
    std::filesystem::rename(params.model_filename, temp);
    core::commit_temporary_file(temp, out);

    report.faces_used = static_cast<int>(used.size());
    Eigen::Matrix2Xd mean = Eigen::Matrix2Xd::Zero(2, 68);
    for (const auto* face : used) mean += face->truth / static_cast<double>(used.size());
    for (const auto* face : used) {
        report.train_nme_initial += landmark_nme(mean, face->truth) / static_cast<double>(used.size());
        report.train_nme_final += landmark_nme(fit_canonical(*lbf, face->crop), face->truth) / static_cast<double>(used.size());
    }
    return report;
}

struct LbfPredictor::Impl {
    cv::Ptr<cv::face::FacemarkLBF> lbf;
};

namespace {

// OpenCV's reader takes whatever it finds and crashes on missing or misshapen parts later, so the
// file's structure is checked first against what FacemarkLBF writes.
void check_lbf_model_file(const std::filesystem::path& path) {
    cv::FileStorage fs;
    try {
        fs.open(path.string(), cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
        throw core::file_error(path.string(), std::string("not an OpenCV LBF model (unreadable YAML): ") + e.err);
    }
    if (!fs.isOpened()) throw core::file_error(path.string(), "not an OpenCV LBF model (unreadable YAML)");
    const auto integer = [&](const char* key, int low, int high) {
        const cv::FileNode node = fs[key];
        if (!node.isInt() || static_cast<int>(node) < low || static_cast<int>(node) > high)
            throw core::file_error(path.string(), std::string("not an OpenCV LBF model: ") + key + " missing or outside " +
                                                std::to_string(low) + "-" + std::to_string(high));
        return static_cast<int>(node);
    };
    const int stages = integer("stages_n", 1, 20);
    const int trees = integer("tree_n", 1, 100);
    const int depth = integer("tree_depth", 2, 12);
    const int landmarks = integer("n_landmarks", 68, 68);
    const auto matrix = [&](const std::string& key, int rows, int cols) {
        cv::Mat m;
        try {
            fs[key] >> m;
        } catch (const cv::Exception&) {
            m = cv::Mat();
        }
        if (m.rows != rows || m.cols != cols || m.depth() != CV_64F)
            throw core::file_error(path.string(), "not an OpenCV LBF model: " + key + " missing or not " + std::to_string(rows) +
                                                "x" + std::to_string(cols));
    };
    matrix("regressor_meanshape", landmarks, 2);
    const int leaves = 1 << (depth - 1);
    for (int k = 0; k < stages; ++k) {
        matrix("weights_" + std::to_string(k), 2 * landmarks, landmarks * trees * leaves);
        for (int i = 0; i < landmarks; ++i)
            for (int j = 0; j < trees; ++j) {
                const std::string suffix = std::to_string(k) + "_" + std::to_string(i) + "_" + std::to_string(j);
                matrix("tree_" + suffix, 2 * leaves, 4);
                if (fs["thresholds_" + suffix].size() != 2 * static_cast<std::size_t>(leaves))
                    throw core::file_error(path.string(), "not an OpenCV LBF model: thresholds_" + suffix + " missing or short");
            }
    }
}

}  // namespace

LbfPredictor::LbfPredictor(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
    if (!std::filesystem::is_regular_file(path)) throw core::file_error(path.string(), "LBF model not found");
    check_lbf_model_file(path);
    cv::face::FacemarkLBF::Params params;
    params.verbose = false;
    impl_->lbf = make_lbf(params);
    try {
        impl_->lbf->loadModel(path.string());
    } catch (const cv::Exception& e) {
        throw core::file_error(path.string(), std::string("not an OpenCV LBF model: ") + e.err);
    }
}

LbfPredictor::~LbfPredictor() = default;
LbfPredictor::LbfPredictor(LbfPredictor&&) noexcept = default;
LbfPredictor& LbfPredictor::operator=(LbfPredictor&&) noexcept = default;

Eigen::Matrix2Xd LbfPredictor::predict(const cv::Mat& crop) const { return fit_canonical(*impl_->lbf, crop); }

}  // namespace facesynth::train
