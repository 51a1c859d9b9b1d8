#include "train/evaluate.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "morph/landmarks.h"
#include "train/sdm.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cmath>
#include <limits>

namespace facesynth::train {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

std::vector<std::pair<int, int>> yaw_bins() { return {{0, 15}, {15, 30}, {30, 45}, {45, 60}, {60, 90}}; }

Evaluation evaluate_landmarks(const std::vector<LabelledImage>& images, std::span<const LandmarkRegressor* const> regressors,
                              DetectorKind detector_kind, const std::function<void()>& on_image) {
    Evaluation result;
    result.detector = detector_kind;
    for (const auto* r : regressors) result.regressors.push_back({r->label(), {}, 0, {}});
    const FaceDetector detector(detector_kind);
    std::vector<double> predict_ms(regressors.size(), 0.0);
    double detect_ms = 0;
    int detected_faces = 0;
    const double inf = std::numeric_limits<double>::infinity();
    for (const auto& image : images) {
        FaceEvaluation face;
        face.key = image.key;
        face.yaw_deg = read_meta_yaw(image);
        try {
            const auto [truth, gray] = load_labelled_face(image);
            const auto start = Clock::now();
            const auto box = match_detection(detector.detect(gray), truth);
            detect_ms += ms_since(start);
            face.detected = box.has_value();
            if (box) face.view = box->view;
            for (std::size_t r = 0; r < regressors.size(); ++r) {
                if (!box) {
                    face.nme.push_back(inf);
                    continue;
                }
                const auto t = Clock::now();
                const Eigen::Matrix2Xd predicted = regressors[r]->predict(gray, *box);
                predict_ms[r] += ms_since(t);
                face.nme.push_back(landmark_nme(predicted, truth));
            }
            if (box) ++detected_faces;
        } catch (const core::Error& e) {
            result.warnings.push_back(std::string(e.what()) + " (counted as a miss)");
            face.detected = false;
            face.nme.assign(regressors.size(), inf);
        }
        if (!face.detected) ++result.detector_misses;
        for (std::size_t r = 0; r < regressors.size(); ++r) result.regressors[r].nmes.push_back(face.nme[r]);
        result.faces.push_back(std::move(face));
        if (on_image) on_image();
    }
    result.detector_ms_per_image = images.empty() ? 0 : detect_ms / static_cast<double>(images.size());
    for (std::size_t r = 0; r < regressors.size(); ++r) {
        auto& reg = result.regressors[r];
        reg.summary = summarise_nme(reg.nmes);
        reg.ms_per_face = detected_faces ? predict_ms[r] / detected_faces : 0;
    }
    return result;
}

}  // namespace facesynth::train
