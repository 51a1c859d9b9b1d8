#include "profile/dataset.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "core/random.h"
#include "morph/landmarks.h"
#include "synth/dataset_layout.h"
#include "synth/png.h"
#include "train/photo_landmarks.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace facesynth::profile {
namespace {

constexpr const char* kSettingsFile = "profile.json";
constexpr const char* kPhotoFolder = "photos";  // one record per finished photograph: marks it complete

std::string sample_key(std::int64_t index) {
    char key[32];
    std::snprintf(key, sizeof key, "s%08lld", static_cast<long long>(index));
    return key;
}

std::string photo_key(std::size_t index) {
    char key[32];
    std::snprintf(key, sizeof key, "p%08zu", index);
    return key;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

nlohmann::json points_json(const Eigen::Matrix2Xd& points) {
    nlohmann::json out = nlohmann::json::array();
    for (Eigen::Index k = 0; k < points.cols(); ++k) out.push_back({points(0, k), points(1, k)});
    return out;
}

nlohmann::json flags_json(const std::vector<std::uint8_t>& flags) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto f : flags) out.push_back(static_cast<int>(f));
    return out;
}

nlohmann::json photo_record(const fs::path& photo, const FoundLandmarks& found, const PhotoScene& scene) {
    const auto& pose = scene.camera.angles;
    nlohmann::json fit = {{"yaw", pose.yaw},
                          {"pitch", pose.pitch},
                          {"roll", pose.roll},
                          {"scale_px_per_mm", scene.camera.scale},
                          {"rms_px", scene.fit.reprojection_rms_px},
                          {"error_iod", scene.fit_error_iod},
                          {"alpha", scene.fit.alpha},
                          {"psi", scene.fit.psi}};
    return {{"photo", photo.string()},
            {"landmarks_source", found.source},
            {"fit", fit},
            // view pixel = (photo pixel + 0.5) * scale - 0.5 - offset
            {"crop", {{"scale_x", scene.scale.x()}, {"scale_y", scene.scale.y()},
                      {"offset_x", scene.roi_origin.x() * scene.scale.x() + scene.view_origin.x()},
                      {"offset_y", scene.roi_origin.y() * scene.scale.y() + scene.view_origin.y()}}},
            {"residual_px", points_json(scene.residual_px)}};
}

std::string encode_image(const cv::Mat& rgb, const ProfileRunOptions& options, synth::PngEncoder& png, const std::string& context) {
    if (options.image_format != "jpg") return png.encode(rgb, context);
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    std::vector<unsigned char> bytes;
    if (!cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality})) throw core::Error(context + ": image encoding failed");
    return {bytes.begin(), bytes.end()};
}

}  // namespace

std::vector<double> parse_yaws(const std::string& text) {
    const auto fail = [&](const std::string& why) { return core::Error("--yaws '" + text + "': " + why); };
    std::vector<double> values;
    const auto number = [&](const std::string& part) {
        std::size_t used = 0;
        double v = 0;
        try {
            v = std::stod(part, &used);
        } catch (const std::exception&) {
            throw fail("'" + part + "' is not a number");
        }
        if (used != part.size() || !std::isfinite(v)) throw fail("'" + part + "' is not a number");
        if (v < -180 || v > 180) throw fail("yaw " + part + " lies outside [-180, 180]");
        return v;
    };
    if (text.find(':') != std::string::npos) {
        std::vector<std::string> parts;
        std::stringstream stream(text);
        for (std::string part; std::getline(stream, part, ':');) parts.push_back(part);
        if (parts.size() != 3) throw fail("expected first:last:step");
        const double first = number(parts[0]), last = number(parts[1]);
        double step = 0;
        try {
            step = std::stod(parts[2]);
        } catch (const std::exception&) {
            throw fail("the step is not a number");
        }
        if (!(step > 0)) throw fail("the step must be positive");
        if (last < first) throw fail("last is below first");
        for (int k = 0; first + k * step <= last + 1e-9; ++k) values.push_back(first + k * step);
    } else {
        std::stringstream stream(text);
        for (std::string part; std::getline(stream, part, ',');)
            if (!part.empty()) values.push_back(number(part));
    }
    if (values.empty()) throw fail("no yaw");
    if (values.size() > 1000) throw fail("more than 1000 views per photograph");
    return values;
}

std::optional<ViewPose> plan_view(const ViewPlan& plan, const ViewPose& source, std::uint64_t seed, std::int64_t index) {
    const int views = plan.views();
    if (views <= 0) throw core::Error("profile: no views per photograph");
    core::Rng rng = core::make_rng(seed, static_cast<std::uint64_t>(index), core::RandomStream::kPose);
    ViewPose pose = source;
    if (!plan.yaws.empty()) {
        pose.yaw = plan.yaws[static_cast<std::size_t>(index % views)];
        if (std::abs(pose.yaw - source.yaw) > plan.max_turn + 1e-9) return std::nullopt;
    } else {
        double low = std::max(-plan.yaw_limit, source.yaw - plan.max_turn);
        double high = std::min(plan.yaw_limit, source.yaw + plan.max_turn);
        if (plan.toward_profile) {
            constexpr double kFrontal = 5;
            const bool right = source.yaw > kFrontal || (std::abs(source.yaw) <= kFrontal && rng.uniform() < 0.5);
            if (right)
                low = std::max(low, std::min(source.yaw, high));
            else
                high = std::min(high, std::max(source.yaw, low));
        }
        if (high < low) return std::nullopt;
        pose.yaw = rng.uniform(low, high);
    }
    if (plan.pitch_jitter > 0) pose.pitch = source.pitch + rng.normal(0, plan.pitch_jitter);
    return pose;
}

nlohmann::json profile_settings(const ProfileRunOptions& options, const morph::MorphableModel& model) {
    const ProfileOptions& p = options.profile;
    return {{"tool", "facesynth profile"},
            {"model", model.name},
            {"model_checksum", model.checksum()},
            {"seed", options.seed},
            {"yaws", options.plan.yaws},
            {"views_per_photo", options.plan.views()},
            {"yaw_limit", options.plan.yaw_limit},
            {"toward_profile", options.plan.toward_profile},
            {"max_turn", options.plan.max_turn},
            {"pitch_jitter", options.plan.pitch_jitter},
            {"jaw", options.jaw},
            {"image_format", options.image_format},
            {"jpeg_quality", options.jpeg_quality},
            {"size", p.size},
            {"crop_margin", p.crop_margin},
            {"isomap_size", p.isomap_size},
            {"grid_step_px", p.grid_step_px},
            {"falloff_mm", p.falloff_mm},
            {"far_plane_mm", p.far_plane_mm},
            {"grid_behind_mm", p.grid_behind_mm},
            {"smoothing_px", p.smoothing_px},
            {"apply_residual", p.apply_residual},
            {"fit_lambda", p.fit.lambda},
            {"fit_expression_lambda", p.fit.expression_lambda},
            {"fit_iterations", p.fit.iterations}};
}

ProfileRunResult run_profile(const ProfileRunOptions& options, const morph::MorphableModel& model) {
    if (options.jaw != "contour" && options.jaw != "fixed") throw core::Error("profile: jaw must be 'contour' or 'fixed', not '" + options.jaw + "'");
    if (options.image_format != "png" && options.image_format != "jpg")
        throw core::Error("profile: image format must be 'png' or 'jpg', not '" + options.image_format + "'");
    if (options.plan.views() <= 0) throw core::Error("profile: give the views' yaws or a number of views per photograph");
    if (options.threads < 1) throw core::Error("profile: threads must be at least 1");
    const auto start = std::chrono::steady_clock::now();
    const std::vector<fs::path> photos = train::list_photos(options.photos);
    ProfileRunResult result;
    result.photos = photos.size();

    const fs::path& out = options.out;
    const nlohmann::json settings = profile_settings(options, model);
    const fs::path settings_path = out / kSettingsFile;
    if (fs::exists(settings_path)) {
        nlohmann::json existing;
        try {
            existing = nlohmann::json::parse(core::read_file(settings_path));
        } catch (const nlohmann::json::exception& e) {
            throw core::file_error(settings_path.string(), std::string("not JSON: ") + e.what());
        }
        const std::string key = synth::identity_mismatch(existing, settings);
        if (!key.empty()) {
            if (!options.overwrite)
                throw core::file_error(out.string(), "holds a profiled dataset made with other settings (" + key +
                                                         " differs); use another folder or --overwrite");
            for (const char* folder : {"images", "landmarks", "meta", kPhotoFolder}) fs::remove_all(out / folder);
        }
    }
    for (const char* folder : {"images", "landmarks", "meta", kPhotoFolder}) {
        std::error_code error;
        fs::create_directories(out / folder, error);
        if (error) throw core::file_error((out / folder).string(), "cannot create the folder: " + error.message());
    }
    core::write_file_atomically(settings_path, settings.dump(2) + "\n");

    std::vector<std::size_t> todo;
    for (std::size_t p = 0; p < photos.size(); ++p) {
        if (static_cast<int>(p % static_cast<std::size_t>(options.shard.count)) != options.shard.index) continue;
        ++result.photos_in_shard;
        if (fs::exists(out / kPhotoFolder / (photo_key(p) + ".json")))
            ++result.photos_done_before;
        else
            todo.push_back(p);
    }
    if (options.on_start) options.on_start(todo.size());

    const int views = options.plan.views();
    const std::string extension = options.image_format == "jpg" ? ".jpg" : ".png";
    std::mutex mutex;  // result, on_photo and the landmark finder
    std::atomic<std::size_t> next{0};
    std::exception_ptr fatal;
    const auto work = [&](int worker) {
        try {
            render::RendererOptions renderer_options = options.renderer;
            renderer_options.software_display = worker;
            Profiler profiler(model, renderer_options);
            synth::PngEncoder png(1);
            for (std::size_t n = next++; n < todo.size(); n = next++) {
                const std::size_t p = todo[n];
                const fs::path& photo = photos[p];
                std::size_t written = 0, skipped = 0;
                double prepare_s = 0, render_s = 0, write_s = 0;
                try {
                    auto t0 = std::chrono::steady_clock::now();
                    const cv::Mat image = train::read_photo(photo);
                    FoundLandmarks found;
                    if (options.landmarks) {
                        const std::lock_guard lock(mutex);
                        found = options.landmarks(photo, image);
                    } else {
                        found = {train::read_pts68(fs::path(photo).replace_extension(".pts")), "pts"};
                    }
                    if (found.points.cols() != 68) throw core::file_error(photo.string(), "its landmarks have " + std::to_string(found.points.cols()) + " points, expected 68");
                    for (Eigen::Index k = 0; k < found.points.cols(); ++k)
                        if (!found.points.col(k).allFinite() || found.points(0, k) < -0.5 * image.cols || found.points(1, k) < -0.5 * image.rows ||
                            found.points(0, k) > 1.5 * image.cols || found.points(1, k) > 1.5 * image.rows)
                            throw core::file_error(photo.string(), "landmark " + std::to_string(k + 1) + " lies far outside the image (" +
                                                                       std::to_string(image.cols) + "x" + std::to_string(image.rows) + "): a .pts of another image?");
                    PhotoScene scene;
                    try {
                        scene = profiler.prepare(image, found.points, options.profile);
                    } catch (const core::Error& e) {
                        throw core::file_error(photo.string(), e.what());
                    }
                    prepare_s = seconds_since(t0);
                    const nlohmann::json record = photo_record(photo, found, scene);
                    const ViewPose source = Profiler::source_pose(scene);
                    for (int v = 0; v < views; ++v) {
                        const std::int64_t index = static_cast<std::int64_t>(p) * views + v;
                        const std::optional<ViewPose> pose = plan_view(options.plan, source, options.seed, index);
                        if (!pose) {
                            ++skipped;
                            continue;
                        }
                        const std::string key = sample_key(index);
                        if (fs::exists(out / "meta" / (key + ".json"))) continue;  // an earlier, interrupted run's
                        t0 = std::chrono::steady_clock::now();
                        const ProfiledView view = profiler.render_view(scene, *pose, options.profile);
                        render_s += seconds_since(t0);
                        t0 = std::chrono::steady_clock::now();
                        const bool contour = options.jaw == "contour";
                        const Eigen::Matrix2Xd& labels = contour ? view.landmarks_contour : view.landmarks_fixed;
                        const auto& visible = contour ? view.visible_contour : view.visible_fixed;
                        nlohmann::json meta = {{"key", key},
                                               {"index", index},
                                               {"yaw", pose->yaw},
                                               {"pitch", pose->pitch},
                                               {"roll", pose->roll},
                                               {"jaw", options.jaw},
                                               {"landmarks", points_json(labels)},
                                               {"visibility", flags_json(visible)},
                                               {"occluded", std::vector<int>(68, 0)},
                                               {"landmarks_fixed", points_json(view.landmarks_fixed)},
                                               {"landmarks_contour", points_json(view.landmarks_contour)},
                                               {"visibility_fixed", flags_json(view.visible_fixed)},
                                               {"visibility_contour", flags_json(view.visible_contour)},
                                               {"residual_px", points_json(view.residual_px)},
                                               {"filled_share", view.filled_share},
                                               {"stretched_share", view.stretched_share},
                                               {"face_share", view.face_share},
                                               {"photo_index", p},
                                               {"view", v},
                                               {"source", record}};
                        core::write_file_atomically(out / "images" / (key + extension), encode_image(view.image, options, png, key));
                        core::write_file_atomically(out / "landmarks" / (key + ".pts"), morph::format_pts(labels));
                        core::write_file_atomically(out / "meta" / (key + ".json"), meta.dump() + "\n");
                        write_s += seconds_since(t0);
                        ++written;
                    }
                    nlohmann::json done = record;
                    done["index"] = p;
                    done["views_written"] = written;
                    done["views_skipped"] = skipped;
                    core::write_file_atomically(out / kPhotoFolder / (photo_key(p) + ".json"), done.dump(2) + "\n");
                    const std::lock_guard lock(mutex);
                    if (found.source != "pts") ++result.detected;
                } catch (const core::Error& e) {
                    const std::lock_guard lock(mutex);
                    result.failures.push_back({photo.string(), e.what()});
                }
                const std::lock_guard lock(mutex);
                result.views_written += written;
                result.views_skipped += skipped;
                result.prepare_seconds += prepare_s;
                result.render_seconds += render_s;
                result.write_seconds += write_s;
                if (options.on_photo) options.on_photo();
            }
        } catch (...) {
            const std::lock_guard lock(mutex);
            if (!fatal) fatal = std::current_exception();
            next = todo.size();
        }
    };
    const int threads = std::max(1, std::min<int>(options.threads, static_cast<int>(std::max<std::size_t>(todo.size(), 1))));
    std::vector<std::thread> workers;
    for (int w = 1; w < threads; ++w) workers.emplace_back(work, w);
    work(0);
    for (auto& t : workers) t.join();
    if (fatal) std::rethrow_exception(fatal);
    std::sort(result.failures.begin(), result.failures.end(), [](const PhotoFailure& a, const PhotoFailure& b) { return a.photo < b.photo; });
    result.seconds = seconds_since(start);
    return result;
}

}  // namespace facesynth::profile
