#include "track/session.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "morph/model_io.h"
#include "track/frame_source.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <fstream>
#include <set>
#include <sstream>

namespace facesynth::track {
namespace {

namespace fs = std::filesystem;

nlohmann::json points_json(const Eigen::Matrix2Xd& points) {
    nlohmann::json out = nlohmann::json::array();
    for (Eigen::Index i = 0; i < points.cols(); ++i) out.push_back({points(0, i), points(1, i)});
    return out;
}

void draw_faces(cv::Mat& image, const std::vector<FaceState>& faces) {
    for (const FaceState& face : faces) {
        const cv::Scalar colour = face.from_detector ? cv::Scalar(0, 200, 255) : cv::Scalar(0, 255, 0);
        const cv::Rect box(cv::Point(static_cast<int>(face.box.centre.x() - 0.5 * face.box.width), static_cast<int>(face.box.centre.y() - 0.5 * face.box.width)),
                           cv::Size(static_cast<int>(face.box.width), static_cast<int>(face.box.width)));
        cv::rectangle(image, box, colour, 1, cv::LINE_AA);
        for (Eigen::Index i = 0; i < face.landmarks.cols(); ++i)
            cv::circle(image, cv::Point2d(face.landmarks(0, i), face.landmarks(1, i)), 1, colour, -1, cv::LINE_AA);
        char label[64];
        std::snprintf(label, sizeof label, "#%d yaw %+.0f", face.id, face.fit.pose.angles.yaw);
        cv::putText(image, label, box.tl() + cv::Point(0, -4), cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv::LINE_AA);
    }
}

}  // namespace

train::DetectorKind tracking_detector(const std::string& option, const train::LandmarkRegressor& regressor) {
    if (option == "auto" && !regressor.trained_detector()) return train::DetectorKind::kDlib;
    const train::LandmarkRegressor* const regressors[] = {&regressor};
    return train::choose_detector(option, regressors);
}

TrackOutputs parse_track_outputs(const std::string& list) {
    TrackOutputs outputs;
    outputs.pose = false;
    std::stringstream stream(list);
    std::string item;
    while (std::getline(stream, item, ',')) {
        if (item == "landmarks") continue;  // always written
        if (item == "pose") outputs.pose = true;
        else if (item == "overlay") outputs.overlay = true;
        else throw core::Error("--outputs: unknown output '" + item + "' (expected landmarks, pose, overlay)");
    }
    return outputs;
}

std::string frame_record(std::int64_t frame, double time_s, const std::vector<FaceState>& faces, bool pose) {
    nlohmann::json j;
    j["frame"] = frame;
    j["time_s"] = time_s;
    j["faces"] = nlohmann::json::array();
    for (const FaceState& face : faces) {
        nlohmann::json f;
        f["id"] = face.id;
        f["landmarks"] = points_json(face.landmarks);
        f["box"] = {face.box.centre.x() - 0.5 * face.box.width, face.box.centre.y() - 0.5 * face.box.width, face.box.width, face.box.width};
        f["detected"] = face.from_detector;
        f["fit_error"] = face.fit_error;
        if (pose) {
            f["yaw"] = face.fit.pose.angles.yaw;
            f["pitch"] = face.fit.pose.angles.pitch;
            f["roll"] = face.fit.pose.angles.roll;
            f["expression"] = face.fit.psi;
            f["identity"] = face.identity;
            f["identity_frames"] = face.identity_frames;
        }
        j["faces"].push_back(std::move(f));
    }
    return j.dump();
}

nlohmann::json TrackSummary::json() const {
    nlohmann::json j;
    j["frames"] = frames;
    j["frames_with_face"] = frames_with_face;
    j["detector_runs"] = detector_runs;
    j["losses"] = losses;
    j["reacquired"] = reacquired;
    j["faces"] = faces;
    j["fps"] = track_seconds > 0 ? static_cast<double>(frames) / track_seconds : 0.0;
    j["ms_per_frame"] = frames > 0 ? 1000.0 * track_seconds / static_cast<double>(frames) : 0.0;
    j["decode_ms_per_frame"] = frames > 0 ? 1000.0 * decode_seconds / static_cast<double>(frames) : 0.0;
    return j;
}

TrackSummary run_track(const TrackJob& job, const std::function<void(std::int64_t, std::optional<std::int64_t>)>& on_frame) {
    if (job.max_frames < 0) throw core::Error("track: max_frames must not be negative");
    if (fs::exists(job.out)) throw core::file_error(job.out.string(), "exists already: choose a new output folder");
    FrameSource source(job.input, job.folder_fps);
    const morph::MorphableModel model = morph::load_model(job.model);
    const fit::Fitter fitter(model);
    const auto regressor = train::open_regressor(job.regressor);
    Tracker tracker(*regressor, tracking_detector(job.detector, *regressor), fitter, job.tracker);

    const fs::path temporary = core::temporary_path_for(job.out);
    std::error_code ignored;
    try {
        fs::create_directories(temporary);
        std::ofstream lines(temporary / "faces.jsonl", std::ios::binary);
        if (!lines) throw core::file_error((temporary / "faces.jsonl").string(), "cannot be written");
        std::optional<cv::VideoWriter> overlay;
        TrackSummary summary;
        std::set<int> ids;
        std::optional<std::int64_t> total = source.expected_frames();
        if (job.max_frames > 0) total = total ? std::min(*total, job.max_frames) : job.max_frames;
        cv::Mat frame;
        while ((job.max_frames == 0 || summary.frames < job.max_frames) && source.next(frame)) {
            const auto start = std::chrono::steady_clock::now();
            const double time_s = static_cast<double>(summary.frames) / source.fps();
            const std::vector<FaceState>& faces = tracker.process(frame, time_s);
            lines << frame_record(summary.frames, time_s, faces, job.outputs.pose) << '\n';
            if (job.outputs.overlay) {
                if (!overlay) {
                    overlay.emplace((temporary / "overlay.avi").string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), source.fps(), frame.size());
                    if (!overlay->isOpened()) throw core::file_error((job.out / "overlay.avi").string(), "the video writer cannot be opened");
                }
                cv::Mat drawn = frame.channels() == 3 ? frame.clone() : cv::Mat();
                if (drawn.empty()) cv::cvtColor(frame, drawn, cv::COLOR_GRAY2BGR);
                draw_faces(drawn, faces);
                overlay->write(drawn);
            }
            for (const FaceState& face : faces) ids.insert(face.id);
            if (!faces.empty()) ++summary.frames_with_face;
            ++summary.frames;
            summary.track_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (on_frame) on_frame(summary.frames, total);
        }
        if (overlay) overlay->release();
        lines.flush();
        if (!lines) throw core::file_error((job.out / "faces.jsonl").string(), "write failed (disk full?)");
        lines.close();
        summary.decode_seconds = source.decode_seconds();
        summary.detector_runs = tracker.detector_runs();
        summary.losses = tracker.losses();
        summary.reacquired = tracker.reacquired();
        summary.faces = static_cast<int>(ids.size());
        core::write_file_atomically(temporary / "summary.json", summary.json().dump(2) + "\n");
        fs::rename(temporary, job.out);
        return summary;
    } catch (...) {
        fs::remove_all(temporary, ignored);
        throw;
    }
}

}  // namespace facesynth::track
