#include "track/session.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "frontal/frontalise.h"
#include "morph/model_io.h"
#include "track/frame_source.h"
#include "track/isomap_fusion.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
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

// An MJPEG video in the temporary folder, opened at its first frame.
class VideoOut {
public:
    VideoOut(std::filesystem::path temporary, std::filesystem::path final_name, double fps)
        : temporary_(std::move(temporary)), final_(std::move(final_name)), fps_(fps) {}
    void write(const cv::Mat& frame) {
        if (!writer_) {
            writer_.emplace(temporary_.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps_, frame.size());
            if (!writer_->isOpened()) throw core::file_error(final_.string(), "the video writer cannot be opened");
        }
        writer_->write(frame);
    }
    void close() {
        if (writer_) writer_->release();
    }

private:
    std::filesystem::path temporary_, final_;
    double fps_;
    std::optional<cv::VideoWriter> writer_;
};

// The fused isomap as a picture: its colours where some frame saw the texel, black elsewhere.
cv::Mat isomap_picture(const cv::Mat& bgra) {
    cv::Mat picture(bgra.size(), CV_8UC3, cv::Scalar::all(0));
    for (int y = 0; y < bgra.rows; ++y)
        for (int x = 0; x < bgra.cols; ++x) {
            const cv::Vec4b& t = bgra.at<cv::Vec4b>(y, x);
            if (t[3] > 0) picture.at<cv::Vec3b>(y, x) = cv::Vec3b(t[0], t[1], t[2]);
        }
    return picture;
}

// The tiles of the isomap and frontal videos, one per face followed at once: a face keeps its tile
// while it is followed, a new face takes the first free one.
class FaceTiles {
public:
    explicit FaceTiles(int count) : ids_(static_cast<std::size_t>(count), kFree) {}
    [[nodiscard]] int count() const { return static_cast<int>(ids_.size()); }
    // The tile of each of `faces` (at most count() of them).
    std::vector<int> assign(const std::vector<FaceState>& faces) {
        for (int& id : ids_)
            if (std::none_of(faces.begin(), faces.end(), [id](const FaceState& f) { return f.id == id; })) id = kFree;
        std::vector<int> tile_of;
        for (const FaceState& face : faces) {
            auto tile = std::find(ids_.begin(), ids_.end(), face.id);
            if (tile == ids_.end()) tile = std::find(ids_.begin(), ids_.end(), kFree);
            if (tile == ids_.end()) throw core::Error("track: more faces than --max-faces");
            *tile = face.id;
            tile_of.push_back(static_cast<int>(tile - ids_.begin()));
        }
        return tile_of;
    }

private:
    static constexpr int kFree = -1;
    std::vector<int> ids_;
};

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
        else if (item == "isomap") outputs.isomap = true;
        else if (item == "frontal") outputs.frontal = true;
        else throw core::Error("--outputs: unknown output '" + item + "' (expected landmarks, pose, overlay, isomap, frontal)");
    }
    return outputs;
}

std::string frame_record(std::int64_t frame, double time_s, const std::vector<FaceState>& faces, const Tracker& tracker, bool pose) {
    nlohmann::json j;
    j["frame"] = frame;
    j["time_s"] = time_s;
    j["scene_change"] = tracker.scene_change();
    j["cut"] = tracker.cut();
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
    j["fallback_detector_runs"] = fallback_runs;
    j["losses"] = losses;
    j["reacquired"] = reacquired;
    j["cuts"] = cuts;
    j["reidentified"] = reidentified;
    j["faces"] = faces;
    j["fps"] = track_seconds > 0 ? static_cast<double>(frames) / track_seconds : 0.0;
    j["ms_per_frame"] = frames > 0 ? 1000.0 * track_seconds / static_cast<double>(frames) : 0.0;
    j["decode_ms_per_frame"] = frames > 0 ? 1000.0 * decode_seconds / static_cast<double>(frames) : 0.0;
    j["texture_ms_per_frame"] = frames > 0 ? 1000.0 * texture_seconds / static_cast<double>(frames) : 0.0;
    j["isomap_coverage"] = isomap_coverage;
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
        VideoOut overlay(temporary / "overlay.avi", job.out / "overlay.avi", source.fps());
        VideoOut isomap_video(temporary / "isomap.avi", job.out / "isomap.avi", source.fps());
        VideoOut frontal_video(temporary / "frontal.avi", job.out / "frontal.avi", source.fps());
        const bool textures = job.outputs.isomap || job.outputs.frontal;
        std::optional<frontal::Frontaliser> frontaliser;  // a renderer: only when textures are asked for
        if (textures) frontaliser.emplace(model);
        frontal::IsomapOptions isomap_options;
        isomap_options.size = job.outputs.isomap_size;
        frontal::FrontalRenderOptions frontal_options;
        frontal_options.size = job.outputs.frontal_size;
        std::map<int, IsomapFusion> fusions;  // per face id
        FaceTiles tiles(job.tracker.max_faces);
        TrackSummary summary;
        std::set<int> ids;
        std::optional<std::int64_t> total = source.expected_frames();
        if (job.max_frames > 0) total = total ? std::min(*total, job.max_frames) : job.max_frames;
        cv::Mat frame;
        while ((job.max_frames == 0 || summary.frames < job.max_frames) && source.next(frame)) {
            const auto start = std::chrono::steady_clock::now();
            const double time_s = static_cast<double>(summary.frames) / source.fps();
            const std::vector<FaceState>& faces = tracker.process(frame, time_s);
            lines << frame_record(summary.frames, time_s, faces, tracker, job.outputs.pose) << '\n';
            if (job.outputs.overlay) {
                cv::Mat drawn = frame.channels() == 3 ? frame.clone() : cv::Mat();
                if (drawn.empty()) cv::cvtColor(frame, drawn, cv::COLOR_GRAY2BGR);
                draw_faces(drawn, faces);
                overlay.write(drawn);
            }
            if (textures) {
                // Every followed face in its tile: its isomap from this frame joins the ones before,
                // and the fused texture is shown, and rendered frontally with the fused identity and
                // this frame's expression.
                const auto texture_start = std::chrono::steady_clock::now();
                const int isomap_side = job.outputs.isomap_size, frontal_side = job.outputs.frontal_size;
                cv::Mat isomap_frame(isomap_side, isomap_side * tiles.count(), CV_8UC3, cv::Scalar::all(0));
                cv::Mat frontal_frame(frontal_side, frontal_side * tiles.count(), CV_8UC3, cv::Scalar::all(0));
                const std::vector<int> tile_of = tiles.assign(faces);
                for (std::size_t f = 0; f < faces.size(); ++f) {
                    const FaceState& face = faces[f];
                    const Eigen::Matrix3Xf seen = fit::fitted_shape(model, face.fit);
                    IsomapFusion& fusion = fusions[face.id];
                    fusion.add(frontaliser->extract_isomap(frame, seen, {face.fit.camera, face.fit.pose}, isomap_options));
                    isomap_picture(fusion.fused()).copyTo(isomap_frame(cv::Rect(tile_of[f] * isomap_side, 0, isomap_side, isomap_side)));
                    if (job.outputs.frontal)
                        frontaliser->render_frontal(model.shape_instance(face.identity, face.fit.psi), fusion.fused(), frontal_options)
                            .image.copyTo(frontal_frame(cv::Rect(tile_of[f] * frontal_side, 0, frontal_side, frontal_side)));
                }
                if (job.outputs.isomap) isomap_video.write(isomap_frame);
                if (job.outputs.frontal) frontal_video.write(frontal_frame);
                summary.texture_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - texture_start).count();
            }
            for (const FaceState& face : faces) ids.insert(face.id);
            if (!faces.empty()) ++summary.frames_with_face;
            ++summary.frames;
            summary.track_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (on_frame) on_frame(summary.frames, total);
        }
        overlay.close();
        isomap_video.close();
        frontal_video.close();
        if (textures && !fusions.empty()) {
            const auto longest = std::max_element(fusions.begin(), fusions.end(), [](const auto& a, const auto& b) { return a.second.frames() < b.second.frames(); });
            summary.isomap_coverage = longest->second.coverage(frontal::layout_mask(frontaliser->uv_raster(job.outputs.isomap_size)));
        }
        lines.flush();
        if (!lines) throw core::file_error((job.out / "faces.jsonl").string(), "write failed (disk full?)");
        lines.close();
        summary.decode_seconds = source.decode_seconds();
        summary.detector_runs = tracker.detector_runs();
        summary.fallback_runs = tracker.fallback_runs();
        summary.losses = tracker.losses();
        summary.cuts = tracker.cuts();
        summary.reidentified = tracker.reidentified();
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
