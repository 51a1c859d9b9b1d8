#include "train/image_copies.h"

#include "core/error.h"
#include "core/random.h"
#include "degrade/degrade.h"
#include "train/face_box.h"

#include <opencv2/imgproc.hpp>

#include <string>

namespace facesynth::train {
namespace {

constexpr std::uint64_t kCopyStream = 0x434f'5059;       // "COPY"
constexpr std::uint64_t kCopyNoiseStream = 0x434e'4f49;  // "CNOI"

bool chance(core::Rng& rng, double probability) { return rng.uniform() < probability; }

// A camera unlike the photograph's: each degradation with its probability, every value drawn whatever the
// probabilities (so that changing one never moves another). Gain about black, not mid-grey, as an exposure
// change is; the ranges are those the forty-fifth run measured (docs/history/results-runs.md).
degrade::DegradationSpec copy_degradation(core::Rng& rng) {
    const double gamma = rng.uniform(0.6, 1.6);
    const double gain = rng.uniform(0.6, 1.3);
    const double blur = rng.uniform(0.4, 1.5);
    const double noise = rng.uniform(2.0, 8.0);
    const int quality = rng.uniform_int(20, 70);
    degrade::DegradationSpec d;
    if (chance(rng, 0.7)) d.gamma = gamma;
    if (chance(rng, 0.7)) d.gains = Eigen::Vector3d::Constant(gain);
    if (chance(rng, 0.4)) d.blur_sigma = blur;
    if (chance(rng, 0.4)) d.noise_sigma = noise;
    if (chance(rng, 0.3)) d.jpeg_quality = quality;
    return d;
}

}  // namespace

TrainingFace moved_and_degraded_copy(const TrainingFace& face, std::uint64_t seed, std::size_t face_index, int copy) {
    if (copy < 0) throw core::Error("image copies: copy index " + std::to_string(copy) + " is negative");
    if (face.crop.type() != CV_8UC1 || face.crop.rows != kCanonicalCropSide || face.crop.cols != kCanonicalCropSide)
        throw core::Error("image copies: training face " + std::to_string(face_index) + " is not a " +
                          std::to_string(kCanonicalCropSide) + "² 8-bit grey crop");
    // One seed per copy, drawn in turn from the face's stream: copy k's seed is the (k+1)-th draw.
    core::Rng seeds(seed, face_index, kCopyStream);
    std::uint64_t copy_seed = 0;
    for (int k = 0; k <= copy; ++k) copy_seed = seeds.next_u64();
    core::Rng rng(copy_seed, static_cast<std::uint64_t>(copy), kCopyStream);
    core::Rng noise(copy_seed, static_cast<std::uint64_t>(copy), kCopyNoiseStream);

    const double turn = rng.uniform(-kCopyMaxTurnDeg, kCopyMaxTurnDeg);
    const double scale = 1 + rng.uniform(-kCopyMaxScale, kCopyMaxScale);
    const double shift_x = rng.uniform(-kCopyMaxShift, kCopyMaxShift);
    const double shift_y = rng.uniform(-kCopyMaxShift, kCopyMaxShift);
    const double centre = (kCanonicalCropSide - 1) / 2.0;
    cv::Mat to_copy = cv::getRotationMatrix2D(cv::Point2f(static_cast<float>(centre), static_cast<float>(centre)), turn, scale);
    to_copy.at<double>(0, 2) += shift_x;
    to_copy.at<double>(1, 2) += shift_y;

    TrainingFace out;
    cv::warpAffine(face.crop, out.crop, to_copy, face.crop.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    Eigen::Matrix<double, 2, 3> m;
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 3; ++c) m(r, c) = to_copy.at<double>(r, c);
    out.truth = (m.leftCols<2>() * face.truth).colwise() + m.col(2);
    degrade::apply(out.crop, copy_degradation(rng), noise);
    out.box_from_detector = false;
    out.view = face.view;
    out.yaw_deg = face.yaw_deg;
    out.photograph = face.photograph;
    return out;
}

}  // namespace facesynth::train
