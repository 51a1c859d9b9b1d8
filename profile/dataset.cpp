#include "profile/dataset.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_header.h"
#include "core/random.h"
#include "morph/landmarks.h"
#include "synth/dataset_layout.h"
#include "synth/config.h"
#include "synth/png.h"
#include "synth/scene.h"
#include "synth/tar.h"
#include "train/photo_landmarks.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace facesynth::profile {
namespace {

using synth::sample_key;

constexpr const char* kSettingsFile = "profile.json";
constexpr const char* kPhotoFolder = "photos";  // one record per finished photograph: marks it complete

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

// The folders a run writes into, each created if missing.
constexpr std::array<const char*, 4> kFolders = {"images", "landmarks", "meta", kPhotoFolder};

// The keys of photograph p's views that are on disk, in index order.
std::vector<std::int64_t> views_on_disk(const fs::path& out, std::size_t p, int views) {
    std::vector<std::int64_t> indices;
    for (int v = 0; v < views; ++v) {
        const std::int64_t index = static_cast<std::int64_t>(p) * views + v;
        if (fs::exists(out / "meta" / (sample_key(index) + ".json"))) indices.push_back(index);
    }
    return indices;
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
    if (!plan.random_yaws()) {
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

void apply_config_file(ProfileRunOptions& options, const fs::path& path) {
    std::string yaws;
    int views_per_photo = 0;
    ViewPlan& plan = options.plan;
    ProfileOptions& scene = options.profile;
    ProfileOutput& output = options.output;
    const std::vector<synth::ConfigField> fields = {
        {"seed", &options.seed, "seed of the random yaws and pitches"},
        {"jaw", &options.jaw, "jaw landmarks in the .pts: contour or fixed"},
        {"views.yaws", &yaws, "the views' yaws, first:last:step or a,b,c (degrees)"},
        {"views.per_photo", &views_per_photo, "instead of yaws: this many views per photograph at random yaws"},
        {"views.yaw_limit", &plan.yaw_limit, "random yaws lie in [-limit, limit]"},
        {"views.toward_profile", &plan.toward_profile, "random yaws only further toward profile than the photograph's"},
        {"views.max_turn", &plan.max_turn, "no view turns the face more than this from its yaw in the photograph"},
        {"views.pitch_jitter", &plan.pitch_jitter, "standard deviation of a random change of pitch per view (degrees)"},
        {"views.relight", &plan.relight, "largest strength of a directional light added per view (0: the photograph's light)"},
        {"scene.size", &scene.size, "view side, px"},
        {"scene.crop_margin", &scene.crop_margin, "the view shows this many times the landmarks' box"},
        {"scene.isomap_size", &scene.isomap_size, "face texture side, texels"},
        {"scene.grid_step_px", &scene.grid_step_px, "spacing of the picture's grid mesh, px"},
        {"scene.falloff_mm", &scene.falloff_mm, "outside the head, depth and motion fade to the far plane over this distance"},
        {"scene.far_plane_mm", &scene.far_plane_mm, "the far plane, behind the head's centre"},
        {"scene.grid_behind_mm", &scene.grid_behind_mm, "the grid lies this far behind the fitted surface"},
        {"scene.smoothing_px", &scene.smoothing_px, "Gaussian smoothing of the grid's depth and motion"},
        {"scene.apply_residual", &scene.apply_residual, "add the annotation's residual to the fit to every view's landmarks"},
        {"fit.lambda", &scene.fit.lambda, "shape regularisation of the fit"},
        {"fit.expression_lambda", &scene.fit.expression_lambda, "expression regularisation of the fit"},
        {"fit.iterations", &scene.fit.iterations, "fit rounds"},
        {"output.formats", &output.formats, "folder, wds, coco (the folder is always written)"},
        {"output.image_format", &output.image_format, "png or jpg"},
        {"output.jpeg_quality", &output.jpeg_quality, "JPEG quality"},
        {"output.png_compression", &output.png_compression, "PNG deflate level 0-9"},
        {"output.wds_shard_size", &output.wds_shard_size, "views per WebDataset tar (whole photographs)"},
        {"output.wds_prefix", &output.wds_prefix, "WebDataset tar name prefix"}};
    synth::apply_toml_fields(fields, path);
    if (!yaws.empty() && views_per_photo > 0) throw core::file_error(path.string(), "give views.yaws or views.per_photo, not both");
    if (!yaws.empty()) {
        try {
            plan.yaws = parse_yaws(yaws);
        } catch (const core::Error& e) {
            throw core::file_error(path.string(), std::string("views.yaws: ") + e.what());
        }
        plan.views_per_photo = 0;
    } else if (views_per_photo != 0) {
        if (views_per_photo < 1 || views_per_photo > 1000) throw core::file_error(path.string(), "views.per_photo must lie in [1, 1000]");
        plan.views_per_photo = views_per_photo;
    }
}

void validate(const ProfileRunOptions& options) {
    const auto in_range = [](const char* key, double value, double low, double high) {
        if (!(value >= low && value <= high))
            throw core::Error("profile: " + std::string(key) + " = " + std::to_string(value) + " lies outside [" + std::to_string(low) + ", " +
                              std::to_string(high) + "]");
    };
    if (options.jaw != "contour" && options.jaw != "fixed") throw core::Error("profile: jaw must be 'contour' or 'fixed', not '" + options.jaw + "'");
    const ProfileOutput& output = options.output;
    if (output.image_format != "png" && output.image_format != "jpg")
        throw core::Error("profile: output.image_format must be 'png' or 'jpg', not '" + output.image_format + "'");
    (void)synth::parse_formats(output.formats);
    if (output.wds_prefix.empty() || output.wds_prefix.find_first_of("/.") != std::string::npos)
        throw core::Error("profile: output.wds_prefix must be a non-empty name without '/' or '.'");
    in_range("output.jpeg_quality", output.jpeg_quality, 1, 100);
    in_range("output.png_compression", output.png_compression, 0, 9);
    in_range("output.wds_shard_size", output.wds_shard_size, 1, 1e7);
    const ViewPlan& plan = options.plan;
    if (plan.views() <= 0) throw core::Error("profile: give the views' yaws or a number of views per photograph");
    in_range("views.per_photo", plan.views(), 1, 1000);
    in_range("views.yaw_limit", plan.yaw_limit, 0, 180);
    in_range("views.max_turn", plan.max_turn, 0, 360);
    in_range("views.pitch_jitter", plan.pitch_jitter, 0, 45);
    in_range("views.relight", plan.relight, 0, 0.9);
    const ProfileOptions& scene = options.profile;
    in_range("scene.size", scene.size, 16, 4096);
    in_range("scene.crop_margin", scene.crop_margin, 1, 8);
    in_range("scene.isomap_size", scene.isomap_size, 64, 4096);
    in_range("scene.grid_step_px", scene.grid_step_px, 1, 64);
    in_range("scene.falloff_mm", scene.falloff_mm, 1, 1000);
    in_range("scene.far_plane_mm", scene.far_plane_mm, 1, 10000);
    in_range("scene.grid_behind_mm", scene.grid_behind_mm, 0, 100);
    in_range("scene.smoothing_px", scene.smoothing_px, 0, 100);
    in_range("fit.lambda", scene.fit.lambda, 0, 1e9);
    in_range("fit.expression_lambda", scene.fit.expression_lambda, 0, 1e9);
    in_range("fit.iterations", scene.fit.iterations, 1, 100);
    if (options.threads < 1) throw core::Error("profile: threads must be at least 1");
}

std::size_t photos_per_tar(const ProfileRunOptions& options) {
    if (!synth::parse_formats(options.output.formats).wds) return 1;
    return static_cast<std::size_t>(std::max(1, options.output.wds_shard_size / std::max(1, options.plan.views())));
}

ViewLight plan_light(const ViewPlan& plan, std::uint64_t seed, std::int64_t index) {
    if (!(plan.relight > 0)) return {};
    core::Rng rng = core::make_rng(seed, static_cast<std::uint64_t>(index), core::RandomStream::kLighting);
    ViewLight light;
    light.strength = rng.uniform(0, plan.relight);
    light.azimuth = rng.uniform(-75, 75);
    light.elevation = rng.uniform(-20, 50);
    return light;
}

nlohmann::json profile_settings(const ProfileRunOptions& options, const morph::MorphableModel& model) {
    const ProfileOptions& p = options.profile;
    return {{"tool", "facesynth profile"},
            {"model", model.name},
            {"model_checksum", model.checksum()},
            {"seed", options.seed},
            {"yaws", options.plan.random_yaws() ? std::vector<double>{} : options.plan.yaws},
            {"views_per_photo", options.plan.views()},
            {"yaw_limit", options.plan.yaw_limit},
            {"toward_profile", options.plan.toward_profile},
            {"max_turn", options.plan.max_turn},
            {"pitch_jitter", options.plan.pitch_jitter},
            {"relight", options.plan.relight},
            {"jaw", options.jaw},
            {"image_format", options.output.image_format},
            {"jpeg_quality", options.output.jpeg_quality},
            {"png_compression", options.output.png_compression},
            {"wds_shard_size", options.output.wds_shard_size},
            {"wds_prefix", options.output.wds_prefix},
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
    validate(options);
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
            for (const char* folder : kFolders) fs::remove_all(out / folder);
        }
    }
    for (const char* folder : kFolders) {
        std::error_code error;
        fs::create_directories(out / folder, error);
        if (error) throw core::file_error((out / folder).string(), "cannot create the folder: " + error.message());
    }
    core::write_file_atomically(settings_path, settings.dump(2) + "\n");

    const std::size_t unit = photos_per_tar(options);
    const auto in_shard = [&](std::size_t p) { return static_cast<int>((p / unit) % static_cast<std::size_t>(options.shard.count)) == options.shard.index; };
    std::vector<std::size_t> todo;
    for (std::size_t p = 0; p < photos.size(); ++p) {
        if (!in_shard(p)) continue;
        ++result.photos_in_shard;
        if (fs::exists(out / kPhotoFolder / (photo_key(p) + ".json")))
            ++result.photos_done_before;
        else
            todo.push_back(p);
    }
    if (options.on_start) options.on_start(todo.size());

    const int views = options.plan.views();
    const std::string extension = options.output.image_format == "jpg" ? ".jpg" : ".png";
    std::mutex mutex;  // result, on_photo and the landmark finder
    std::atomic<std::size_t> next{0};
    std::exception_ptr fatal;
    const auto work = [&](int worker) {
        try {
            render::RendererOptions renderer_options = options.renderer;
            renderer_options.software_display = worker;
            Profiler profiler(model, renderer_options);
            synth::PngEncoder png(options.output.png_compression);
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
                    const std::string record_file = std::string(kPhotoFolder) + "/" + photo_key(p) + ".json";
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
                        const ViewLight light = plan_light(options.plan, options.seed, index);
                        const ProfiledView view = profiler.render_view(scene, *pose, options.profile, light);
                        render_s += seconds_since(t0);
                        t0 = std::chrono::steady_clock::now();
                        const bool contour = options.jaw == "contour";
                        const Eigen::Matrix2Xd& labels = contour ? view.landmarks_contour : view.landmarks_fixed;
                        const auto& visible = contour ? view.visible_contour : view.visible_fixed;
                        const auto box = synth::landmark_box(labels, view.image.cols, view.image.rows);
                        nlohmann::json meta = {{"key", key},
                                               {"index", index},
                                               {"yaw", pose->yaw},
                                               {"pitch", pose->pitch},
                                               {"roll", pose->roll},
                                               {"jaw", options.jaw},
                                               {"landmarks", points_json(labels)},
                                               {"light", {{"strength", light.strength}, {"azimuth", light.azimuth}, {"elevation", light.elevation}}},
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
                                               {"image_width", view.image.cols},
                                               {"image_height", view.image.rows},
                                               {"bbox", box},
                                               {"photo", photo.string()},
                                               {"photo_index", p},
                                               {"photo_record", record_file},
                                               {"view", v}};
                        core::write_file_atomically(out / "images" / (key + extension), synth::encode_image(view.image, options.output.image_format, options.output.jpeg_quality, png, key));
                        core::write_file_atomically(out / "landmarks" / (key + ".pts"), morph::format_pts(labels));
                        core::write_file_atomically(out / "meta" / (key + ".json"), meta.dump() + "\n");
                        write_s += seconds_since(t0);
                        ++written;
                    }
                    nlohmann::json done = record;
                    done["index"] = p;
                    done["views_written"] = written;
                    done["views_skipped"] = skipped;
                    core::write_file_atomically(out / record_file, done.dump(2) + "\n");
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

    const synth::OutputFormats formats = synth::parse_formats(options.output.formats);
    const std::set<std::size_t> processed(todo.begin(), todo.end());
    const auto finished_views = [&](std::size_t first, std::size_t end) {
        std::vector<std::int64_t> indices;
        for (std::size_t p = first; p < end; ++p)
            if (fs::exists(out / kPhotoFolder / (photo_key(p) + ".json")))
                for (const std::int64_t index : views_on_disk(out, p, views)) indices.push_back(index);
        return indices;
    };
    if (formats.wds) {
        for (std::size_t first = 0; first < photos.size(); first += unit) {
            if (!in_shard(first)) continue;
            const std::size_t end = std::min(photos.size(), first + unit);
            const fs::path tar = out / synth::wds_tar_name(options.output.wds_prefix, static_cast<std::int64_t>(first / unit));
            bool stale = !fs::exists(tar);
            for (std::size_t p = first; p < end && !stale; ++p) stale = processed.count(p) > 0;
            if (!stale) continue;
            std::vector<synth::TarMember> members;
            for (const std::int64_t index : finished_views(first, end)) {
                const std::string key = sample_key(index);
                members.push_back({key + extension, out / "images" / (key + extension)});
                members.push_back({key + ".pts", out / "landmarks" / (key + ".pts")});
                members.push_back({key + ".json", out / "meta" / (key + ".json")});
            }
            synth::write_tar_file(tar, members);
            ++result.tars_written;
        }
    }
    if (formats.coco) {
        std::vector<std::int64_t> indices;
        for (std::size_t p = 0; p < photos.size(); ++p)
            if (in_shard(p))
                for (const std::int64_t index : finished_views(p, p + 1)) indices.push_back(index);
        core::write_file_atomically(out / synth::coco_name(options.shard),
                                    synth::coco_from_meta(out, indices, extension, "facesynth profiled photographs").dump() + "\n");
    }
    result.seconds = seconds_since(start);
    return result;
}

}  // namespace facesynth::profile
