#include "fit/fit_record.h"

#include <nlohmann/json.hpp>

namespace facesynth::fit {

LandmarkFitOptions landmark_fit_options(const FaceFitChoices& c) {
    LandmarkFitOptions options;
    options.fit.subset = c.subset;
    options.fit.jaw = c.jaw;
    options.fit.lambda = options.fit.expression_lambda = c.lambda;
    options.fit.iterations = c.iterations;
    options.fit.shape_components = c.shape_components;
    options.fit.fit_expression = c.fit_expression;
    options.refine = c.refine;
    options.refine_options.landmark_sigma_px = c.landmark_sigma_px;
    if (c.image_width > 0 && c.image_height > 0) {
        options.refine_options.intrinsics.width = c.image_width;
        options.refine_options.intrinsics.height = c.image_height;
        options.refine_options.intrinsics.cx = 0.5 * (c.image_width - 1);
        options.refine_options.intrinsics.cy = 0.5 * (c.image_height - 1);
    }
    options.refine_options.intrinsics.fx = options.refine_options.intrinsics.fy = c.focal_px;
    return options;
}

LandmarkFit fit_face(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks, const LandmarkFitOptions& options) {
    LandmarkFit f;
    f.linear = fitter.fit(landmarks, options.fit);
    if (options.refine) f.refined = refine(fitter, landmarks, f.linear, options.fit, options.refine_options);
    f.mesh = fitter.model().instance(f.alpha(), f.psi());
    if (f.refined) {
        f.vertices_px = morph::project(f.refined->intrinsics, f.refined->pose, f.mesh.vertices);
    } else {
        f.vertices_px.resize(2, f.mesh.num_vertices());
        for (int v = 0; v < f.mesh.num_vertices(); ++v) f.vertices_px.col(v) = f.linear.camera.project(f.mesh.vertices.col(v).cast<double>());
    }
    return f;
}

nlohmann::json matrix_json(const Eigen::MatrixXd& m) {
    nlohmann::json rows = nlohmann::json::array();
    for (Eigen::Index r = 0; r < m.rows(); ++r) {
        nlohmann::json row = nlohmann::json::array();
        for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
        rows.push_back(row);
    }
    return rows;
}

void write_json(nlohmann::json& j, const LandmarkFit& fit) {
    const FitResult& linear = fit.linear;
    j["landmarks_used"] = linear.used.size();
    j["refined"] = fit.refined.has_value();
    j["linear_reprojection_rms_px"] = linear.reprojection_rms_px;
    j["linear_scale_px_per_mm"] = linear.pose.scale;
    j["linear_translation_px"] = {linear.pose.translation.x(), linear.pose.translation.y()};
    j["affine_camera"] = matrix_json(linear.camera.matrix);
    j["iterations"] = linear.iterations;
    if (fit.refined) {
        const RefineResult& r = *fit.refined;
        j["focal_px"] = r.intrinsics.fx;
        j["cx"] = r.intrinsics.cx;
        j["cy"] = r.intrinsics.cy;
        j["translation_mm"] = {r.pose.translation.x(), r.pose.translation.y(), r.pose.translation.z()};
        j["refine_iterations"] = r.iterations;
    }
    j["yaw_deg"] = fit.angles().yaw;
    j["pitch_deg"] = fit.angles().pitch;
    j["roll_deg"] = fit.angles().roll;
    j["rotation"] = matrix_json(fit.rotation());
    j["alpha"] = fit.alpha();
    j["psi"] = fit.psi();
    j["reprojection_rms_px"] = fit.reprojection_rms_px();
}

void write_json(nlohmann::json& j, const FitResult& fit) {
    j["yaw_deg"] = fit.pose.angles.yaw;
    j["pitch_deg"] = fit.pose.angles.pitch;
    j["roll_deg"] = fit.pose.angles.roll;
    j["rotation"] = matrix_json(fit.pose.rotation);
    j["scale_px_per_mm"] = fit.pose.scale;
    j["translation_px"] = {fit.pose.translation.x(), fit.pose.translation.y()};
    j["affine_camera"] = matrix_json(fit.camera.matrix);
    j["alpha"] = fit.alpha;
    j["psi"] = fit.psi;
    j["reprojection_rms_px"] = fit.reprojection_rms_px;
}

}  // namespace facesynth::fit
