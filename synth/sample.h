#pragma once
// Turning a SampleSpec into pixels and labels: render the face, place it over the background,
// apply occluders and degradations, and compute the landmarks (both jaw modes) with visibility.
#include "morph/jaw_contour.h"
#include "morph/model.h"
#include "render/landmarks.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/head_parts.h"
#include "synth/neck.h"
#include "synth/scene.h"

#include <opencv2/core.hpp>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace facesynth::synth {

struct SampleLabels {
    Eigen::Matrix2Xd landmarks_fixed;     // 2 x 68, 0-based px
    Eigen::Matrix2Xd landmarks_contour;   // 2 x 68, 0-based px (jaw points on the silhouette)
    Eigen::Matrix3Xd landmarks_3d_fixed;  // 3 x 68, model space mm (with expression)
    Eigen::Matrix3Xd landmarks_3d_contour;
    std::vector<int> visible_fixed;       // 1 = not self-occluded and inside the image
    std::vector<int> visible_contour;
    // landmarks.mode = "even" only (empty otherwise): the contour points with the jaw evenly spaced
    // along the outline (render::space_jaw_evenly).
    Eigen::Matrix2Xd landmarks_even;
    Eigen::Matrix3Xd landmarks_3d_even;
    std::vector<int> visible_even;
    std::vector<int> occluded;            // 1 = covered by an occluder (landmarks of the chosen mode)
};

struct Sample {
    SampleSpec spec;
    SampleLabels labels;
    cv::Mat image;    // CV_8UC3, RGB, final (background, occluders, degradations)
    cv::Mat mask;     // CV_8UC1, visible face coverage (occluders removed)
    cv::Mat depth;    // CV_32FC1, camera-space mm, 0 = background
    cv::Mat normals;  // CV_32FC3, camera axes
    cv::Mat regions;  // CV_8UC1, Region id per pixel (morph/regions.h), 0 = background or occluder
    std::string texture;  // file name of the UV texture map used; empty without albedo.texture_folder
    std::string texture_mix;  // the texture whose coarse colour was mixed in; empty without
    std::string hair, clothing;  // head.body: the hair and clothing meshes worn (hair empty: none)
    double exposure_gain = 1;    // linear gain of the face-metered exposure (lighting.face_luminance_mean)
};

// Where time goes, summed over samples (seconds): wall time and CPU time of the worker thread. The
// CPU time excludes llvmpipe's rasteriser threads unless LP_NUM_THREADS=0 makes it render on the
// calling thread; the wall time of a loaded machine includes waiting for a core.
struct StageTimes {
    struct Stage {
        double wall = 0;
        double cpu = 0;
        Stage& operator+=(const Stage& other);
    };
    Stage sample;     // scene sampling + mesh instance
    Stage render;     // GL draw + readback
    Stage composite;  // background, occluders, degradations, landmarks
    Stage encode;     // PNG/JPEG/EXR encoding, .pts and JSON text
    Stage write;      // files, renames, manifest
    StageTimes& operator+=(const StageTimes& other);
};

// Splits a thread's time into StageTimes stages: each lap() adds the wall and thread CPU time since
// the previous lap (or construction) to one stage.
class StageClock {
public:
    StageClock();
    void lap(StageTimes::Stage& stage);

private:
    std::chrono::steady_clock::time_point wall_;
    double cpu_;
};

// A folder of images read once and shared read-only between threads: backgrounds for
// background.type = "images", UV texture maps for albedo.texture_folder. Files are taken in name
// order; unreadable ones are skipped with a warning on stderr naming them; none usable is an error
// naming the folder and `kind` ("background", "texture").
class ImageLibrary {
public:
    ImageLibrary() = default;
    ImageLibrary(const std::filesystem::path& folder, const std::string& kind);
    // Images already read (CV_8UC3 RGB), with their names.
    ImageLibrary(std::vector<cv::Mat> images, std::vector<std::string> names) : images_(std::move(images)), names_(std::move(names)) {}
    // With the fit each image was taken with (a texture bank's); which of them are greyscale is found here.
    ImageLibrary(std::vector<cv::Mat> images, std::vector<std::string> names, std::vector<TextureFit> fits);
    [[nodiscard]] bool empty() const { return images_.empty(); }
    [[nodiscard]] const cv::Mat& image(std::uint64_t choice) const { return images_[choice % images_.size()]; }
    [[nodiscard]] const std::string& name(std::uint64_t choice) const { return names_[choice % names_.size()]; }
    [[nodiscard]] std::size_t size() const { return images_.size(); }
    // Whether a bank's texture has no colour (from a greyscale photograph: is_greyscale); false for other libraries.
    [[nodiscard]] bool greyscale(std::uint64_t choice) const { return !greyscale_.empty() && greyscale_[choice % greyscale_.size()]; }
    [[nodiscard]] std::span<const TextureFit> fits() const { return fits_; }

private:
    std::vector<cv::Mat> images_;  // CV_8UC3 RGB
    std::vector<std::string> names_;  // file names
    std::vector<TextureFit> fits_;  // empty, or one per image
    std::vector<bool> greyscale_;  // with fits: one per image
};

// An 8-bit RGB image without colour: at most 1 % of its pixels have channels more than 2 levels apart
// (rounding and JPEG chroma noise of a grey picture stay within that).
[[nodiscard]] bool is_greyscale(const cv::Mat& rgb);

// One per worker thread: owns its Renderer (GL context), created once.
class SampleGenerator {
public:
    SampleGenerator(const SynthConfig& config, const morph::MorphableModel& model, const ImageLibrary& backgrounds,
                    const ImageLibrary& textures, const render::RendererOptions& renderer_options);
    [[nodiscard]] Sample generate(std::int64_t index, StageTimes* times = nullptr);
    [[nodiscard]] std::string renderer_description() const;

private:
    // Adds the sample's head parts to mesh_ (vertices, triangles, uv, colours) and dressed_labels_,
    // dressed_topology_; returns the texture to render with (the atlas when `texture` is given).
    const cv::Mat* dress(Sample& s, const cv::Mat* texture);

    const SynthConfig& config_;
    const morph::MorphableModel& model_;
    const ImageLibrary& backgrounds_;
    const ImageLibrary& textures_;
    morph::JawContourRegion contour_region_;  // the face region of the jaw contour definition
    render::LandmarkTopology landmark_topology_;  // the model's, for project_landmarks
    std::optional<morph::SkinColourCheck> albedo_check_;  // albedo.reject_implausible
    render::Antialiasing antialiasing_;  // render.antialiasing and its samples, resolved once
    std::optional<NeckTemplate> neck_;  // head.neck
    std::optional<HeadParts> head_parts_;  // head.body
    std::optional<HeadPlacement> head_placement_;
    std::vector<Eigen::VectorXf> skin_visibility_;  // head.ambient_occlusion > 0: skin_ambient_visibility
    DressedParts dressed_;  // the sample's head parts
    cv::Mat atlas_;  // with head.body and a texture: the texture with the parts' patches
    std::vector<std::uint8_t> dressed_labels_;  // the model's labels, then the parts'
    std::map<std::pair<int, int>, render::LandmarkTopology> dressed_topologies_;  // by (hair, outfit) worn
    const render::LandmarkTopology* dressed_topology_ = nullptr;  // the sample's, from dressed_topologies_
    std::vector<std::uint8_t> vertex_labels_;  // the model's, then the neck's
    render::Renderer renderer_;
    render::Frame frame_;
    render::Frame head_parts_frame_;  // lighting.face_light = "even": the colour under the head parts' light
    morph::Mesh mesh_;  // the model's triangles and uv, set once; vertices and colours per sample
    cv::Mat background_, background_canvas_;  // per sample, in buffers kept between samples
    cv::Mat toned_texture_;  // the sample's texture times its albedo.texture_tone_jitter gains
    cv::Mat mixed_texture_;  // with the coarse colour of a second texture (albedo.texture_mix_probability)
};

// Landmarks of the mode named in config.landmarks.mode, with their visibility.
[[nodiscard]] const Eigen::Matrix2Xd& chosen_landmarks(const SampleLabels& labels, const std::string& mode);
[[nodiscard]] const std::vector<int>& chosen_visibility(const SampleLabels& labels, const std::string& mode);
[[nodiscard]] const Eigen::Matrix3Xd& chosen_landmarks_3d(const SampleLabels& labels, const std::string& mode);

}  // namespace facesynth::synth
