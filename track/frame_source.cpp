#include "track/frame_source.h"

#include "core/error.h"
#include "core/image_header.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>

namespace facesynth::track {
namespace {

namespace fs = std::filesystem;

bool is_camera_index(const std::string& input) {
    return !input.empty() && input.size() <= 3 && std::all_of(input.begin(), input.end(), [](unsigned char c) { return std::isdigit(c); });
}

bool is_image_file(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" || ext == ".tiff";
}

}  // namespace

FrameSource::FrameSource(const std::string& input, double folder_fps) : input_(input), fps_(folder_fps) {
    if (is_camera_index(input) && !fs::exists(input)) {
        // Video4Linux only: the other backends OpenCV would probe for a missing camera (GStreamer,
        // libgphoto2 through libusb) print noise and keep allocations they never free.
        capture_.emplace(std::stoi(input), cv::CAP_V4L2);
        if (!capture_->isOpened()) throw core::Error("camera " + input + ": no camera answers to this index");
        const double reported = capture_->get(cv::CAP_PROP_FPS);
        if (std::isfinite(reported) && reported > 0) fps_ = reported;
        return;
    }
    if (!fs::exists(input)) throw core::file_error(input, "not found (a video file, a folder of frames or a camera index)");
    if (fs::is_directory(input)) {
        for (const auto& entry : fs::directory_iterator(input))
            if (entry.is_regular_file() && is_image_file(entry.path())) images_.push_back(entry.path());
        std::sort(images_.begin(), images_.end());
        if (images_.empty()) throw core::file_error(input, "folder has no images (.png, .jpg, .bmp, .tif)");
        expected_ = static_cast<std::int64_t>(images_.size());
        return;
    }
    capture_.emplace(input, cv::CAP_FFMPEG);
    if (!capture_->isOpened()) throw core::file_error(input, "cannot be opened as a video (unreadable, truncated or not a video)");
    const double reported = capture_->get(cv::CAP_PROP_FPS);
    if (std::isfinite(reported) && reported > 0) fps_ = reported;
    const double count = capture_->get(cv::CAP_PROP_FRAME_COUNT);
    if (std::isfinite(count) && count > 0) expected_ = static_cast<std::int64_t>(std::llround(count));
}

bool FrameSource::next(cv::Mat& frame) {
    const auto start = std::chrono::steady_clock::now();
    bool ok = false;
    if (capture_) {
        ok = capture_->read(frame) && !frame.empty();
    } else if (frames_read_ < static_cast<std::int64_t>(images_.size())) {
        const fs::path& path = images_[static_cast<std::size_t>(frames_read_)];
        core::check_image_not_too_large(path.string());
        frame = cv::imread(path.string(), cv::IMREAD_COLOR);
        if (frame.empty()) throw core::file_error(path.string(), "cannot read the image (frame " + std::to_string(frames_read_) + " of " + input_ + ")");
        ok = true;
    }
    decode_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (ok) {
        ++frames_read_;
        return true;
    }
    if (frames_read_ == 0) throw core::file_error(input_, "no frame could be read (an empty or broken video)");
    // Containers announce their length; a stream that stops well short of it was cut off. A few
    // frames' slack: the count is estimated from the duration for some formats.
    if (capture_ && expected_ && frames_read_ < *expected_ - std::max<std::int64_t>(3, *expected_ / 50))
        throw core::file_error(input_, "truncated: the video ends after " + std::to_string(frames_read_) + " of the " +
                                           std::to_string(*expected_) + " frames its container announces");
    return false;
}

}  // namespace facesynth::track
