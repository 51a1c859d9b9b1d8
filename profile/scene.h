#pragma once
// Face profiling (Zhu et al., CVPR 2016; docs/profile.md): an annotated photograph turned in 3D to a new
// head pose. The face is the fitted model textured from the photograph (isomap, mirror fill of the
// hidden side, push-pull fill of the rest); everything else in the picture (hair, ears, neck, clothes,
// background) is a grid mesh textured with the photograph itself, whose depth is the fitted head's
// inside its outline and, outside, the head's outline depth extended smoothly and falling back to a far
// plane. Near the head the grid turns with it; far from it the background stays where it was.
//
// Every image is the photograph seen by the fit's scaled orthographic camera, so at the source pose the
// view reproduces the photograph, and a view's landmarks are the fitted model's (exact, both jaw modes,
// with visibility) plus the annotator's residual at the source pose carried along in the face's frame.
#include "fit/fit.h"
#include "frontal/frontalise.h"
#include "morph/model.h"
#include "render/landmarks.h"
#include "render/renderer.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace facesynth::profile {

struct ProfileOptions {
    int size = 256;            // views are size x size
    // The view shows a square of this many times the annotated landmarks' box (its longer side),
    // centred on the box at the source pose.
    double crop_margin = 2.0;
    fit::FitOptions fit;       // jaw on the silhouette (photographs are annotated so)
    int isomap_size = 256;     // face texture, texels per side
    int grid_step_px = 4;      // spacing of the grid mesh of the picture, output pixels
    // Outside the head, the grid's depth and its share of the head's motion fade from the head's
    // outline to the far plane (and no motion) over this distance, mm at the face's scale.
    double falloff_mm = 100;
    double far_plane_mm = 250;  // behind the head's centre
    // The grid lies this far behind the fitted surface inside the head's outline, so that the face mesh
    // (with the hidden side filled) is drawn wherever both are.
    double grid_behind_mm = 3;
    // The grid's depth and motion are smoothed with a Gaussian of this standard deviation (output px).
    double smoothing_px = 6;
    // Add the annotation's residual to the fit (at the source pose) to every view's landmarks.
    bool apply_residual = true;
    ProfileOptions() { fit.jaw = fit::JawMode::kContour; }
};

// One photograph prepared for profiling: fit, textures and the picture's grid mesh. Coordinates are
// "working" pixels: the photograph cropped to the region of interest and scaled so that the view's
// square is `size` pixels; a view pixel is a working pixel minus `view_origin`.
struct PhotoScene {
    cv::Size working_size;
    // working = (photo + 0.5) · scale - 0.5 - roi_origin · scale, per axis; view = working - view_origin.
    Eigen::Vector2d scale = Eigen::Vector2d::Ones();
    Eigen::Vector2d roi_origin = Eigen::Vector2d::Zero();  // photo pixels
    Eigen::Vector2d view_origin = Eigen::Vector2d::Zero();  // working pixels

    fit::FitResult fit;                 // in working pixels
    fit::ScaledOrthographic camera;     // the fit's scaled orthographic camera (working pixels)
    Eigen::Matrix3Xf vertices;          // fitted shape (identity and expression), model space
    morph::Mesh face;                   // the fitted mesh with the model's triangles and uv, as every view draws it
    double fit_error_iod = 0;           // landmark RMS of the fit over the inter-ocular distance

    cv::Mat face_texture;               // the renderer's RGB texture for the model's uv
    std::vector<char> triangle_seen;    // per model triangle: its texture was seen, not filled
    cv::Mat photo_texture;              // the renderer's RGB texture of the working photograph

    // The grid: vertices in working pixels (x, y) with depth (mm, camera space, + 1000), and how much
    // of the head's rotation each follows (1 near the head, 0 far from it).
    Eigen::Matrix3Xd grid;
    std::vector<float> grid_motion;
    std::vector<morph::Triangle> grid_triangles;
    Eigen::Matrix2Xf grid_uv;
    std::vector<double> grid_source_area;  // px² per grid triangle at the source pose

    Eigen::Matrix2Xd annotated;         // 2 x 68, working pixels
    Eigen::Matrix2Xd residual_px;       // annotated minus the fitted model's contour-mode landmarks at the source pose
    Eigen::Matrix3Xd residual_mm;       // the same lifted into model space (in the source view's image plane)
};

struct ViewPose {
    double yaw = 0, pitch = 0, roll = 0;  // degrees, the face's pose in the view (morph/pose.h)
};

// A directional light added to a view, changing the photograph's shading: each surface's colour (in
// linear light) is multiplied by ((1 − k) + k · max(0, n · l)) / ((1 − k) + k · max(0, c · l)), where
// n is its normal, c the normal of a surface facing the camera and l the direction toward the light.
// Surfaces facing the camera (the flat background, the middle of the face) keep their brightness; those
// turned toward the light brighten, those turned away darken. Strength 0 leaves the view as it was.
struct ViewLight {
    double strength = 0;   // k in [0, 0.9]
    double azimuth = 0;    // degrees, positive toward the view's right (+x)
    double elevation = 0;  // degrees, positive above the view's centre
    [[nodiscard]] bool changes() const { return strength > 0; }
};

struct ProfiledView {
    cv::Mat image;                        // CV_8UC3, R G B
    cv::Mat face_mask;                    // CV_8UC1: the fitted face's coverage where it is shown, else 0
    ViewPose pose;
    Eigen::Matrix2Xd landmarks_fixed;     // 2 x 68, view pixels (0-based), residual applied
    Eigen::Matrix2Xd landmarks_contour;
    std::vector<std::uint8_t> visible_fixed, visible_contour;
    Eigen::Matrix2Xd residual_px;         // 2 x 68: what the annotation's residual added to each landmark in this view
    double filled_share = 0;     // of the face's pixels: texture filled (mirror or neighbours), not seen
    double stretched_share = 0;  // of the view's pixels: picture grid stretched over twice its area in the photograph
    double face_share = 0;       // of the view's pixels: the fitted face
};

// Holds what depends on the model only and one renderer: use from one thread at a time; the model must
// outlive it.
class Profiler {
public:
    explicit Profiler(const morph::MorphableModel& model, const render::RendererOptions& renderer_options = {});

    // Fits `landmarks` (68 iBUG points, 0-based photo pixels) and builds the scene. Throws core::Error
    // on a bad image or landmarks, or a failed fit.
    [[nodiscard]] PhotoScene prepare(const cv::Mat& photo, const Eigen::Matrix2Xd& landmarks, const ProfileOptions& options = {});

    // The photograph at the source pose: the fit's angles.
    [[nodiscard]] static ViewPose source_pose(const PhotoScene& scene);
    [[nodiscard]] ProfiledView render_view(const PhotoScene& scene, const ViewPose& pose, const ProfileOptions& options = {},
                                           const ViewLight& light = {});

    // The view's camera (orthographic, view pixels) for the fitted face at `pose`.
    [[nodiscard]] static render::Camera view_camera(const PhotoScene& scene, const ViewPose& pose, int size);
    [[nodiscard]] const morph::MorphableModel& model() const { return frontaliser_.model(); }
    [[nodiscard]] render::Renderer& renderer() { return frontaliser_.renderer(); }

private:
    frontal::Frontaliser frontaliser_;
    morph::JawContourRegion contour_region_;
    render::LandmarkTopology topology_;
    std::vector<char> face_triangle_;  // per model triangle: drawn from the face mesh (face regions), not the grid
    render::Frame face_frame_, grid_frame_;
};

}  // namespace facesynth::profile
