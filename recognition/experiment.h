#pragma once
// The pose-invariant verification experiment of issue 7 (docs/recognition.md), on synthetic
// identities: every identity has one shape and one texture (frontal/evaluate.h,
// make_textured_face); its images differ in yaw and lighting only. Each image is represented twice:
// `org`, the eye-aligned crop of the rendered image, and `LM`, the frontal rendering made by
// frontalising the image from its ground-truth landmarks (contour jaw). Both are matched with
// OpenCV's LBPH (local binary pattern histograms, chi-square distance) against a gallery of one
// image per identity at a fixed yaw; probes fall in yaw bins.
#include "frontal/benchmark.h"
#include "recognition/appearance.h"
#include "recognition/face_crop.h"
#include "recognition/verification.h"
#include "morph/model.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace facesynth::recognition {

struct ExperimentOptions {
    int identities = 200;
    std::uint64_t seed = 1;
    std::vector<int> gallery_yaws{0, 20, 40};  // degrees; one gallery image per identity for each
    int probe_bin_width = 10;                  // probe |yaw| bins [0, w), [w, 2w), ... up to probe_max_yaw
    int probe_max_yaw = 70;
    int image_size = 256;                      // rendered images, px
    int isomap_size = 256;
    int frontal_size = 128;
    bool mirror_fill = false;                  // LM: fill hidden texels from the mirror side (needs a symmetry map)
    CropOptions crop;                          // both representations end as crop.size² grey images
    LbphSettings lbph;
    int example_identities = 4;
    // With a LandmarkFinder: the probes it sees are rendered with the same camera and more around the
    // face (frontal::with_context), so that the detector has the head's outline to find.
    double detection_framing = 2.5;
};

// The same hook as the frontalisation benchmark's: landmarks found on an image (the CLI brings the
// detector and regressor from train/), or nullopt when no face is found.
using frontal::LandmarkFinder;

struct BinScores {
    int gallery_yaw = 0;
    int low = 0;   // probe |yaw| in [low, high)
    int high = 0;
    MatchScores org;
    MatchScores lm;
    // With a LandmarkFinder: LM probes frontalised from found landmarks, matched against the same LM
    // gallery (enrolled from true landmarks). A probe whose face is not found, or whose fit fails, is a
    // failure to acquire: distance +inf to every gallery image (its genuine pair rejected, its impostor
    // pairs never accepted), so the pair counts match the other columns.
    MatchScores lm_detected;
    int detector_misses = 0;  // of this bin's probes (the same probes for every gallery)
};

struct ExperimentResult {
    std::vector<BinScores> bins;  // gallery-major, bins in ascending yaw
    // The first identities' matched images, a row of org crops over a row of LM renderings each
    // (galleries, then one probe per bin), 8-bit grey: for people to look at.
    cv::Mat examples;
    int images = 0;
    int failed_frontalisations = 0;  // those images are left out of both representations
    bool detected = false;           // lm_detected was measured (a LandmarkFinder was given)
    int detector_misses = 0;         // probes without found landmarks or with a failed fit, over all bins
};

// Every unordered pair of `images` (8-bit grey, same size) matched with the options' LBPH: pairs of
// the same `identity` are genuine, the others impostor. For sets of photographs (eval recognition
// --photos).
[[nodiscard]] MatchScores match_all_pairs(const std::vector<cv::Mat>& images, const std::vector<int>& identity,
                                          const ExperimentOptions& options);

// Deterministic: identity i's face, yaws and lightings depend only on (seed, i) (and on the finder,
// which should be deterministic too). `on_identity` is called after each identity's images are made.
// `find_landmarks`, when given, adds the lm_detected scores. Throws core::Error when options are
// invalid.
[[nodiscard]] ExperimentResult run_experiment(const morph::MorphableModel& model, const ExperimentOptions& options,
                                              const std::function<void()>& on_identity = {},
                                              const LandmarkFinder& find_landmarks = {});

}  // namespace facesynth::recognition
