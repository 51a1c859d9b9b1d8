#include "train/dlib_baseline.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <dlib/image_processing.h>
#include <dlib/opencv/cv_image.h>

#include <sstream>

namespace facesynth::train {
namespace {

dlib::rectangle to_dlib_rect(const FaceBox& box) {
    const cv::Rect2d r = rect_from_face_box(box);
    return dlib::rectangle(static_cast<long>(std::lround(r.x)), static_cast<long>(std::lround(r.y)),
                           static_cast<long>(std::lround(r.x + r.width - 1)),
                           static_cast<long>(std::lround(r.y + r.height - 1)));
}

}  // namespace

std::filesystem::path default_dlib_predictor_path() { return "/usr/share/dlib/shape_predictor_68_face_landmarks.dat"; }

struct DlibShapePredictor::Impl {
    dlib::shape_predictor predictor;
};

DlibShapePredictor::DlibShapePredictor(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
    if (!std::filesystem::exists(path))
        throw core::file_error(path.string(), "dlib shape predictor not found (Debian package libdlib-data)");
    try {
        dlib::deserialize(path.string()) >> impl_->predictor;
    } catch (const std::exception& e) {
        throw core::file_error(path.string(), std::string("not a dlib shape predictor: ") + e.what());
    }
    if (impl_->predictor.num_parts() == 0) throw core::file_error(path.string(), "dlib shape predictor has no parts");
}

DlibShapePredictor::~DlibShapePredictor() = default;
DlibShapePredictor::DlibShapePredictor(DlibShapePredictor&&) noexcept = default;
DlibShapePredictor& DlibShapePredictor::operator=(DlibShapePredictor&&) noexcept = default;

int DlibShapePredictor::num_parts() const { return static_cast<int>(impl_->predictor.num_parts()); }

Eigen::Matrix2Xd DlibShapePredictor::predict(const cv::Mat& gray, const FaceBox& box) const {
    if (gray.type() != CV_8UC1) throw core::Error("dlib predictor: expected an 8-bit grey image");
    const dlib::cv_image<unsigned char> image(gray);
    const dlib::full_object_detection shape = impl_->predictor(image, to_dlib_rect(box));
    Eigen::Matrix2Xd points(2, shape.num_parts());
    for (unsigned long i = 0; i < shape.num_parts(); ++i) points.col(static_cast<Eigen::Index>(i)) << shape.part(i).x(), shape.part(i).y();
    return points;
}

void train_dlib_ert(std::span<const TrainingFace> faces, const ErtTrainOptions& options, const std::filesystem::path& out) {
    if (faces.empty()) throw core::Error("dlib ERT training needs at least one face");
    dlib::array<dlib::array2d<unsigned char>> images(faces.size());
    std::vector<std::vector<dlib::full_object_detection>> shapes(faces.size());
    const dlib::rectangle rect = to_dlib_rect(canonical_face_box());
    for (std::size_t i = 0; i < faces.size(); ++i) {
        dlib::assign_image(images[i], dlib::cv_image<unsigned char>(faces[i].crop));
        std::vector<dlib::point> parts;
        for (Eigen::Index p = 0; p < faces[i].truth.cols(); ++p)
            parts.emplace_back(std::lround(faces[i].truth(0, p)), std::lround(faces[i].truth(1, p)));
        shapes[i].emplace_back(rect, parts);
    }
    dlib::shape_predictor_trainer trainer;
    trainer.set_num_threads(static_cast<unsigned long>(std::max(options.threads, 1)));
    trainer.set_oversampling_amount(static_cast<unsigned long>(std::max(options.oversampling, 1)));
    trainer.set_cascade_depth(static_cast<unsigned long>(options.cascade_depth));
    trainer.set_tree_depth(static_cast<unsigned long>(options.tree_depth));
    trainer.set_num_trees_per_cascade_level(static_cast<unsigned long>(options.trees_per_level));
    trainer.set_random_seed(std::to_string(options.seed));
    const dlib::shape_predictor predictor = trainer.train(images, shapes);
    std::ostringstream stream;
    dlib::serialize(predictor, stream);
    core::write_file_atomically(out, stream.str());
}

}  // namespace facesynth::train
