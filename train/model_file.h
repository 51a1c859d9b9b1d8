#pragma once
// The SDM model file (docs/train.md): 8-byte magic "FSYNSDM\0", uint32 format version, a header
// (landmark count, stage count, HOG layout, canonical frame, training data checksum, payload size and
// FNV-1a checksum) and the payload (mean shape, box statistics, per-stage settings, weights, bias).
// Little-endian.
#include "train/sdm.h"

#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

namespace facesynth::train {

// 2: reduced-rank stages; 3: the face detector and per-view mean shapes; 4: an optional profile
// cascade (view-specific cascades); 5: the shape unit (kind and length) after the cascades; 6: the
// realigned cascades after the unit (a stage count, 0 for none, and the stages; the main cascade's,
// then the profile cascade's where there is one). Versions 1
// and 2 are still read, as models of the frontal detector with one mean shape, version 3 as a model
// with one cascade for all views, and versions up to 4 as measuring shapes in inter-eye-centre distances.
inline constexpr std::uint32_t kSdmModelVersion = 6;

// FNV-1a 64, the checksum of the model files' payloads.
[[nodiscard]] std::uint64_t fnv1a_64(std::string_view bytes);

// Atomic write; throws core::Error naming the file.
void write_sdm_model(const std::filesystem::path& path, const SdmModel& model);
// Throws core::Error naming the file for a missing, foreign, wrong-version, truncated or corrupt
// file, or one whose HOG layout this build does not produce, and for an ensemble file.
[[nodiscard]] SdmModel read_sdm_model(const std::filesystem::path& path);

// An ensemble (`facesynth train merge`; regressors average their members' landmarks): 8-byte magic
// "FSYNSDME", uint32 ensemble version, uint32 member count (2-64), then per member a uint64 size and
// that many bytes of a complete model file as above. The members share one face detector.
inline constexpr std::uint32_t kSdmEnsembleVersion = 1;

// Atomic write; throws core::Error naming the file for fewer than 2 members or members of different
// face detectors.
void write_sdm_ensemble(const std::filesystem::path& path, std::span<const SdmModel> members);
// The members of an ensemble file, or the one model of a model file. Errors name the file and, inside
// an ensemble, the member.
[[nodiscard]] std::vector<SdmModel> read_sdm_members(const std::filesystem::path& path);

}  // namespace facesynth::train
