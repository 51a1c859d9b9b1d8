#pragma once
// Turns labelled images into canonical training faces: runs the face detector on every image,
// matches the detection to the ground truth, measures how detector boxes sit relative to the
// landmarks (per view), and gives faces the detector missed a box synthesised from their landmarks
// with that measured offset and spread (recorded as such). A missed face is assigned the view whose
// detected faces have the nearest mean yaw sign proxy (nose tip offset from the eye-corner midpoint,
// in inter-ocular distances), so that it starts from that view's mean shape.
#include "train/dataset.h"
#include "train/sdm.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace facesynth::train {

struct PreparedFaces {
    std::vector<TrainingFace> faces;
    BoxStatistics boxes;
    std::vector<std::string> warnings;  // one per skipped image, naming the file
    std::uint64_t checksum = 0;         // FNV-1a over keys and landmark values of the faces kept
};

struct PrepareOptions {
    DetectorKind detector = DetectorKind::kFrontal;
    int threads = 1;
    std::uint64_t seed = 1;
    // Label adaptation: every label moved by these offsets (2 x 68, face frame, inter-ocular distances;
    // morph/landmarks.h apply_face_frame_offsets) before training; empty: labels as they are. The
    // detector's box is matched to the label as it was.
    Eigen::Matrix2Xd label_offsets;
    std::function<void(std::size_t done, std::size_t total)> on_progress;
};

[[nodiscard]] PreparedFaces prepare_training_faces(const std::vector<LabelledImage>& images,
                                                   const PrepareOptions& options);

}  // namespace facesynth::train
