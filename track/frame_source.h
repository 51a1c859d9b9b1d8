#pragma once
// The frames `facesynth track` reads: a video file (OpenCV's FFmpeg backend), a folder of images
// (taken in name order) or a camera (a device index such as "0").
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace facesynth::track {

class FrameSource {
public:
    // Throws core::Error naming the input when it does not exist, cannot be opened as a video, is a
    // folder without images, or is a camera index no camera answers to.
    explicit FrameSource(const std::string& input, double folder_fps = 30);

    // The next frame (8-bit BGR) into `frame`; false at the end. Throws core::Error naming the input
    // when the first frame cannot be read (no frames), when a video ends well before the frame count
    // its container announces (truncated), or when an image of a folder cannot be read.
    bool next(cv::Mat& frame);

    [[nodiscard]] double fps() const { return fps_; }
    [[nodiscard]] const std::string& input() const { return input_; }
    [[nodiscard]] std::int64_t frames_read() const { return frames_read_; }
    // Frames the container announces (video files), the image count (folders); nullopt for cameras.
    [[nodiscard]] std::optional<std::int64_t> expected_frames() const { return expected_; }
    [[nodiscard]] double decode_seconds() const { return decode_seconds_; }  // time spent in next()

private:
    std::string input_;
    std::optional<cv::VideoCapture> capture_;
    std::vector<std::filesystem::path> images_;
    std::optional<std::int64_t> expected_;
    double fps_ = 30;
    std::int64_t frames_read_ = 0;
    double decode_seconds_ = 0;
};

}  // namespace facesynth::track
