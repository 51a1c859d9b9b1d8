#pragma once
// The iBUG 68-point scheme, its named subsets, and .pts files.
// Indices are 0-based in code (iBUG id - 1); .pts files are 1-based pixel coordinates, converted on
// read and write only.
#include <Eigen/Core>

#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

namespace facesynth::morph {

inline constexpr int kNumIbugLandmarks = 68;

// 0-based indices of the outer eye corners (iBUG 37 and 46), used for inter-ocular NME.
inline constexpr int kRightEyeOuterCorner = 36;
inline constexpr int kLeftEyeOuterCorner = 45;

// The 17 jaw points (iBUG 1-17) are indices 0..16; 0..7 subject's right, 8 chin, 9..16 subject's left.
inline constexpr int kNumJawLandmarks = 17;
inline constexpr int kChinLandmark = 8;
// The nose's tip (iBUG 31) and the base of its columella (iBUG 34).
inline constexpr int kNoseTipLandmark = 30;
inline constexpr int kNoseBaseLandmark = 33;

enum class LandmarkSubset { k7, k13, k49, k68 };

// 0-based iBUG indices of a named subset (see docs/conventions.md for the lists).
[[nodiscard]] std::span<const int> landmark_subset(LandmarkSubset subset);
// "7", "13", "49" or "68"; throws core::Error otherwise.
[[nodiscard]] LandmarkSubset parse_landmark_subset(std::string_view name);

// 0-based index of each point's left/right mirror partner in the 68-point scheme.
[[nodiscard]] std::span<const int> ibug_mirror_pairs();

// Mean of the two eye centres (iBUG 37,40 and 43,46) distance, as superviseddescent uses.
[[nodiscard]] double inter_eye_centre_distance(const Eigen::Matrix2Xd& points68);
// Distance between the outer eye corners (iBUG 37 and 46): the NME normaliser.
[[nodiscard]] double inter_ocular_distance(const Eigen::Matrix2Xd& points68);

// (points - reference) in the face frame of `reference` (x along the line from the image-left eye's
// centre, iBUG 37-42, to the other's, 43-48; y perpendicular to it, pointing down), in inter-ocular
// distances: 2 x 68. How a predictor or a model places each point against an annotation, whatever the
// face's size and roll. Throws core::Error for fewer than 68 points or degenerate eyes.
[[nodiscard]] Eigen::Matrix2Xd face_frame_offsets(const Eigen::Matrix2Xd& points, const Eigen::Matrix2Xd& reference);

// The inverse: `points` moved by `offsets` (2 x 68, face frame of `points`, inter-ocular distances).
[[nodiscard]] Eigen::Matrix2Xd apply_face_frame_offsets(const Eigen::Matrix2Xd& points, const Eigen::Matrix2Xd& offsets);

// Reads an iBUG .pts file; returns 0-based pixel coordinates (2 x N). Throws core::Error naming
// the file and the problem.
[[nodiscard]] Eigen::Matrix2Xd read_pts(const std::filesystem::path& path);
// Writes 0-based pixel coordinates as a 1-based .pts file, atomically (temporary name, then rename).
void write_pts(const std::filesystem::path& path, const Eigen::Matrix2Xd& points);
// The .pts text for 0-based points (shared with in-memory writers such as tar shards).
[[nodiscard]] std::string format_pts(const Eigen::Matrix2Xd& points);

}  // namespace facesynth::morph
