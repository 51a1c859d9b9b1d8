#pragma once
// View-specific baselines (docs/train.md, "Baselines on the same boxes"): dlib's ERT or OpenCV's LBF
// trained twice, as our view-specific cascades are, on the faces of the frontal detector view and on
// the profile views (nose-right faces mirrored into nose-left orientation), and run at test time by
// the view of the detector box. The two trained model files are kept unchanged inside one bundle file:
//   magic "FSYNVWB\0", uint32 version (1), uint32 method (1 ERT, 2 LBF), FNV-1a 64 of everything after
//   it, detector name (uint64 length + bytes), frontal and profile model sizes (uint64 × 2), then the
//   frontal model's bytes and the profile model's bytes. Little-endian.
#include "train/face_box.h"
#include "train/sdm.h"
#include "train/view_cascades.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>

namespace facesynth::train {

enum class BaselineMethod : std::uint32_t { kErt = 1, kLbf = 2 };

struct ViewBaselineBundle {
    BaselineMethod method = BaselineMethod::kErt;
    DetectorKind detector = DetectorKind::kMultiView;  // the detector whose boxes and views trained it
    std::string frontal_model, profile_model;          // the contents of each trained model file
};

// Atomic write; throws core::Error naming the file.
void write_view_baseline_bundle(const std::filesystem::path& path, const ViewBaselineBundle& bundle);
// Whether the file starts with the bundle's magic (a plain dlib or LBF file does not).
[[nodiscard]] bool is_view_baseline_bundle(const std::filesystem::path& path);
// Throws core::Error naming the file when it is missing, truncated, corrupt or of another method.
[[nodiscard]] ViewBaselineBundle read_view_baseline_bundle(const std::filesystem::path& path, BaselineMethod expected);

// Trains one model per view set with `train_one(faces, file)` (which writes a model file) and returns
// their contents. Throws core::Error naming the view when either set is empty or training fails.
using TrainBaselineFile = std::function<void(std::span<const TrainingFace> faces, const std::filesystem::path& file)>;
[[nodiscard]] ViewBaselineBundle train_view_baselines(BaselineMethod method, DetectorKind detector,
                                                      const ViewFaceSets& sets, const std::filesystem::path& out,
                                                      const TrainBaselineFile& train_one);

// Runs a canonical-crop predictor by the detector view, as the view-specific cascades do: frontal
// boxes through `frontal`, nose-left crops through `profile`, nose-right crops flipped, through
// `profile`, and the result mirrored back. Canonical crop coordinates in and out.
using CanonicalPredict = std::function<Eigen::Matrix2Xd(const cv::Mat& crop)>;
[[nodiscard]] Eigen::Matrix2Xd predict_by_view(const cv::Mat& crop, FaceView view, const CanonicalPredict& frontal,
                                               const CanonicalPredict& profile);

// A file that is removed when this goes out of scope: a bundle's model extracted for a reader that
// only takes paths (OpenCV's LBF, dlib's deserialise).
class ScopedTemporaryFile {
public:
    // Writes `contents` to a fresh file in the system's temporary folder; `label` names it in errors.
    ScopedTemporaryFile(const std::string& contents, const std::string& label);
    ~ScopedTemporaryFile();
    ScopedTemporaryFile(const ScopedTemporaryFile&) = delete;
    ScopedTemporaryFile& operator=(const ScopedTemporaryFile&) = delete;
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

}  // namespace facesynth::train
