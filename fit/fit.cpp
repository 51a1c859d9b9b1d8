#include "fit/fit.h"

#include "fit/landmark_basis.h"
#include "core/error.h"
#include "morph/landmarks.h"

#include <Eigen/Cholesky>

#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace facesynth::fit {

JawMode parse_jaw_mode(const std::string& text) {
    if (text == "fixed") return JawMode::kFixed;
    if (text == "contour") return JawMode::kContour;
    throw core::Error("jaw '" + text + "': expected fixed or contour");
}
// Not in the anonymous namespace: Fitter::LinearCache, a class with external linkage, holds BasisGrams,
// and GCC warns of members of internal-linkage types wherever this file is included (unity builds).
namespace gram_blocks {

// Weighted Gram blocks of a basis restricted to landmark points, G_ab = Σ_i w_i B_i[a]ᵀ B_i[b] for the
// rows a, b ∈ {x, y, z} of each point's 3 × K block B_i. For any affine camera matrix M (2 × 3),
//   Σ_i w_i B_iᵀ MᵀM B_i = Σ_ab (MᵀM)_ab G_ab,
// so the normal matrix of Eq. 2 costs six K × K additions per camera instead of a 2n-row rank update,
// and the blocks of the model's fixed landmarks are computed once per Fitter.
class BasisGram {
public:
    BasisGram() = default;
    explicit BasisGram(Eigen::Index k) {
        for (auto& block : blocks_) block.setZero(k, k);
    }
    // rows: 3n × K (point i in rows 3i..3i+2); weights: n, any sign (a negative weight removes a point).
    void add(const Eigen::MatrixXd& rows, const Eigen::VectorXd& weights) {
        const Eigen::Index n = weights.size();
        if (n == 0) return;
        std::array<Eigen::MatrixXd, 3> axis, weighted;
        for (int a = 0; a < 3; ++a) {
            axis[a] = rows(Eigen::seqN(a, n, 3), Eigen::all);
            weighted[a] = weights.asDiagonal() * axis[a];
        }
        for (int a = 0; a < 3; ++a) blocks_[a].triangularView<Eigen::Lower>() += axis[a].transpose() * weighted[a];
        constexpr std::array<std::array<int, 2>, 3> kPairs{{{0, 1}, {0, 2}, {1, 2}}};
        for (int p = 0; p < 3; ++p) {
            const auto [a, b] = kPairs[static_cast<std::size_t>(p)];
            blocks_[3 + p].triangularView<Eigen::Lower>() += axis[a].transpose() * weighted[b];
            blocks_[3 + p].triangularView<Eigen::Lower>() += axis[b].transpose() * weighted[a];
        }
    }
    BasisGram& operator+=(const BasisGram& other) {
        for (std::size_t b = 0; b < blocks_.size(); ++b) blocks_[b] += other.blocks_[b];
        return *this;
    }
    [[nodiscard]] BasisGram top_left(Eigen::Index k) const {
        BasisGram out;
        for (std::size_t b = 0; b < blocks_.size(); ++b) out.blocks_[b] = blocks_[b].topLeftCorner(k, k);
        return out;
    }
    // Lower triangle of the top-left k × k block of Σ_ab q_ab G_ab (q symmetric; the upper part is left 0).
    Eigen::MatrixXd quadratic(const Eigen::Matrix3d& q, Eigen::Index k) const {
        const std::array<double, 6> factors{q(0, 0), q(1, 1), q(2, 2), q(0, 1), q(0, 2), q(1, 2)};
        Eigen::MatrixXd h = Eigen::MatrixXd::Zero(k, k);
        for (Eigen::Index j = 0; j < k; ++j) {
            auto column = h.col(j).tail(k - j);
            for (std::size_t b = 0; b < blocks_.size(); ++b) column += factors[b] * blocks_[b].col(j).segment(j, k - j);
        }
        return h;
    }

private:
    std::array<Eigen::MatrixXd, 6> blocks_;  // xx, yy, zz, then xy + yx, xz + zx, yz + zy; lower triangles
};

}  // namespace gram_blocks

using gram_blocks::BasisGram;

namespace {

// min ½ cᵀHc − gᵀc subject to c >= 0 (H's lower triangle holds the matrix).
Eigen::VectorXd nonnegative_solve(Eigen::MatrixXd h, const Eigen::VectorXd& g, const Eigen::VectorXd& start);

// Regularised weighted linear least squares for the coefficients c of one basis:
//   min_c Σ_i w_i ‖M (f_i + B_i c) + a − x_i‖² / σ² + λ ‖c‖²   (Eq. 2 in docs/fit.md),
// optionally with c >= 0 (projected Gauss-Seidel on the normal equations, exact for this convex QP).
// `gram` holds the weighted Gram blocks of `rows` (3n × K) for these weights, except for the points
// listed in `outside_gram`, which are added directly.
// Scalar: the precision of the factorisation; float in the alternation (twice the SIMD width; the
// system is regularised), double where exactness matters (fit_identity_for_camera).
// The normal equations of that problem without the prior: H (lower triangle) and g.
IdentityEvidence normal_equations(const Eigen::Matrix<double, 2, 3>& m, const Eigen::Vector2d& a, const Eigen::Matrix3Xd& fixed_part,
                                  const Eigen::MatrixXd& rows, const BasisGram& gram, std::span<const Eigen::Index> outside_gram,
                                  const Eigen::Matrix2Xd& observed, const Eigen::VectorXd& weights, double sigma) {
    const Eigen::Index n = observed.cols(), k = rows.cols();
    const double inv_var = 1.0 / (sigma * sigma);
    // u_i = w_i Mᵀ (x_i − a − M f_i) / σ², stacked; the gradient is Bᵀu.
    Eigen::VectorXd u(3 * n);
    for (Eigen::Index i = 0; i < n; ++i)
        u.segment<3>(3 * i) = (weights(i) * inv_var) * (m.transpose() * (observed.col(i) - a - m * fixed_part.col(i)));
    IdentityEvidence e{gram.quadratic(inv_var * (m.transpose() * m), k), rows.transpose() * u};
    if (!outside_gram.empty()) {  // points whose correspondences move (contour mode): a rank update
        Eigen::MatrixXd jt(k, 2 * static_cast<Eigen::Index>(outside_gram.size()));
        for (std::size_t j = 0; j < outside_gram.size(); ++j) {
            const Eigen::Index i = outside_gram[j];
            jt.middleCols<2>(2 * static_cast<Eigen::Index>(j)) =
                (std::sqrt(weights(i) * inv_var) * (m * rows.middleRows<3>(3 * i))).transpose();
        }
        e.h.selfadjointView<Eigen::Lower>().rankUpdate(jt);
    }
    return e;
}

template <class Scalar>
Eigen::VectorXd solve_normal_equations(Eigen::MatrixXd h, const Eigen::VectorXd& g, double lambda, bool non_negative, const Eigen::VectorXd& start) {
    h.diagonal().array() += lambda;
    if (non_negative) return nonnegative_solve(std::move(h), g, start);
    using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
    const Matrix hs = h.cast<Scalar>();
    // λ > 0 makes the matrix positive definite: Cholesky, about half the work of LDLT.
    if (lambda > 0) return hs.template selfadjointView<Eigen::Lower>().llt().solve(g.cast<Scalar>()).template cast<double>();
    return hs.template selfadjointView<Eigen::Lower>().ldlt().solve(g.cast<Scalar>()).template cast<double>();
}

template <class Scalar>
Eigen::VectorXd solve_coefficients(const Eigen::Matrix<double, 2, 3>& m, const Eigen::Vector2d& a,
                                   const Eigen::Matrix3Xd& fixed_part, const Eigen::MatrixXd& rows, const BasisGram& gram,
                                   std::span<const Eigen::Index> outside_gram, const Eigen::Matrix2Xd& observed,
                                   const Eigen::VectorXd& weights, double sigma, double lambda, bool non_negative,
                                   const Eigen::VectorXd& start) {
    IdentityEvidence e = normal_equations(m, a, fixed_part, rows, gram, outside_gram, observed, weights, sigma);
    return solve_normal_equations<Scalar>(std::move(e.h), e.g, lambda, non_negative, start);
}

Eigen::VectorXd nonnegative_solve(Eigen::MatrixXd h, const Eigen::VectorXd& g, const Eigen::VectorXd& start) {
    const Eigen::Index k = h.rows();
    h.triangularView<Eigen::StrictlyUpper>() = h.transpose();
    Eigen::VectorXd c = Eigen::VectorXd::Zero(k);
    if (start.size() == k) c = start.cwiseMax(0.0);
    for (int sweep = 0; sweep < 200; ++sweep) {
        double change = 0;
        for (Eigen::Index q = 0; q < k; ++q) {
            if (!(h(q, q) > 0)) continue;
            const double updated = std::max(0.0, c(q) - (h.col(q).dot(c) - g(q)) / h(q, q));
            change = std::max(change, std::abs(updated - c(q)));
            c(q) = updated;
        }
        if (change < 1e-7) break;
    }
    return c;
}


// Checks the input and lists the iBUG points that take part (and, in contour mode, the jaw points
// whose correspondences are re-chosen).
std::vector<int> select_points(const morph::MorphableModel& model, const Eigen::Matrix2Xd& landmarks, const FitOptions& options,
                               bool contour_mode, std::vector<int>* jaw_used) {
    if (landmarks.cols() != morph::kNumIbugLandmarks)
        throw core::Error("fit: expected " + std::to_string(morph::kNumIbugLandmarks) + " iBUG landmarks, got " + std::to_string(landmarks.cols()));
    if (static_cast<int>(model.landmarks.size()) != morph::kNumIbugLandmarks)
        throw core::Error("fit: model '" + model.name + "' defines " + std::to_string(model.landmarks.size()) +
                    " landmarks, expected " + std::to_string(morph::kNumIbugLandmarks));
    if (options.weights.size() != 0 && options.weights.size() != morph::kNumIbugLandmarks)
        throw core::Error("fit: " + std::to_string(options.weights.size()) + " landmark weights, expected 68");
    if (options.iterations < 1) throw core::Error("fit: iterations must be at least 1");
    if (!(options.lambda >= 0) || !(options.expression_lambda >= 0)) throw core::Error("fit: regularisation must be >= 0");

    std::vector<int> candidates = options.subset;
    if (candidates.empty())
        for (int i = 0; i < morph::kNumIbugLandmarks; ++i) candidates.push_back(i);
    std::vector<int> used;
    for (int i : candidates) {
        if (i < 0 || i >= morph::kNumIbugLandmarks) throw core::Error("fit: landmark index " + std::to_string(i) + " out of range 0..67");
        const double w = options.weights.size() ? options.weights(i) : 1.0;
        if (!std::isfinite(w) || w < 0) throw core::Error("fit: landmark " + std::to_string(i + 1) + " has an invalid weight");
        if (w == 0) continue;
        const bool contour_point = contour_mode && i < morph::kNumJawLandmarks && i != morph::kChinLandmark;
        if (!defined(model.landmarks[static_cast<std::size_t>(i)]) && !contour_point) continue;
        if (!landmarks.col(i).allFinite())
            throw core::Error("fit: landmark " + std::to_string(i + 1) + " has non-finite coordinates");
        used.push_back(i);
        if (contour_point && jaw_used) jaw_used->push_back(i);
    }
    if (used.size() < 4) throw core::Error("fit: needs at least 4 usable landmarks, got " + std::to_string(used.size()));
    return used;
}

}  // namespace

IdentityEvidence identity_evidence(const morph::MorphableModel& model, const AffineCamera& camera, const Eigen::Matrix2Xd& landmarks,
                                   const FitOptions& options, std::span<const float> psi) {
    const std::vector<int> used = select_points(model, landmarks, options, false, nullptr);
    const auto n = static_cast<Eigen::Index>(used.size());
    const int k_all = model.num_shape_components();
    const int k = options.shape_components > 0 ? std::min(options.shape_components, k_all) : k_all;
    LandmarkBasis lin(model, k);
    lin.resize(n);
    Eigen::Matrix2Xd observed(2, n);
    Eigen::VectorXd weights(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const int id = used[static_cast<std::size_t>(i)];
        observed.col(i) = landmarks.col(id);
        weights(i) = options.weights.size() ? options.weights(id) : 1.0;
        lin.set_point(i, model.landmarks[static_cast<std::size_t>(id)]);
    }
    Eigen::Matrix3Xd fixed = lin.rows().mean;
    if (lin.e() > 0 && !psi.empty()) {
        Eigen::VectorXd p = Eigen::VectorXd::Zero(lin.e());
        for (std::size_t i = 0; i < psi.size() && i < static_cast<std::size_t>(lin.e()); ++i) p(static_cast<Eigen::Index>(i)) = psi[i];
        const Eigen::VectorXd ex = lin.rows().expression * p;
        fixed += Eigen::Map<const Eigen::Matrix3Xd>(ex.data(), 3, n);
    }
    const double sigma = options.landmark_sigma_px > 0 ? options.landmark_sigma_px : decompose(camera).scale;
    BasisGram gram(k);
    gram.add(lin.rows().identity, weights);
    IdentityEvidence e = normal_equations(camera.matrix.topLeftCorner<2, 3>(), camera.matrix.block<2, 1>(0, 3), fixed, lin.rows().identity, gram, {},
                                          observed, weights, sigma);
    e.h.triangularView<Eigen::StrictlyUpper>() = e.h.transpose();
    return e;
}

std::vector<float> solve_identity(const IdentityEvidence& evidence, double lambda, int num_components) {
    const Eigen::Index k = evidence.g.size();
    if (evidence.h.rows() != k || evidence.h.cols() != k || k > num_components)
        throw core::Error("identity evidence of " + std::to_string(k) + " components does not fit a model of " + std::to_string(num_components));
    const Eigen::VectorXd alpha = solve_normal_equations<double>(evidence.h, evidence.g, lambda, false, {});
    std::vector<float> out(static_cast<std::size_t>(num_components), 0.0f);
    for (Eigen::Index c = 0; c < k; ++c) out[static_cast<std::size_t>(c)] = static_cast<float>(alpha(c));
    return out;
}

IdentityEvidence& IdentityEvidence::operator+=(const IdentityEvidence& other) {
    if (g.size() == 0) return *this = other;
    if (other.g.size() != g.size()) throw core::Error("identity evidence of different component counts cannot be added");
    h += other.h;
    g += other.g;
    return *this;
}

std::vector<float> fit_identity_for_camera(const morph::MorphableModel& model, const AffineCamera& camera,
                                           const Eigen::Matrix2Xd& landmarks, const FitOptions& options,
                                           std::span<const float> psi) {
    return solve_identity(identity_evidence(model, camera, landmarks, options, psi), options.lambda, model.num_shape_components());
}

// The model's 68 fixed landmark correspondences with all identity components, and the unit-weight
// Gram blocks of their identity rows: the jaw points that contour mode re-chooses (all but the chin)
// apart from the rest, so a fit only adds what differs from these.
struct Fitter::LinearCache {
    explicit LinearCache(const morph::MorphableModel& model)
        : basis(model, model.num_shape_components()), core(basis.k()), jaw(basis.k()) {
        basis.resize(morph::kNumIbugLandmarks);
        std::vector<int> core_ids, jaw_ids;
        for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
            const morph::SurfacePoint& p = model.landmarks.size() == morph::kNumIbugLandmarks ? model.landmarks[static_cast<std::size_t>(i)] : morph::SurfacePoint{};
            has_point[static_cast<std::size_t>(i)] = defined(p);
            basis.set_point(i, p);
            if (!defined(p)) continue;
            (rechosen_in_contour_mode(i) ? jaw_ids : core_ids).push_back(i);
        }
        core.add(identity_rows(core_ids), Eigen::VectorXd::Ones(static_cast<Eigen::Index>(core_ids.size())));
        jaw.add(identity_rows(jaw_ids), Eigen::VectorXd::Ones(static_cast<Eigen::Index>(jaw_ids.size())));
        all = core;
        all += jaw;
    }
    static bool rechosen_in_contour_mode(int id) { return id < morph::kNumJawLandmarks && id != morph::kChinLandmark; }
    Eigen::MatrixXd identity_rows(const std::vector<int>& ids) const {
        Eigen::MatrixXd rows(3 * static_cast<Eigen::Index>(ids.size()), basis.k());
        for (std::size_t j = 0; j < ids.size(); ++j)
            rows.middleRows(3 * static_cast<Eigen::Index>(j), 3) = basis.rows().identity.middleRows(3 * ids[j], 3);
        return rows;
    }

    LandmarkBasis basis;
    std::array<bool, morph::kNumIbugLandmarks> has_point{};
    BasisGram core, jaw, all;  // all = core + jaw
};

Fitter::Fitter(const morph::MorphableModel& model)
    : model_(model), contour_(model), linear_(std::make_shared<const LinearCache>(model)) {}

FitResult Fitter::fit(const Eigen::Matrix2Xd& landmarks, const FitOptions& options) const {
    const bool contour_mode = options.jaw == JawMode::kContour && !model_.contour.right.empty() && !model_.contour.left.empty();
    const LinearCache& cache = *linear_;
    FitResult result;
    result.correspondences = model_.landmarks;
    std::vector<int> jaw_used;
    result.used = select_points(model_, landmarks, options, contour_mode, &jaw_used);
    const auto n = static_cast<Eigen::Index>(result.used.size());

    const int k_all = model_.num_shape_components();
    const int k = options.shape_components > 0 ? std::min(options.shape_components, k_all) : k_all;
    LandmarkBasis lin(model_, k);
    const int e = options.fit_expression ? lin.e() : 0;
    lin.resize(n);
    Eigen::Matrix2Xd observed(2, n);
    Eigen::VectorXd given_weights(n), weights(n);  // weights: 0 while a point has no model correspondence
    std::array<double, morph::kNumIbugLandmarks> weight_of{};
    std::vector<Eigen::Index> rechosen;  // positions (in `used`) of the jaw points contour mode re-chooses
    for (Eigen::Index i = 0; i < n; ++i) {
        const int id = result.used[static_cast<std::size_t>(i)];
        observed.col(i) = landmarks.col(id);
        given_weights(i) = options.weights.size() ? options.weights(id) : 1.0;
        weights(i) = cache.has_point[static_cast<std::size_t>(id)] ? given_weights(i) : 0.0;
        weight_of[static_cast<std::size_t>(id)] = weights(i);
        lin.copy_point(i, cache.basis, id);
        if (contour_mode && LinearCache::rechosen_in_contour_mode(id)) rechosen.push_back(i);
    }

    // Identity Gram of the points whose correspondences stay fixed: the cached unit-weight blocks plus
    // the difference this call's subset and weights make (or, when most points differ, from scratch).
    std::vector<int> changed_ids, fixed_ids;
    std::vector<double> changed_weights, fixed_weights;
    for (int id = 0; id < morph::kNumIbugLandmarks; ++id) {
        if (contour_mode && LinearCache::rechosen_in_contour_mode(id)) continue;
        const double w = weight_of[static_cast<std::size_t>(id)];
        const double cached = cache.has_point[static_cast<std::size_t>(id)] ? 1.0 : 0.0;
        if (w != cached) {
            changed_ids.push_back(id);
            changed_weights.push_back(w - cached);
        }
        if (w != 0) {
            fixed_ids.push_back(id);
            fixed_weights.push_back(w);
        }
    }
    const BasisGram& cached_gram = contour_mode ? cache.core : cache.all;
    BasisGram adjusted;
    const BasisGram* fixed_gram = &cached_gram;
    if (!changed_ids.empty() || k != k_all) {
        const bool from_scratch = changed_ids.size() >= fixed_ids.size();
        adjusted = from_scratch ? BasisGram(k_all) : cached_gram;
        const auto& ids = from_scratch ? fixed_ids : changed_ids;
        const auto& ws = from_scratch ? fixed_weights : changed_weights;
        adjusted.add(cache.identity_rows(ids), Eigen::Map<const Eigen::VectorXd>(ws.data(), static_cast<Eigen::Index>(ws.size())));
        adjusted = adjusted.top_left(k);
        fixed_gram = &adjusted;
    }
    BasisGram expression_gram;
    auto refresh_expression_gram = [&]() {
        if (e == 0) return;
        expression_gram = BasisGram(e);
        expression_gram.add(lin.rows().expression, weights);
    };
    refresh_expression_gram();

    Eigen::VectorXd alpha = Eigen::VectorXd::Zero(k), psi = Eigen::VectorXd::Zero(lin.e());
    auto to_floats = [](const Eigen::VectorXd& v, std::size_t size) {
        std::vector<float> out(size, 0.0f);
        for (Eigen::Index i = 0; i < v.size(); ++i) out[static_cast<std::size_t>(i)] = static_cast<float>(v(i));
        return out;
    };
    auto estimate_camera = [&]() {
        Eigen::Matrix3Xd x3 = lin.positions(alpha, psi);
        result.camera = estimate_affine_camera(observed, x3, weights);
        result.pose = decompose(result.camera);
        // Re-centre the translation for the orthonormalised camera (weighted mean residual).
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (morph::model_to_camera_flip() * result.pose.rotation).topRows<2>();
        result.pose.translation = ((observed - a3 * x3) * weights).rowwise().sum() / weights.sum();
        return x3;
    };
    auto rms = [&]() {
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (morph::model_to_camera_flip() * result.pose.rotation).topRows<2>();
        const Eigen::Matrix2Xd r = (a3 * lin.positions(alpha, psi)).colwise() + result.pose.translation - observed;
        return std::sqrt((r.colwise().squaredNorm().transpose().cwiseProduct(weights)).sum() / weights.sum());
    };

    double previous = std::numeric_limits<double>::max();
    for (int it = 0; it < options.iterations; ++it) {
        estimate_camera();
        if (!jaw_used.empty()) {
            const auto jaw = contour_.jaw_correspondences(landmarks, result.pose, to_floats(alpha, k_all),
                                                          to_floats(psi, static_cast<std::size_t>(lin.e())), jaw_used);
            for (Eigen::Index i : rechosen) {
                const int id = result.used[static_cast<std::size_t>(i)];
                if (!jaw[static_cast<std::size_t>(id)]) continue;
                result.correspondences[static_cast<std::size_t>(id)] = *jaw[static_cast<std::size_t>(id)];
                lin.set_point(i, result.correspondences[static_cast<std::size_t>(id)]);
                weights(i) = given_weights(i);
            }
            refresh_expression_gram();
            estimate_camera();
        }
        const Eigen::Matrix<double, 2, 3> a3 = result.pose.scale * (morph::model_to_camera_flip() * result.pose.rotation).topRows<2>();
        const double sigma = options.landmark_sigma_px > 0 ? options.landmark_sigma_px : result.pose.scale;
        const auto& rows = lin.rows();
        {
            Eigen::Matrix3Xd fixed = rows.mean;
            if (lin.e() > 0) {
                const Eigen::VectorXd ex = rows.expression * psi;
                fixed += Eigen::Map<const Eigen::Matrix3Xd>(ex.data(), 3, n);
            }
            alpha = solve_coefficients<float>(a3, result.pose.translation, fixed, rows.identity, *fixed_gram, rechosen, observed, weights,
                                              sigma, options.lambda, false, {});
        }
        if (e > 0) {
            const Eigen::VectorXd id_part = rows.identity * alpha;
            const Eigen::Matrix3Xd fixed = rows.mean + Eigen::Map<const Eigen::Matrix3Xd>(id_part.data(), 3, n);
            psi = solve_coefficients<float>(a3, result.pose.translation, fixed, rows.expression, expression_gram, {}, observed, weights,
                                            sigma, options.expression_lambda, lin.has_blendshapes(), psi);
        }
        result.iterations = it + 1;
        const double now = rms();
        if (std::abs(previous - now) < options.convergence_px) break;
        previous = now;
    }
    estimate_camera();
    result.reprojection_rms_px = rms();
    result.camera = result.pose.to_affine();
    result.alpha = to_floats(alpha, static_cast<std::size_t>(k_all));
    result.psi = to_floats(psi, static_cast<std::size_t>(lin.e()));

    // Projections of all 68 correspondences (NaN where the model has none).
    LandmarkBasis all(model_, k);
    all.resize(morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i) {
        if (contour_mode && LinearCache::rechosen_in_contour_mode(i)) all.set_point(i, result.correspondences[static_cast<std::size_t>(i)]);
        else all.copy_point(i, cache.basis, i);
    }
    const Eigen::Matrix3Xd points = all.positions(alpha, psi);
    result.projected.resize(2, morph::kNumIbugLandmarks);
    for (int i = 0; i < morph::kNumIbugLandmarks; ++i)
        result.projected.col(i) = defined(result.correspondences[static_cast<std::size_t>(i)])
                                      ? result.camera.project(points.col(i))
                                      : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    return result;
}

FitResult fit_landmarks(const morph::MorphableModel& model, const Eigen::Matrix2Xd& landmarks, const FitOptions& options) {
    return Fitter(model).fit(landmarks, options);
}

Eigen::Matrix3Xf fitted_shape(const morph::MorphableModel& model, const FitResult& result) {
    return model.shape_instance(result.alpha, result.psi);
}

std::optional<double> annotated_yaw(const Fitter& fitter, const Eigen::Matrix2Xd& landmarks) {
    FitOptions options;
    options.jaw = JawMode::kContour;
    try {
        return fitter.fit(landmarks, options).pose.angles.yaw;
    } catch (const core::Error&) {
        return std::nullopt;
    }
}

}  // namespace facesynth::fit
