#include "frontal/photo_texture.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/mesh.h"
#include "morph/regions.h"

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace facesynth::frontal {
namespace {

// The renderer shows linear albedo a under unit light as a^(1/2.2); photographs are read the same way.
constexpr double kGamma = 2.2;

// The nine real spherical harmonics of bands 0-2 at unit normal n, without their constants (a least-squares
// fit absorbs them).
Eigen::Matrix<double, 9, 1> sh_basis(const Eigen::Vector3d& n) {
    Eigen::Matrix<double, 9, 1> y;
    y << 1, n.x(), n.y(), n.z(), n.x() * n.y(), n.x() * n.z(), n.y() * n.z(), n.x() * n.x() - n.y() * n.y(), 3 * n.z() * n.z() - 1;
    return y;
}

bool is_face_region(std::uint8_t label) {
    const auto r = static_cast<morph::Region>(label);
    return r == morph::Region::kSkin || r == morph::Region::kBrows || r == morph::Region::kEyes || r == morph::Region::kLips || r == morph::Region::kNose;
}

// Skin in the sense of shading estimation: albedo close to uniform (no brows, eyes, lips or hair).
bool is_plain_skin(std::uint8_t label) {
    const auto r = static_cast<morph::Region>(label);
    return r == morph::Region::kSkin || r == morph::Region::kNose;
}

// CIELAB of linear RGB colours (one row of CV_32FC3 in, one out).
cv::Mat lab_of_linear(const std::vector<cv::Vec3f>& rgb_linear) {
    cv::Mat row(1, static_cast<int>(rgb_linear.size()), CV_32FC3);
    auto* p = row.ptr<cv::Vec3f>();
    for (std::size_t i = 0; i < rgb_linear.size(); ++i)
        for (int c = 0; c < 3; ++c) p[i][c] = static_cast<float>(core::srgb_encode(rgb_linear[i][c]));
    cv::cvtColor(row, row, cv::COLOR_RGB2Lab);
    return row;
}

double percentile(std::vector<double> values, double q) {
    if (values.empty()) return 0;
    const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
    return values[k];
}

// Where a face texel's colour in the photograph can be trusted: the 68 landmarks' convex hull, with the
// brows raised by 0.6 of the nose-tip-to-brow distance to take in the forehead. Beyond the jaw line the
// fitted head meets hair, ears, neck or background, whatever the fit.
std::vector<cv::Point2f> trusted_face_polygon(const Eigen::Matrix2Xd& landmarks) {
    std::vector<cv::Point2f> points;
    for (Eigen::Index i = 0; i < landmarks.cols(); ++i) points.emplace_back(static_cast<float>(landmarks(0, i)), static_cast<float>(landmarks(1, i)));
    const Eigen::Vector2d brow_mid = landmarks.middleCols(17, 10).rowwise().mean();
    const Eigen::Vector2d up = 0.6 * (brow_mid - landmarks.col(morph::kNoseTipLandmark));
    for (Eigen::Index i = 17; i < 27; ++i)
        points.emplace_back(static_cast<float>(landmarks(0, i) + up.x()), static_cast<float>(landmarks(1, i) + up.y()));
    std::vector<cv::Point2f> hull;
    cv::convexHull(points, hull);
    return hull;
}

// Distance from p to the annotated jaw line (the polyline through iBUG 1-17), pixels.
double distance_to_jaw_line(const Eigen::Matrix2Xd& landmarks, const Eigen::Vector2d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i + 1 < morph::kNumJawLandmarks; ++i) {
        const Eigen::Vector2d a = landmarks.col(i), ab = landmarks.col(i + 1) - a;
        const double length2 = ab.squaredNorm();
        const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
        best = std::min(best, (p - (a + t * ab)).norm());
    }
    return best;
}

PhotoTexture rejected(PhotoTexture t, std::string why) {
    t.rejection = std::move(why);
    t.texture.release();
    return t;
}

}  // namespace

cv::Mat align_photo_to_fit(const cv::Mat& image, const Eigen::Matrix2Xd& annotated, const Eigen::Matrix2Xd& projected, bool with_jaw) {
    if (annotated.cols() != morph::kNumIbugLandmarks || projected.cols() != morph::kNumIbugLandmarks)
        throw core::Error("texture: feature alignment needs 68 annotated and 68 projected points");
    std::vector<int> used;
    for (int k = with_jaw ? 0 : 17; k < morph::kNumIbugLandmarks; ++k)
        if (annotated.col(k).allFinite() && projected.col(k).allFinite()) used.push_back(k);
    const double eye_distance = (annotated.col(morph::kLeftEyeOuterCorner) - annotated.col(morph::kRightEyeOuterCorner)).norm();
    if (used.size() < 3 || !(eye_distance > 0)) return image;
    const int n = static_cast<int>(used.size());
    const double sigma = 0.25 * eye_distance;
    const auto kernel = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return std::exp(-(a - b).squaredNorm() / (2 * sigma * sigma)); };
    Eigen::MatrixXd k(n, n);
    Eigen::MatrixX2d residual(n, 2);
    for (int i = 0; i < n; ++i) {
        const int a = used[static_cast<std::size_t>(i)];
        residual.row(i) = (annotated.col(a) - projected.col(a)).transpose();
        for (int j = 0; j < n; ++j) k(i, j) = kernel(projected.col(a), projected.col(used[static_cast<std::size_t>(j)]));
    }
    // A little regularisation: neighbouring points (inner and outer lips) with differing residuals
    // would otherwise ask for steep, ringing displacements.
    k.diagonal().array() += 0.05;
    const Eigen::MatrixX2d weights = k.ldlt().solve(residual);
    // The displacement on a grid of 4-pixel cells (it varies over tens of pixels), then bilinear.
    constexpr int kCell = 4;
    const int grid_w = image.cols / kCell + 2, grid_h = image.rows / kCell + 2;
    cv::Mat dx(grid_h, grid_w, CV_32FC1), dy(grid_h, grid_w, CV_32FC1);
    for (int gy = 0; gy < grid_h; ++gy)
        for (int gx = 0; gx < grid_w; ++gx) {
            const Eigen::Vector2d p(gx * kCell, gy * kCell);
            Eigen::Vector2d d = Eigen::Vector2d::Zero();
            for (int i = 0; i < n; ++i) d += weights.row(i).transpose() * kernel(p, projected.col(used[static_cast<std::size_t>(i)]));
            dx.at<float>(gy, gx) = static_cast<float>(d.x());
            dy.at<float>(gy, gx) = static_cast<float>(d.y());
        }
    cv::Mat map_x(image.size(), CV_32FC1), map_y(image.size(), CV_32FC1);
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            const float fx = static_cast<float>(x) / kCell, fy = static_cast<float>(y) / kCell;
            const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
            const float tx = fx - static_cast<float>(x0), ty = fy - static_cast<float>(y0);
            const auto lerp = [&](const cv::Mat& m) {
                return (1 - ty) * ((1 - tx) * m.at<float>(y0, x0) + tx * m.at<float>(y0, x0 + 1)) +
                       ty * ((1 - tx) * m.at<float>(y0 + 1, x0) + tx * m.at<float>(y0 + 1, x0 + 1));
            };
            map_x.at<float>(y, x) = static_cast<float>(x) + lerp(dx);
            map_y.at<float>(y, x) = static_cast<float>(y) + lerp(dy);
        }
    cv::Mat out;
    cv::remap(image, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    return out;
}

void push_pull_fill(cv::Mat& colour, const cv::Mat& weight) {
    if (colour.type() != CV_32FC3 || weight.type() != CV_32FC1 || colour.size() != weight.size())
        throw core::Error("push-pull fill: expects a CV_32FC3 colour and a CV_32FC1 weight of the same size");
    if (cv::countNonZero(weight > 0) == 0) throw core::Error("push-pull fill: no texel has a colour to fill from");
    if (colour.rows <= 1 && colour.cols <= 1) return;
    // Pull: the weighted mean of each 2x2 block; a block with any colour counts as known (weight 1) one
    // level down when its weights add up to one texel's worth.
    cv::Mat premultiplied;
    cv::Mat weight3;
    cv::merge(std::vector<cv::Mat>{weight, weight, weight}, weight3);
    cv::multiply(colour, weight3, premultiplied);
    const cv::Size half((colour.cols + 1) / 2, (colour.rows + 1) / 2);
    cv::Mat coarse_colour, coarse_weight;
    cv::resize(premultiplied, coarse_colour, half, 0, 0, cv::INTER_AREA);
    cv::resize(weight, coarse_weight, half, 0, 0, cv::INTER_AREA);
    for (int r = 0; r < half.height; ++r) {
        auto* c = coarse_colour.ptr<cv::Vec3f>(r);
        auto* w = coarse_weight.ptr<float>(r);
        for (int x = 0; x < half.width; ++x) {
            if (w[x] > 0) c[x] /= w[x];
            w[x] = std::min(1.0f, 4.0f * w[x]);
        }
    }
    push_pull_fill(coarse_colour, coarse_weight);
    // Push: the coarse level, brought back up, fills what the fine level lacks.
    cv::Mat up;
    cv::resize(coarse_colour, up, colour.size(), 0, 0, cv::INTER_LINEAR);
    for (int r = 0; r < colour.rows; ++r) {
        auto* c = colour.ptr<cv::Vec3f>(r);
        const auto* u = up.ptr<cv::Vec3f>(r);
        const auto* w = weight.ptr<float>(r);
        for (int x = 0; x < colour.cols; ++x) {
            const float keep = std::clamp(w[x], 0.0f, 1.0f);
            c[x] = keep * c[x] + (1.0f - keep) * u[x];
        }
    }
}

PhotoTexture extract_photo_texture(Frontaliser& frontaliser, const cv::Mat& image, const Eigen::Matrix2Xd& landmarks,
                                   const PhotoTextureOptions& options) {
    const morph::MorphableModel& model = frontaliser.model();
    if (model.symmetry.size() != static_cast<std::size_t>(model.num_vertices()))
        throw core::Error("texture: model '" + model.name + "' has no symmetry map to fill the hidden side with");
    if (landmarks.cols() != morph::kNumIbugLandmarks) throw core::Error("texture: expected 68 landmarks, got " + std::to_string(landmarks.cols()));
    PhotoTexture out;

    fit::FitOptions fit_options;
    fit_options.jaw = fit::JawMode::kContour;
    fit_options.lambda = options.fit_lambda;
    fit::FitResult fit;
    try {
        fit = frontaliser.fitter().fit(landmarks, fit_options);
    } catch (const core::Error& e) {
        return rejected(out, std::string("fit: ") + e.what());
    }
    out.shape = fit.alpha;
    out.expression = fit.psi;
    out.expression.resize(static_cast<std::size_t>(model.num_expression_components()), 0.0f);  // an unfitted expression is neutral
    out.yaw_deg = fit.pose.angles.yaw;
    out.pitch_deg = fit.pose.angles.pitch;
    out.roll_deg = fit.pose.angles.roll;
    const double iod = morph::inter_ocular_distance(landmarks);
    out.fit_error = iod > 0 ? fit.reprojection_rms_px / iod : 1e9;
    char text[160];
    if (std::abs(out.yaw_deg) > options.max_abs_yaw_deg) {
        std::snprintf(text, sizeof text, "pose: yaw %.0f° beyond ±%.0f°", out.yaw_deg, options.max_abs_yaw_deg);
        return rejected(out, text);
    }
    if (!(out.fit_error <= options.max_fit_error)) {
        std::snprintf(text, sizeof text, "fit: landmark RMS %.3f of the inter-ocular distance, above %.3f", out.fit_error, options.max_fit_error);
        return rejected(out, text);
    }

    const Eigen::Matrix3Xf vertices = fit::fitted_shape(model, fit);
    IsomapOptions isomap_options;
    isomap_options.size = options.size;
    const cv::Mat photo = options.align_features || options.align_jaw ? align_photo_to_fit(image, landmarks, fit.projected, options.align_jaw) : image;
    cv::Mat isomap = frontaliser.extract_isomap(photo, vertices, {fit.camera, fit.pose}, isomap_options);
    const UvRaster& raster = frontaliser.uv_raster(options.size);
    const Eigen::Matrix3Xf normals = morph::vertex_normals(vertices, model.triangles);
    const bool labelled = model.vertex_labels.size() == static_cast<std::size_t>(model.num_vertices());

    // Per covered texel: its region (the label of its heaviest corner) and its normal (model space: the
    // shading fit below is free in all nine coefficients, so its frame does not matter).
    const std::size_t texel_count = raster.texels.size();
    std::vector<std::uint8_t> region(texel_count, static_cast<std::uint8_t>(morph::Region::kSkin));
    std::vector<Eigen::Vector3d> texel_normal(texel_count);
    for (const UvRaster::TriangleTexels& tri : raster.triangles) {
        for (int k = tri.first; k < tri.first + tri.count; ++k) {
            const UvRaster::Texel& t = raster.texels[static_cast<std::size_t>(k)];
            Eigen::Vector3f n = Eigen::Vector3f::Zero();
            std::size_t heaviest = 0;
            for (std::size_t c = 0; c < 3; ++c) {
                n += t.weights[c] * normals.col(tri.vertices[c]);
                if (t.weights[c] > t.weights[heaviest]) heaviest = c;
            }
            texel_normal[static_cast<std::size_t>(k)] = n.cast<double>().normalized();
            if (labelled) region[static_cast<std::size_t>(k)] = model.vertex_labels[static_cast<std::size_t>(tri.vertices[heaviest])];
        }
    }

    // A texel's point on the fitted mesh (model space).
    const auto texel_position = [&](const UvRaster::TriangleTexels& tri, const UvRaster::Texel& t) {
        Eigen::Vector3d position = Eigen::Vector3d::Zero();
        for (std::size_t c = 0; c < 3; ++c) position += t.weights[c] * vertices.col(tri.vertices[c]).cast<double>();
        return position;
    };
    // Face texels seen outside the face's polygon show something else in the photograph: not seen.
    // Those within jaw_margin of the jaw line show its edge: dropped before the fill, below.
    const std::vector<cv::Point2f> face_polygon = trusted_face_polygon(landmarks);
    const double jaw_margin_px = options.jaw_margin * iod;
    std::vector<int> jaw_band;
    auto* isomap_px = isomap.ptr<cv::Vec4b>();
    for (const UvRaster::TriangleTexels& tri : raster.triangles)
        for (int k = tri.first; k < tri.first + tri.count; ++k) {
            const UvRaster::Texel& t = raster.texels[static_cast<std::size_t>(k)];
            if (isomap_px[t.index][3] == 0 || (labelled && !is_face_region(region[static_cast<std::size_t>(k)]))) continue;
            const Eigen::Vector2d p = fit.camera.project(texel_position(tri, t));
            if (cv::pointPolygonTest(face_polygon, cv::Point2f(static_cast<float>(p.x()), static_cast<float>(p.y())), false) < 0)
                isomap_px[t.index][3] = 0;
            else if (jaw_margin_px > 0 && distance_to_jaw_line(landmarks, p) < jaw_margin_px)
                jaw_band.push_back(t.index);
        }

    // Linear colours of the seen texels, and the shading fit over the seen plain skin.
    const auto* pixels = isomap.ptr<cv::Vec4b>();
    std::vector<double> to_linear(256);
    for (int v = 0; v < 256; ++v) to_linear[static_cast<std::size_t>(v)] = std::pow(v / 255.0, kGamma);
    std::vector<std::size_t> skin;
    int face_texels = 0, face_seen = 0;
    for (std::size_t k = 0; k < texel_count; ++k) {
        const bool seen = pixels[raster.texels[k].index][3] > 0;
        if (!labelled || is_face_region(region[k])) {
            ++face_texels;
            face_seen += seen ? 1 : 0;
        }
        if (seen && pixels[raster.texels[k].index][3] >= 64 && (!labelled || is_plain_skin(region[k]))) skin.push_back(k);
    }
    out.seen_share = face_texels > 0 ? static_cast<double>(face_seen) / face_texels : 0;
    if (skin.size() < 200) return rejected(out, "coverage: fewer than 200 skin texels seen");

    Eigen::Matrix<double, 9, 3> sh = Eigen::Matrix<double, 9, 3>::Zero();
    sh(0, 0) = sh(0, 1) = sh(0, 2) = 1;
    if (options.remove_shading) {
        Eigen::MatrixXd a(static_cast<Eigen::Index>(skin.size()), 9);
        Eigen::MatrixXd b(static_cast<Eigen::Index>(skin.size()), 3);
        for (std::size_t i = 0; i < skin.size(); ++i) {
            const auto& p = pixels[raster.texels[skin[i]].index];
            a.row(static_cast<Eigen::Index>(i)) = sh_basis(texel_normal[skin[i]]).transpose();
            for (int c = 0; c < 3; ++c) b(static_cast<Eigen::Index>(i), c) = to_linear[p[2 - c]];
        }
        // A light ridge penalty on bands 1-2 keeps the fit sane when the seen skin spans few normals.
        Eigen::Matrix<double, 9, 9> normal_matrix = a.transpose() * a;
        const double ridge = 1e-3 * normal_matrix(0, 0);
        for (int j = 1; j < 9; ++j) normal_matrix(j, j) += ridge;
        sh = normal_matrix.ldlt().solve(a.transpose() * b);
    }
    const auto shading_of = [&](std::size_t k) -> Eigen::Vector3d { return (sh_basis(texel_normal[k]).transpose() * sh).transpose(); };
    Eigen::Vector3d mean_shading = Eigen::Vector3d::Zero();
    std::vector<double> grey_shading;
    grey_shading.reserve(skin.size());
    for (std::size_t k : skin) {
        const Eigen::Vector3d s = shading_of(k);
        mean_shading += s;
        grey_shading.push_back(s.mean());
    }
    mean_shading /= static_cast<double>(skin.size());
    if (!(mean_shading.minCoeff() > 0)) return rejected(out, "shading: the fitted light is not positive over the skin");
    out.shading_range = percentile(grey_shading, 0.9) / std::max(1e-6, percentile(grey_shading, 0.1));

    // Albedo (linear) of every seen texel: its colour over its shading relative to the mean, so that the
    // skin keeps the photograph's average colour.
    cv::Mat albedo(options.size, options.size, CV_32FC3, cv::Scalar::all(0));
    cv::Mat seen(options.size, options.size, CV_8UC4, cv::Scalar::all(0));  // the isomap layout for mirror_fill
    auto* albedo_px = albedo.ptr<cv::Vec3f>();
    auto* seen_px = seen.ptr<cv::Vec4b>();
    for (std::size_t k = 0; k < texel_count; ++k) {
        const int index = raster.texels[k].index;
        const cv::Vec4b& p = pixels[index];
        if (p[3] == 0) continue;
        const Eigen::Vector3d s = shading_of(k).cwiseMax(options.min_shading * mean_shading).cwiseQuotient(mean_shading);
        cv::Vec3f linear;
        for (int c = 0; c < 3; ++c) linear[c] = static_cast<float>(std::min(1.0, to_linear[p[2 - c]] / s[c]));
        albedo_px[index] = linear;
        // Stored in the isomap's 8-bit B G R A layout so that the model's mirror fill can move it.
        for (int c = 0; c < 3; ++c) seen_px[index][2 - c] = cv::saturate_cast<uchar>(255.0 * std::pow(linear[c], 1 / kGamma));
        seen_px[index][3] = p[3];
    }

    // Outliers among the seen skin: far from the skin's median colour.
    std::vector<cv::Vec3f> skin_linear;
    skin_linear.reserve(skin.size());
    std::array<std::vector<double>, 3> channels;
    for (std::size_t k : skin) {
        const cv::Vec3f& a = albedo_px[raster.texels[k].index];
        skin_linear.push_back(a);
        for (std::size_t c = 0; c < 3; ++c) channels[c].push_back(a[static_cast<int>(c)]);
    }
    cv::Vec3f median_linear;
    for (std::size_t c = 0; c < 3; ++c) {
        median_linear[static_cast<int>(c)] = static_cast<float>(percentile(channels[c], 0.5));
        out.skin_srgb[c] = 255.0 * core::srgb_encode(median_linear[static_cast<int>(c)]);
    }
    const cv::Vec3f median_lab = lab_of_linear({median_linear}).at<cv::Vec3f>(0);
    const cv::Mat skin_lab = lab_of_linear(skin_linear);
    int outliers = 0;
    for (int i = 0; i < skin_lab.cols; ++i) outliers += cv::norm(skin_lab.at<cv::Vec3f>(i) - median_lab) > kOutlierDeltaE ? 1 : 0;
    out.skin_outliers = static_cast<double>(outliers) / static_cast<double>(skin_lab.cols);

    // Coverage says how much of the face the photograph showed: occluders and the jaw band dropped
    // below still count.
    cv::Mat shown = seen;
    if (options.drop_occluders || !jaw_band.empty()) {
        shown = seen.clone();
        frontaliser.mirror_fill(shown);
    }
    for (const int index : jaw_band) seen_px[index][3] = 0;
    if (options.drop_occluders) {
        const Eigen::Matrix3Xf points = model.landmark_positions(vertices);
        const Eigen::Vector3d nose_base = points.col(morph::kNoseBaseLandmark).cast<double>();
        const Eigen::Vector3d up = (points.middleCols(17, 10).rowwise().mean() - points.col(morph::kChinLandmark)).cast<double>().normalized();
        std::vector<int> candidates;
        std::vector<cv::Vec3f> candidate_linear;
        for (const UvRaster::TriangleTexels& tri : raster.triangles)
            for (int k = tri.first; k < tri.first + tri.count; ++k) {
                const int index = raster.texels[static_cast<std::size_t>(k)].index;
                if (seen_px[index][3] == 0 || (labelled && !is_plain_skin(region[static_cast<std::size_t>(k)]))) continue;
                if ((texel_position(tri, raster.texels[static_cast<std::size_t>(k)]) - nose_base).dot(up) <= 0) continue;
                candidates.push_back(index);
                candidate_linear.push_back(albedo_px[index]);
            }
        if (!candidates.empty()) {
            const cv::Mat candidate_lab = lab_of_linear(candidate_linear);
            int dropped_count = 0;
            for (std::size_t i = 0; i < candidates.size(); ++i)
                if (cv::norm(candidate_lab.at<cv::Vec3f>(static_cast<int>(i)) - median_lab) > kOutlierDeltaE) {
                    seen_px[candidates[i]][3] = 0;
                    ++dropped_count;
                }
            out.dropped_share = face_texels > 0 ? static_cast<double>(dropped_count) / face_texels : 0;
        }
    }

    // The hidden side from the mirror, then coverage of the face counted after it.
    frontaliser.mirror_fill(seen);
    int face_filled = 0;
    for (std::size_t k = 0; k < texel_count; ++k)
        if ((!labelled || is_face_region(region[k])) && shown.ptr<cv::Vec4b>()[raster.texels[k].index][3] > 0) ++face_filled;
    out.face_coverage = face_texels > 0 ? static_cast<double>(face_filled) / face_texels : 0;
    if (out.face_coverage < options.min_face_coverage) {
        std::snprintf(text, sizeof text, "coverage: %.0f %% of the face seen (with its mirror), below %.0f %%", 100 * out.face_coverage,
                      100 * options.min_face_coverage);
        return rejected(out, text);
    }
    if (out.skin_outliers > options.max_skin_outliers) {
        std::snprintf(text, sizeof text, "occlusion: %.0f %% of the seen skin far from its median colour, above %.0f %%", 100 * out.skin_outliers,
                      100 * options.max_skin_outliers);
        return rejected(out, text);
    }

    // Every texel: the seen and mirrored ones, weighted by how squarely they were seen (grazing texels
    // blend into their neighbours), the rest from the pyramid.
    cv::Mat weight(options.size, options.size, CV_32FC1, cv::Scalar(0));
    auto* weight_px = weight.ptr<float>();
    for (std::size_t k = 0; k < texel_count; ++k) {
        const int index = raster.texels[k].index;
        const cv::Vec4b& p = seen_px[index];
        if (p[3] == 0) continue;
        for (int c = 0; c < 3; ++c) albedo_px[index][c] = static_cast<float>(to_linear[p[2 - c]]);
        weight_px[index] = std::min(1.0f, static_cast<float>(p[3]) / 128.0f);
    }
    const auto beyond_face = [&](std::size_t k) {
        const auto r = static_cast<morph::Region>(region[k]);
        return labelled && (r == morph::Region::kEars || r == morph::Region::kNeck);
    };
    if (options.skin_beyond_face)
        for (std::size_t k = 0; k < texel_count; ++k)
            if (beyond_face(k)) weight_px[raster.texels[k].index] = 0;
    const cv::Mat unseen = options.skin_beyond_face ? cv::Mat(weight == 0) : cv::Mat();
    push_pull_fill(albedo, weight);
    if (options.skin_beyond_face) {
        cv::Mat distance;
        cv::distanceTransform(unseen, distance, cv::DIST_L2, 3);
        const float fade = static_cast<float>(std::max(1.0, options.skin_fade * options.size));
        const auto* distance_px = distance.ptr<float>();
        for (std::size_t k = 0; k < texel_count; ++k) {
            const auto r = static_cast<morph::Region>(region[k]);
            if (labelled && r != morph::Region::kSkin && r != morph::Region::kNose && !beyond_face(k)) continue;
            const int index = raster.texels[k].index;
            const float t = beyond_face(k) ? 1.0f : std::min(1.0f, distance_px[index] / fade);
            const float a = t * t * (3 - 2 * t);
            albedo_px[index] = (1 - a) * albedo_px[index] + a * median_linear;
        }
    }
    out.texture.create(options.size, options.size, CV_8UC3);
    for (int r = 0; r < options.size; ++r) {
        const auto* a = albedo.ptr<cv::Vec3f>(r);
        auto* t = out.texture.ptr<cv::Vec3b>(r);
        for (int c = 0; c < options.size; ++c)
            for (int ch = 0; ch < 3; ++ch) t[c][ch] = cv::saturate_cast<uchar>(255.0 * core::srgb_encode(a[c][ch]));
    }
    return out;
}

}  // namespace facesynth::frontal
