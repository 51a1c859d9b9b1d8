#include "morph/builtin.h"

#include "morph/regions.h"

#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/mesh.h"
#include "morph/model_io.h"
#include "morph/pca.h"
#include "core/random.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

// The build-time copy of the model (morph/builtin_model_data.S.in), its first byte and one past its
// last. Weak: the generator that writes the copy links without it and finds them null.
extern "C" {
extern const unsigned char facesynth_builtin_model_fsm_begin[] __attribute__((weak));
extern const unsigned char facesynth_builtin_model_fsm_end[] __attribute__((weak));
}

namespace facesynth::morph {
namespace {

constexpr int kColumns = kBuiltinColumns;
constexpr int kRows = kBuiltinRows;
constexpr int kMidColumn = kColumns / 2;
constexpr int kNumVertices = kColumns * kRows;

// Rows the anatomy pins down (row index grows downward).
constexpr int kRowTrichion = 6;
constexpr int kRowAboveBrow = 17;
constexpr int kRowEye = 31;      // palpebral fissure centre line; the lid margins are kRowEye -/+ kFissureRows
constexpr int kRowBelowEye = 39;
constexpr int kRowSubnasale = 51;
constexpr int kRowStomion = 63;  // the mouth line: the inner lips are the rows just above and below it
constexpr int kRowBelowLip = 75;
constexpr int kRowGnathion = 84;
constexpr int kFissureRows = 4;
// Columns (counted from the midline) that carry the inner and outer eye corners.
constexpr int kInnerCanthusColumn = 7;
constexpr int kOuterCanthusColumn = 18;

constexpr int kShapePopulation = 128;
constexpr int kShapeComponents = 40;
constexpr int kAlbedoPopulation = 120;
constexpr int kAlbedoComponents = 30;
constexpr std::uint64_t kBuiltinSeed = 0x6661636573796e74ull;  // "facesynt"

int vertex_id(int row, int column) { return row * kColumns + column; }

double smoothstep(double edge0, double edge1, double x) {
    const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}
double gauss(double dx, double sx) { return std::exp(-0.5 * dx * dx / (sx * sx)); }
double gauss2(double dx, double dy, double sx, double sy) { return std::exp(-0.5 * (dx * dx / (sx * sx) + dy * dy / (sy * sy))); }
double lerp(double a, double b, double t) { return a + (b - a) * t; }

// A smooth monotone curve through knots (piecewise cubic Hermite, Fritsch-Carlson slopes), constant
// beyond the ends. Used for the head's profiles along the vertical axis.
class Profile {
public:
    explicit Profile(std::vector<std::pair<double, double>> knots) : knots_(std::move(knots)) {
        std::sort(knots_.begin(), knots_.end());
        const std::size_t n = knots_.size();
        slopes_.assign(n, 0.0);
        std::vector<double> secant(n - 1);
        for (std::size_t i = 0; i + 1 < n; ++i)
            secant[i] = (knots_[i + 1].second - knots_[i].second) / std::max(1e-9, knots_[i + 1].first - knots_[i].first);
        for (std::size_t i = 1; i + 1 < n; ++i)
            slopes_[i] = secant[i - 1] * secant[i] <= 0 ? 0.0 : 3.0 * secant[i - 1] * secant[i] / (secant[i - 1] + 2.0 * secant[i]) +
                                                                 0.0 * secant[i];
        if (n >= 2) {
            slopes_[0] = secant[0];
            slopes_[n - 1] = secant[n - 2];
        }
    }
    [[nodiscard]] double operator()(double y) const {
        if (y <= knots_.front().first) return knots_.front().second;
        if (y >= knots_.back().first) return knots_.back().second;
        std::size_t i = 0;
        while (knots_[i + 1].first < y) ++i;
        const double h = knots_[i + 1].first - knots_[i].first;
        const double t = (y - knots_[i].first) / h;
        const double t2 = t * t, t3 = t2 * t;
        return (2 * t3 - 3 * t2 + 1) * knots_[i].second + (t3 - 2 * t2 + t) * h * slopes_[i] +
               (-2 * t3 + 3 * t2) * knots_[i + 1].second + (t3 - t2) * h * slopes_[i + 1];
    }

private:
    std::vector<std::pair<double, double>> knots_;
    std::vector<double> slopes_;
};

// One individual's anatomy. Lengths in mm (Farkas measures as named), factors are 1 on average.
struct Anatomy {
    double head_width = 147.5;      // eu-eu
    double face_width = 133.5;      // zy-zy
    double jaw_width = 94.0;        // go-go
    double face_height = 116.5;     // n-gn
    double lower_face = 68.0;       // sn-gn
    double forehead = 58.0;         // tr-n
    double biocular = 89.5;         // ex-ex
    double intercanthal = 32.5;     // en-en
    double nose_height = 52.0;      // n-sn
    double nose_width = 33.0;       // al-al
    double nose_protrusion = 19.5;  // sn-prn
    double mouth_width = 52.0;      // ch-ch
    double upper_lip = 21.0;        // sn-sto
    double head_depth = 1.0;
    double brow_ridge = 1.0;
    double cheek = 1.0;
    double chin = 1.0;
    double lips = 1.0;
    double nose_bridge = 1.0;
    double nose_tip = 1.0;
    double eye_size = 1.0;
    double eye_depth = 1.0;
};

struct Expression {
    double jaw_open = 0, smile = 0, brow_raise = 0, eye_close = 0, pucker = 0;
};

// Anatomical heights and widths derived from an Anatomy (model space, mm; eye line at y = 0).
struct Layout {
    double y_eye = 0, y_n, y_sn, y_sto, y_gn, y_tr, y_top, y_go, y_prn;
    double x_ex, x_en, x_ec, eye_half, x_al, x_ch;
    double fissure_up, fissure_down, tilt;
    double z_nasion, z_cornea, z_prn;

    explicit Layout(const Anatomy& a) {
        // n-sn plus sn-gn is scaled to n-gn, since Farkas' three means do not add up exactly.
        const double scale = a.face_height / (a.nose_height + a.lower_face);
        const double nose_h = a.nose_height * scale;
        y_n = 0.17 * nose_h;
        y_sn = y_n - nose_h;
        y_sto = y_sn - a.upper_lip * scale;
        y_gn = y_n - a.face_height;
        y_tr = y_n + a.forehead;
        y_top = y_tr + 48.0;
        y_go = y_sto - 12.0;
        y_prn = y_sn + 0.3 * a.nose_protrusion;
        x_ex = 0.5 * a.biocular;
        x_en = 0.5 * a.intercanthal;
        x_ec = 0.5 * (x_ex + x_en);
        eye_half = 0.5 * (x_ex - x_en);
        x_al = 0.5 * a.nose_width;
        x_ch = 0.5 * a.mouth_width;
        fissure_up = 5.6 * a.eye_size;
        fissure_down = 4.4 * a.eye_size;
        tilt = 2.0;
        z_nasion = 0;  // filled by the surface builder from the midline profile
        z_cornea = 0;
        z_prn = 0;
    }
    // Centre line of the eye opening at signed position t (-1 at en, +1 at ex).
    [[nodiscard]] double eye_centre_y(double t) const { return y_eye + 0.5 * tilt * t; }
    [[nodiscard]] double upper_lid(double t, double openness) const {
        const double s = std::max(0.0, 1.0 - t * t);
        return eye_centre_y(t) + std::pow(s, 0.6) * lerp(-fissure_down + 0.4, fissure_up, openness);
    }
    [[nodiscard]] double lower_lid(double t) const {
        const double s = std::max(0.0, 1.0 - t * t);
        return eye_centre_y(t) - std::pow(s, 0.85) * fissure_down;
    }
    // Vermilion borders (upper with a Cupid's bow) and the mouth line, as functions of x. The lips
    // taper toward the corners as helen_train's annotations have them (`facesynth eval conventions`:
    // fuller sides put the outer lip points 50/54 0.04 and 56/60 0.02 inter-ocular distances off).
    [[nodiscard]] double mouth_line(double x) const { return y_sto + 1.0 * (x / x_ch) * (x / x_ch); }
    [[nodiscard]] double upper_vermilion(double x) const {
        const double r = std::min(1.0, std::abs(x) / x_ch);
        const double bow = 1.0 - 0.18 * gauss(x, 2.2);
        return mouth_line(x) + 7.0 * std::pow(1.0 - r * r, 1.4) * bow;
    }
    [[nodiscard]] double lower_vermilion(double x) const {
        const double r = std::min(1.0, std::abs(x) / x_ch);
        return mouth_line(x) - 10.0 * std::pow(1.0 - r * r, 0.95);
    }
};

// The individual's surface, built on the fixed grid.
class FaceBuilder {
public:
    FaceBuilder(const Anatomy& anatomy, const Expression& expression)
        : a_(anatomy), e_(expression), l_(anatomy),
          depth_({{l_.y_top, 20},
                  {l_.y_tr + 32, 62},
                  {l_.y_tr + 16, 78},
                  {l_.y_tr, 86},
                  {l_.y_tr - 0.45 * (l_.y_tr - l_.y_n), 93},
                  {l_.y_n + 11, 95},
                  {l_.y_n, 91},
                  {l_.y_eye - 12, 88},
                  {l_.y_sn, 88},
                  {l_.y_sto, 90},
                  {l_.y_sto - 0.42 * (l_.y_sto - l_.y_gn), 84},
                  {l_.y_gn + 11, 86.5 + 2.0 * (a_.chin - 1.0)},
                  {l_.y_gn, 79}}),
          exponent_({{l_.y_top, 2.0},
                     {l_.y_tr, 2.2},
                     {l_.y_eye + 15, 2.4},
                     {l_.y_eye - 10, 2.4},
                     {l_.y_sto, 2.2},
                     {l_.y_go, 2.1},
                     {l_.y_gn + 10, 1.9},
                     {l_.y_gn, 1.8}}) {
        const double hw = 0.5 * a_.head_width, fw = 0.5 * a_.face_width, jw = 0.5 * a_.jaw_width;
        width_ = Profile({{l_.y_top, 0.22 * hw},
                          {l_.y_tr + 32, 0.72 * hw},
                          {l_.y_tr + 16, 0.87 * hw},
                          {l_.y_tr, 0.94 * hw},
                          {l_.y_eye + 28, hw},
                          {l_.y_eye + 12, 0.985 * hw},
                          {l_.y_eye - 14, fw},
                          {l_.y_sto + 4, 0.5 * (fw + jw) + 4.0},
                          {l_.y_go, jw},
                          {l_.y_go - 10, 0.93 * jw},
                          {l_.y_gn + 14, 0.76 * jw},
                          {l_.y_gn + 8, 0.58 * jw},
                          {l_.y_gn + 4, 0.42 * jw},
                          {l_.y_gn, 0.18 * jw}});
        // Behind the face: the skull above, the neck below (where the mask stops short of it).
        back_depth_ = Profile({{l_.y_top, 22.0}, {l_.y_tr + 32, 70.0}, {l_.y_tr + 16, 88.0}, {l_.y_tr, 97.0}, {l_.y_eye, 97.0},
                               {l_.y_sn, 75.0}, {l_.y_go, 30.0}});
        max_angle_ = Profile({{l_.y_go, 105.0}, {l_.y_sn, 150.0}});
        forward_ = Profile({{l_.y_sto, 0.0}, {l_.y_go, 4.0}, {l_.y_gn + 14, 38.0}, {l_.y_gn, 48.0}});
        nose_half_width_ = Profile({{l_.y_sn - 2, 7.0}, {l_.y_sn, 8.5}, {l_.y_prn, 11.0 * a_.nose_tip}, {l_.y_prn + 12, 10.0},
                                    {l_.y_eye, 9.5}, {l_.y_n, 9.5}, {l_.y_n + 8, 11.0}});
        l_.z_nasion = depth(l_.y_n) + 1.0;
        // 17 mm, not 12: with 12 every eye point sat 0.03-0.06 inter-ocular distances in front of where
        // helen_train's annotations put it as the head turns (docs/builtin-model.md "Depth").
        l_.z_cornea = l_.z_nasion - 17.0 * a_.eye_depth;
        l_.z_prn = depth(l_.y_sn) + 0.95 * a_.nose_protrusion + 2.0;
    }

    [[nodiscard]] const Layout& layout() const { return l_; }

    // Per vertex of `points` (this builder's surface): whether the ear flap or the nose field lifts
    // it by more than `threshold` mm, i.e. whether it is part of the ear or of the nose.
    struct FeatureMasks {
        std::vector<char> ears, nose;
    };
    [[nodiscard]] FeatureMasks feature_masks(const Eigen::Matrix3Xf& points, double threshold) const {
        FeatureMasks m{std::vector<char>(kNumVertices, 0), std::vector<char>(kNumVertices, 0)};
        const auto row_y = regular_rows();
        constexpr int kEarRow = kRowBelowEye + 2;
        const auto ear_columns = column_points(section_at(kEarRow, row_y[kEarRow]));
        for (int r = 0; r < kRows; ++r) {
            const Section section = section_at(r, row_y[static_cast<std::size_t>(r)]);
            for (int c = 0; c < kColumns; ++c) {
                const int id = vertex_id(r, c);
                const Eigen::Vector3d p = points.col(id).cast<double>();
                const int side_column = c >= kMidColumn ? c : kColumns - 1 - c;
                const Eigen::Vector3d mirrored(std::abs(p.x()), p.y(), p.z());
                if (!section.under_chin &&
                    ear_offset(ear_columns[static_cast<std::size_t>(side_column - kMidColumn)].second, mirrored, section.centre).norm() > threshold)
                    m.ears[static_cast<std::size_t>(id)] = 1;
                if (p.z() > 0 && nose_height(p.x(), p.y()) > threshold) m.nose[static_cast<std::size_t>(id)] = 1;
            }
        }
        return m;
    }

    [[nodiscard]] Eigen::Matrix3Xf build() const {
        Eigen::Matrix3Xf points(3, kNumVertices);
        const auto row_y = regular_rows();
        // The ear is laid out on the columns of one reference section (at ear height), so that each
        // column crosses it at the same place on every row.
        constexpr int kEarRow = kRowBelowEye + 2;
        const auto ear_columns = column_points(section_at(kEarRow, row_y[kEarRow]));
        const auto eye_row = column_points(section_at(kRowEye, row_y[kRowEye]));
        const EyeColumns eye{eye_row[static_cast<std::size_t>(kInnerCanthusColumn)].first,
                             eye_row[static_cast<std::size_t>(kOuterCanthusColumn)].first};
        for (int r = 0; r < kRows; ++r) {
            const Section section = section_at(r, row_y[static_cast<std::size_t>(r)]);
            const auto columns = column_points(section);
            for (int c = kMidColumn; c < kColumns; ++c) {
                const auto [x0, z0] = columns[static_cast<std::size_t>(c - kMidColumn)];
                Eigen::Vector3d p = surface_point(r, c, x0, z0, row_y, section, eye);
                if (!section.under_chin) p += ear_offset(ear_columns[static_cast<std::size_t>(c - kMidColumn)].second, p, section.centre);
                points.col(vertex_id(r, c)) = p.cast<float>();
                points.col(vertex_id(r, kColumns - 1 - c)) = Eigen::Vector3f(static_cast<float>(-p.x()), static_cast<float>(p.y()),
                                                                            static_cast<float>(p.z()));
            }
        }
        return points;
    }

private:
    // x of the columns that carry the inner and outer eye corners, on this individual's eye row.
    struct EyeColumns {
        double inner, outer;
    };

    struct Section {
        double y, half_width, depth, back_depth, exponent, centre;
        bool under_chin;
        double max_angle = 0;
    };

    [[nodiscard]] double depth(double y) const { return depth_(y) * a_.head_depth; }
    [[nodiscard]] double width(double y) const { return width_(y); }

    [[nodiscard]] std::array<double, kRows> regular_rows() const {
        const std::array<std::pair<int, double>, 10> anchors = {{{0, l_.y_top},
                                                                 {kRowTrichion, l_.y_tr},
                                                                 {kRowAboveBrow, l_.y_eye + 22},
                                                                 {kRowEye, l_.y_eye},
                                                                 {kRowBelowEye, l_.y_eye - 12},
                                                                 {kRowSubnasale, l_.y_sn},
                                                                 {kRowStomion, l_.y_sto},
                                                                 {kRowBelowLip, l_.y_sto - 20},
                                                                 {kRowGnathion, l_.y_gn},
                                                                 {kRows - 1, l_.y_gn - 1.5}}};
        std::array<double, kRows> y{};
        for (std::size_t i = 0; i + 1 < anchors.size(); ++i) {
            const auto [r0, y0] = anchors[i];
            const auto [r1, y1] = anchors[i + 1];
            for (int r = r0; r <= r1; ++r) y[static_cast<std::size_t>(r)] = lerp(y0, y1, double(r - r0) / (r1 - r0));
        }
        return y;
    }

    [[nodiscard]] Section section_at(int row, double y) const {
        Section s{y, width(y), depth(y), 0.0, exponent_(y), forward_(y), row > kRowGnathion, 0.0};
        if (s.under_chin) {
            const double f = double(row - kRowGnathion) / (kRows - 1 - kRowGnathion);
            s.half_width = width(l_.y_gn) * (1.0 - 0.25 * f);
            s.depth = lerp(depth(l_.y_gn), s.centre + 10.0, f);
        }
        s.back_depth = std::max(back_depth_(y), 0.35 * s.half_width + 0.8 * s.centre);
        s.max_angle = max_angle_(y) * std::numbers::pi / 180.0;
        return s;
    }

    // Points of the right half (x >= 0) of a section, at fixed fractions of its arc length from the
    // midline to the mask's edge behind the ear: dense over the face, sparse toward the ear.
    [[nodiscard]] std::array<std::pair<double, double>, kColumns - kMidColumn> column_points(const Section& s) const {
        constexpr int kSamples = 160;
        std::array<std::pair<double, double>, kSamples + 1> curve{};
        std::array<double, kSamples + 1> arc{};
        for (int i = 0; i <= kSamples; ++i) {
            const double theta = s.max_angle * i / kSamples;
            const double e = 2.0 / s.exponent;
            const double x = s.half_width * std::pow(std::sin(theta), e);
            const double c = std::cos(theta);
            const double z = c >= 0 ? s.centre + (s.depth - s.centre) * std::pow(c, e) : s.centre - s.back_depth * std::pow(-c, e);
            curve[static_cast<std::size_t>(i)] = {x, z};
            if (i > 0) {
                const auto [px, pz] = curve[static_cast<std::size_t>(i - 1)];
                arc[static_cast<std::size_t>(i)] = arc[static_cast<std::size_t>(i - 1)] + std::sqrt((x - px) * (x - px) + (z - pz) * (z - pz));
            }
        }
        std::array<std::pair<double, double>, kColumns - kMidColumn> out{};
        std::size_t j = 0;
        for (int c = 0; c < kColumns - kMidColumn; ++c) {
            const double s01 = double(c) / (kColumns - 1 - kMidColumn);
            const double target = arc.back() * column_fraction(s01);
            while (j + 1 < arc.size() - 1 && arc[j + 1] < target) ++j;
            const double f = std::clamp((target - arc[j]) / std::max(1e-9, arc[j + 1] - arc[j]), 0.0, 1.0);
            out[static_cast<std::size_t>(c)] = {lerp(curve[j].first, curve[j + 1].first, f), lerp(curve[j].second, curve[j + 1].second, f)};
        }
        return out;
    }

public:
    // Arc-length fraction of column position s in [0, 1] (0 midline, 1 mask edge).
    static double column_fraction(double s) { return 0.42 * s + 0.58 * s * s * s; }

private:
    // Signed position along the eye: -1 at the inner corner, +1 at the outer corner.
    [[nodiscard]] double eye_t(double x) const { return (std::abs(x) - l_.x_ec) / l_.eye_half; }

    // Vertical position of a vertex: the regular row height, bent around the eye opening and the
    // mouth line so that the lid margins and the lips fall on fixed rows.
    [[nodiscard]] double warped_y(int r, double x, const std::array<double, kRows>& row_y) const {
        double y = row_y[static_cast<std::size_t>(r)];
        // Eye: rows kRowEye -/+ kFissureRows are the lid margins.
        const int k = r - kRowEye;
        if (std::abs(k) <= 2 * kFissureRows + 1) {
            const double t = eye_t(x);
            const double openness = std::clamp(1.0 - e_.eye_close, 0.0, 1.0) * (1.0 + 0.2 * e_.brow_raise);
            const double reach = smoothstep(1.0, 1.6, std::abs(t));  // 0 inside the eye, 1 well outside
            const auto margin_y = [&](int side) {  // side -1: upper margin row, +1 lower margin row
                const int row = kRowEye + side * kFissureRows;
                const double inside = side < 0 ? l_.upper_lid(std::clamp(t, -1.0, 1.0), openness)
                                               : l_.lower_lid(std::clamp(t, -1.0, 1.0)) + 0.6 * e_.smile * (1 - t * t);
                return lerp(inside, row_y[static_cast<std::size_t>(row)], reach);
            };
            const double upper = margin_y(-1), lower = margin_y(+1);
            if (std::abs(k) <= kFissureRows) {
                const double f = double(kFissureRows - k) / (2 * kFissureRows);  // 1 at the upper margin
                const double gap = std::max(upper - lower, 1.0);
                return lower + gap * f;
            }
            const int side = k < 0 ? -1 : 1;
            const int margin_row = kRowEye + side * kFissureRows;
            const double shift = (side < 0 ? upper : lower) - row_y[static_cast<std::size_t>(margin_row)];
            const double decay = 1.0 - double(std::abs(k) - kFissureRows) / (kFissureRows + 2);
            y += shift * std::max(0.0, decay);
            return y;
        }
        // Mouth: row kRowStomion is the mouth line, the rows beside it the inner lip edges.
        const int m = r - kRowStomion;
        if (std::abs(m) <= 3) {
            const double inside = smoothstep(l_.x_ch + 6.0, l_.x_ch - 1.5, std::abs(x));
            static constexpr std::array<double, 4> offset = {0.0, 0.35, 1.7, 0.0};
            const double line = l_.mouth_line(x);
            double target = line - (m > 0 ? 1 : -1) * offset[static_cast<std::size_t>(std::abs(m))];
            if (std::abs(m) == 3) target = y;
            y = lerp(y, target, inside);
        }
        return y;
    }

    // Sideways warp that puts the eye corners of every individual on the same two columns, so the
    // rows that meet at the canthi meet at the same vertices in the whole population (otherwise
    // blending faces whose corners fall on different columns folds the thin triangles there).
    [[nodiscard]] double eye_aligned_x(int r, double x, const EyeColumns& eye) const {
        const int k = r - kRowEye;
        const double weight = smoothstep(3.5 * kFissureRows, 2.5 * kFissureRows, std::abs(k));
        if (weight <= 0) return x;
        const double ax = std::abs(x), end = eye.outer + 14.0;
        double mapped = ax;
        if (ax <= eye.inner) mapped = ax * l_.x_en / eye.inner;
        else if (ax <= eye.outer) mapped = lerp(l_.x_en, l_.x_ex, (ax - eye.inner) / (eye.outer - eye.inner));
        else if (ax <= end) mapped = lerp(l_.x_ex, end, (ax - eye.outer) / (end - eye.outer));
        return (x < 0 ? -1.0 : 1.0) * lerp(ax, mapped, weight);
    }

    [[nodiscard]] Eigen::Vector3d surface_point(int r, int c, double x0, double z0, const std::array<double, kRows>& row_y,
                                                const Section& section, const EyeColumns& eye) const {
        // Eyes and mouth are on the front; the back of the head has columns at the same |x| too.
        const bool face_side = z0 > 10.0;
        const double x = face_side ? eye_aligned_x(r, x0, eye) : x0;
        const double y = face_side ? warped_y(r, x, row_y) : row_y[static_cast<std::size_t>(r)];
        double z = z0;
        // The front re-evaluates the section at the warped position.
        if (!section.under_chin && z0 > section.centre && (std::abs(y - section.y) > 1e-9 || x != x0)) {
            const double a = width(y), b = depth(y), n = exponent_(y), centre = forward_(y);
            const double q = std::min(1.0, std::abs(x) / a);
            z = centre + (b - centre) * std::pow(std::max(0.0, 1.0 - std::pow(q, n)), 1.0 / n);
        }
        const double front = smoothstep(-5.0, 25.0, z0) * (section.under_chin ? 0.0 : 1.0);
        z += front * feature_depth(r, x, y, z);
        Eigen::Vector3d p(x, y, z);
        p += expression_offset(r, c, p);
        return p;
    }

    // The ear: a flap standing out from the side of the head with a raised rim (helix) around a
    // hollow (concha), and a lobule, as a displacement away from the head's vertical axis.
    [[nodiscard]] Eigen::Vector3d ear_offset(double column_z, const Eigen::Vector3d& p, double centre) const {
        const double top = l_.y_eye + 13.0, bottom = l_.y_sn - 5.0;
        const double back = -column_z - 16.0 * a_.head_depth, up = p.y() - 0.5 * (top + bottom);
        const double tilt = 0.26;  // the ear's long axis leans back by about 15 degrees
        const double u = back * std::cos(tilt) + up * std::sin(tilt), v = up * std::cos(tilt) - back * std::sin(tilt);
        const double half_length = 0.5 * (top - bottom), half_width = 0.5 * half_length * 0.58;
        const double rho = std::hypot(u / half_width, v / half_length);
        if (rho > 1.1) return Eigen::Vector3d::Zero();
        // The grid is coarse on the side of the head (about 8 mm between columns), so the ear is a
        // smooth flap with a shallow hollow rather than a detailed helix.
        const double flap = smoothstep(1.08, 0.55, rho) * (4.0 + 6.0 * std::clamp(0.5 + 0.5 * u / half_width, 0.0, 1.0));
        const double concha = 3.0 * gauss2(u + 0.1 * half_width, v + 0.05 * half_length, 0.45 * half_width, 0.32 * half_length);
        const double height = std::max(0.0, flap - concha);
        Eigen::Vector3d outward(p.x(), 0.0, p.z() - centre);
        if (outward.norm() < 1e-9) return Eigen::Vector3d::Zero();
        return height * outward.normalized();
    }

    // Sum of the local displacement fields (mm along +z) at (x, y) of the base surface.
    [[nodiscard]] double feature_depth(int r, double x, double y, double z_base) const {
        const double ax = std::abs(x);
        double dz = 0;
        // Forehead, brow ridge, glabella, temples.
        dz += 3.5 * a_.brow_ridge * gauss2(ax - l_.x_ec - 1, y - (l_.y_eye + 15.0), 17.0, 5.5);
        dz += 2.5 * a_.brow_ridge * gauss2(x, y - (l_.y_n + 9), 9.0, 6.0);
        dz -= 3.0 * gauss2(ax - (l_.x_ex + 16), y - (l_.y_eye + 26), 10.0, 14.0);
        // Eye sockets.
        dz -= 7.0 * a_.eye_depth * gauss2(ax - l_.x_ec - 1, y - (l_.y_eye + 1), 14.0, 10.0);
        // Cheekbones.
        dz += 5.0 * a_.cheek * gauss2(ax - (l_.x_ec + 8), y - (l_.y_eye - 21), 13.0, 11.0);
        // Nose.
        dz += nose_height(x, y);
        // Lips, mouth line, philtrum, chin.
        dz += lips_depth(r, x, y);
        dz -= dental_arch_depth(x, y);
        dz += 3.5 * a_.chin * gauss2(x, y - (l_.y_gn + 13), 14.0, 9.0);
        // Eyes: eyeball shell and lids replace the surface inside the lids' reach.
        const double w = eye_weight(r, x);
        if (w > 0) {
            const double shell = eye_shell(r, x, y);
            dz = lerp(dz, shell - z_base, w);
        }
        return dz;
    }

    [[nodiscard]] double eye_weight(int r, double x) const {
        const int k = r - kRowEye;
        const double t = eye_t(x);
        const double wx = smoothstep(1.5, 0.95, std::abs(t));
        const double reach = k < 0 ? 2.6 * kFissureRows : 1.5 * kFissureRows;
        const double wr = smoothstep(reach, kFissureRows, std::abs(k));
        return wx * wr;
    }

    // Eyeball front surface plus lid thickness outside the opening.
    [[nodiscard]] double eye_shell(int r, double x, double y) const {
        const double dx = std::abs(x) - l_.x_ec, dy = y - l_.y_eye;
        // The inner canthus sits forward of the ball's sphere, on the nose's side of the socket: on the sphere
        // it was 0.05 inter-ocular distances behind the annotated one relative to the other eye points
        // (docs/builtin-model.md "Depth").
        const double ball = l_.z_cornea - dx * dx / (2.0 * 13.0) - dy * dy / (2.0 * 12.0) + 4.5 * gauss(eye_t(x) + 1.0, 0.35);
        const int k = r - kRowEye;
        double lid = 0;
        if (std::abs(k) >= kFissureRows) lid = 1.0 + 0.45 * (std::abs(k) - kFissureRows);
        if (k < 0) lid -= 1.3 * gauss(-k - 2.0 * kFissureRows, 0.8) * (1.0 - e_.eye_close);  // upper lid crease
        // A closed eye: the lid skin covers the ball.
        if (std::abs(k) < kFissureRows) lid = 1.0 * e_.eye_close;
        return ball + lid;
    }

    [[nodiscard]] double nose_height(double x, double y) const {
        const double ax = std::abs(x);
        const double y_root = l_.y_n, y_tip = l_.y_prn, y_base = l_.y_sn;
        double midline = 0;  // height of the nose's midline above the base surface
        if (y >= y_tip) {
            const double f = std::clamp((y_root - y) / (y_root - y_tip), 0.0, 1.0);
            const double dorsum = l_.z_nasion + (l_.z_prn - l_.z_nasion) * std::pow(f, 1.25) +
                                  1.2 * a_.nose_bridge * std::sin(std::numbers::pi * f);
            midline = dorsum - depth(std::min(y, y_root));
            if (y > y_root) midline *= gauss(y - y_root, 5.0);
        } else {
            const double g = std::clamp((y_tip - y) / (y_tip - y_base), 0.0, 1.0);
            const double underside = depth(y_base) + 1.0 + (l_.z_prn - depth(y_base) - 1.0) * std::sqrt(std::max(0.0, 1.0 - g * g));
            midline = underside - depth(y);
            if (y < y_base) midline = std::max(0.0, (depth(y_base) + 1.0 - depth(y)) * gauss(y - y_base, 1.5));
        }
        // Half-width of the nose body, from a narrow bridge to the lobule.
        const double w = nose_half_width_(y) * (0.85 + 0.15 * a_.nose_width / 33.0);
        const double r2 = std::min(1.0, (x * x) / (w * w));
        double h = std::max(0.0, midline) * std::pow(1.0 - r2, 1.6);
        // Tip lobule, alae, nostrils.
        h += 2.5 * a_.nose_tip * gauss2(x, y - y_tip, 6.5, 5.0);
        const double ala_x = l_.x_al - 3.8, ala_y = y_base + 4.5;
        h += 8.0 * gauss2(ax - ala_x, y - ala_y, 4.2, 4.5);
        h -= 1.2 * gauss2(std::hypot(ax - ala_x, (y - ala_y) * 0.9) - 6.0, 0.0, 1.2, 1.0);  // alar crease
        h -= 3.0 * gauss2(ax - 0.42 * l_.x_al, y - (y_base + 2.2), 2.6, 1.5);                 // nostrils
        return h;
    }

    // The lips and the skin around them wrap round the teeth: the mouth corners lie about 30 mm behind the
    // lips' midline, not the 20 mm the head's section gives. Seen in how far each point moves sideways as
    // the head turns (`facesynth eval conventions`' depth on helen_train's annotations, docs/builtin-model.md
    // "Depth"): without this the corners sat 0.13 inter-ocular distances in front of the annotated ones,
    // the inner corners 0.18 (the Surrey model, from 3D scans, puts its corners near the annotated depth
    // when rendered). The fades above the upper lip and beside the corners are wide: a narrow one shades
    // as a ring round the mouth.
    [[nodiscard]] double dental_arch_depth(double x, double y) const {
        const double across = (1.0 - gauss(x, 12.0)) * smoothstep(l_.x_ch + 34.0, l_.x_ch + 6.0, std::abs(x));
        const double down = smoothstep(l_.y_sn + 2.0, l_.y_sto + 7.0, y) * smoothstep(l_.y_gn + 6.0, l_.y_sto - 14.0, y);
        return 13.0 * across * down;
    }

    [[nodiscard]] double lips_depth(int r, double x, double y) const {
        const double ax = std::abs(x);
        const double window = smoothstep(l_.x_ch + 4.0, l_.x_ch - 8.0, ax);
        double dz = 0;
        // Upper lip: skin sloping forward from subnasale to the vermilion, the vermilion bulge, its border.
        const double y_vu = l_.upper_vermilion(x), y_vl = l_.lower_vermilion(x);
        dz += 6.0 * a_.lips * window * gauss(y - (l_.y_sto + 3.5), 4.2);
        dz += 0.7 * window * gauss(y - y_vu, 0.9);
        // Lower lip.
        dz += 5.5 * a_.lips * window * gauss(y - (l_.y_sto - 5.0), 4.6);
        dz += 0.4 * window * gauss(y - y_vl, 1.0);
        // Philtrum: a groove between two ridges.
        const double philtrum = smoothstep(l_.y_sn - 1.0, l_.y_sn - 5.0, y) * smoothstep(y_vu - 0.5, y_vu + 2.0, y);
        dz += philtrum * (0.6 * gauss(ax - 5.0, 1.6) - 0.7 * gauss(x, 2.2));
        // Mouth line and corners.
        const int m = r - kRowStomion;
        const double inside = smoothstep(l_.x_ch + 2.0, l_.x_ch - 2.0, ax);
        if (m == 0) dz -= 2.8 * inside;
        if (std::abs(m) == 1) dz -= 1.0 * inside;
        dz -= 2.0 * gauss2(ax - l_.x_ch, y - l_.y_sto, 3.5, 3.5);
        // Nasolabial fold: a soft crease from the ala past the mouth corner.
        const Eigen::Vector2d fold_top(l_.x_al + 1.5, l_.y_sn + 5.0), fold_end(l_.x_ch + 5.0, l_.y_sto - 8.0);
        const Eigen::Vector2d q(ax, y), along = fold_end - fold_top;
        const double u = std::clamp((q - fold_top).dot(along) / along.squaredNorm(), 0.0, 1.0);
        const double fold_distance = (q - (fold_top + u * along)).norm();
        dz -= 1.3 * gauss(fold_distance, 2.2) * std::sin(std::numbers::pi * (0.15 + 0.85 * u));
        return dz;
    }

    // Expression displacement at a point of the neutral face.
    [[nodiscard]] Eigen::Vector3d expression_offset(int r, int /*c*/, const Eigen::Vector3d& p) const {
        Eigen::Vector3d d = Eigen::Vector3d::Zero();
        const double x = p.x(), y = p.y(), ax = std::abs(x), sx = x < 0 ? -1.0 : 1.0;
        if (e_.smile != 0) {
            const double corner = gauss2(ax - l_.x_ch, y - l_.y_sto, 11.0, 10.0);
            d += e_.smile * corner * Eigen::Vector3d(sx * 5.0, 6.0, -3.5);
            const double cheek = gauss2(ax - (l_.x_ch + 12), y - (l_.y_sto + 20), 14.0, 12.0);
            d += e_.smile * cheek * Eigen::Vector3d(sx * 1.5, 3.0, 2.5);
            const double lips = smoothstep(l_.x_ch + 6, l_.x_ch - 4, ax) * gauss(y - l_.y_sto, 10.0);
            d.x() += e_.smile * 0.08 * x * lips;
        }
        if (e_.pucker != 0) {
            const double g = gauss2(x, y - l_.y_sto, 0.85 * l_.x_ch, 9.0);
            d += e_.pucker * g * Eigen::Vector3d(-0.45 * x, 0.0, 10.0);
        }
        if (e_.brow_raise != 0) {
            const double above = smoothstep(l_.y_eye + 5.0, l_.y_eye + 14.0, y) * (1.0 - 0.6 * smoothstep(l_.y_eye + 25, l_.y_tr, y));
            const double across = smoothstep(l_.x_ex + 25.0, l_.x_ex + 5.0, ax);
            d.y() += e_.brow_raise * 7.0 * above * across;
        }
        if (e_.jaw_open != 0) {
            const int m = r - kRowStomion;
            const double inside = smoothstep(l_.x_ch + 8.0, l_.x_ch - 2.0, ax);
            const double mouth_weight = m > 0 ? 1.0 : (m == 0 ? 0.5 : 0.0);
            const double side_weight = smoothstep(l_.y_sto + 8.0, l_.y_sto - 22.0, y);
            const double w = lerp(side_weight, mouth_weight, inside);
            const double angle = e_.jaw_open * 20.0 * std::numbers::pi / 180.0 * w;
            const double hy = l_.y_eye - 25.0, hz = 5.0;
            const double dy = y - hy, dz = p.z() - hz;
            d.y() += dy * std::cos(angle) - dz * std::sin(angle) - dy;
            d.z() += dy * std::sin(angle) + dz * std::cos(angle) - dz;
            if (m == 0) d.z() -= e_.jaw_open * 14.0 * smoothstep(l_.x_ch, l_.x_ch - 8.0, ax);
            if (std::abs(m) == 1 || std::abs(m) == 2) d.z() -= e_.jaw_open * 2.0 * inside;
        }
        return d;
    }

    Anatomy a_;
    Expression e_;
    Layout l_;
    Profile depth_, exponent_;
    Profile width_{{{0.0, 0.0}, {1.0, 0.0}}};
    Profile forward_{{{0.0, 0.0}, {1.0, 0.0}}};
    Profile back_depth_{{{0.0, 0.0}, {1.0, 0.0}}};
    Profile max_angle_{{{0.0, 0.0}, {1.0, 0.0}}};  // degrees round from the midline where the mask ends  // how far forward the section's widest point sits (the mandible)
    Profile nose_half_width_{{{0.0, 0.0}, {1.0, 0.0}}};
};

// Farkas norms (docs/builtin-model.md) for one sex, with a shared size factor and individual spreads.
Anatomy random_anatomy(core::Rng& rng) {
    const bool male = rng.uniform() < 0.5;
    const double size = 1.0 + 0.035 * rng.truncated_normal(2.5);
    const auto measure = [&](double m, double f) { return (male ? m : f) * size * (1.0 + 0.04 * rng.truncated_normal(2.5)); };
    const auto factor = [&](double sd) { return 1.0 + sd * rng.truncated_normal(2.5); };
    Anatomy a;
    a.head_width = measure(151, 144);
    a.face_width = measure(137, 130);
    a.jaw_width = measure(97, 91);
    a.face_height = measure(121, 112);
    a.lower_face = measure(72, 64);
    a.forehead = measure(60, 56);
    a.biocular = measure(91, 88);
    a.intercanthal = measure(33, 32);
    a.nose_height = measure(54, 50);
    a.nose_width = measure(35, 31);
    a.nose_protrusion = measure(20, 19);
    a.mouth_width = measure(54, 50);
    a.upper_lip = measure(22, 20);
    a.head_depth = factor(0.03);
    a.brow_ridge = factor(0.25) * (male ? 1.15 : 0.85);
    a.cheek = factor(0.25);
    a.chin = factor(0.3) * (male ? 1.1 : 0.9);
    a.lips = factor(0.2) * (male ? 0.95 : 1.05);
    a.nose_bridge = factor(0.5);
    a.nose_tip = factor(0.12);
    a.eye_size = factor(0.08);
    a.eye_depth = factor(0.12);
    return a;
}

Eigen::VectorXf stacked(const Eigen::Matrix3Xf& points) {
    return Eigen::Map<const Eigen::VectorXf>(points.data(), points.size());
}

std::vector<Triangle> grid_triangles() {
    std::vector<Triangle> t;
    t.reserve(2 * (kRows - 1) * (kColumns - 1));
    for (int r = 0; r + 1 < kRows; ++r)
        for (int c = 0; c + 1 < kColumns; ++c) {
            const int a = vertex_id(r, c), b = vertex_id(r, c + 1), d = vertex_id(r + 1, c), e = vertex_id(r + 1, c + 1);
            // Diagonals mirror across the midline so the triangulation is symmetric.
            if (c < kMidColumn) {
                t.push_back({a, d, e});
                t.push_back({a, e, b});
            } else {
                t.push_back({a, d, b});
                t.push_back({b, d, e});
            }
        }
    return t;
}

Eigen::Matrix2Xf grid_uv() {
    Eigen::Matrix2Xf uv(2, kNumVertices);
    for (int r = 0; r < kRows; ++r)
        for (int c = 0; c < kColumns; ++c) {
            const double s = double(c - kMidColumn) / (kColumns - 1 - kMidColumn);
            const double f = FaceBuilder::column_fraction(std::abs(s));
            uv.col(vertex_id(r, c)) << static_cast<float>(0.5 + 0.5 * (s < 0 ? -f : f)), static_cast<float>(double(r) / (kRows - 1));
        }
    return uv;
}

// Eyebrow: centre line height and thickness at distance ax from the midline (thickness 0 outside).
// Its extent (from 5 mm inside the inner eye corner to 14 mm beyond the outer one) and its arch (a
// cubic in the position u along the brow, peaking at 5.9 mm above the inner end) are where 300-W's
// annotators put the brow points on helen_train, measured with the model fitted to their annotations
// (docs/builtin-model.md, "Where annotators put the points"); a brow over the eye alone was too short.
double brow_u(const Layout& l, double ax) { return (ax - (l.x_en - 5.0)) / ((l.x_ex + 14.0) - (l.x_en - 5.0)); }
double brow_x(const Layout& l, double u) { return lerp(l.x_en - 5.0, l.x_ex + 14.0, u); }
double brow_centre(const Layout& l, double ax) {
    const double u = std::clamp(brow_u(l, ax), 0.0, 1.0);
    return l.y_eye + 12.8 + u * (18.85 + u * (-3.84 - 19.57 * u));
}
double brow_thickness(const Layout& l, double ax) {
    const double u = brow_u(l, ax);
    if (u < 0.0 || u > 1.0) return 0.0;
    return lerp(9.0, 4.0, u) * std::min(1.0, u / 0.06 + 0.3) * std::min(1.0, (1.0 - u) / 0.08 + 0.2);
}

// A point on row `row` at model x, between the two row vertices that bracket it.
SurfacePoint on_row(const Eigen::Matrix3Xf& v, int row, double x) {
    int best = kMidColumn;
    for (int c = 0; c + 1 < kColumns; ++c) {
        const double x0 = v(0, vertex_id(row, c)), x1 = v(0, vertex_id(row, c + 1));
        if (v(2, vertex_id(row, c)) < 0 || v(2, vertex_id(row, c + 1)) < 0) continue;
        if ((x0 - x) * (x1 - x) <= 0) {
            best = c;
            const float f = static_cast<float>(std::clamp((x - x0) / std::max(1e-9, x1 - x0), 0.0, 1.0));
            return {{vertex_id(row, c), vertex_id(row, c + 1), vertex_id(row, c + 1)}, {1.0f - f, f, 0.0f}};
        }
    }
    return SurfacePoint::at_vertex(vertex_id(row, best));
}

// The front-most surface point under model (x, y) seen from the front (barycentric in a triangle).
SurfacePoint frontal_point(const Eigen::Matrix3Xf& v, const std::vector<Triangle>& triangles, double x, double y) {
    double best_z = -1e9;
    SurfacePoint best = SurfacePoint::at_vertex(0);
    for (const auto& t : triangles) {
        const Eigen::Vector3f a = v.col(t[0]), b = v.col(t[1]), c = v.col(t[2]);
        const double det = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
        if (det <= 1e-9) continue;  // back-facing or degenerate seen from the front
        const double w1 = ((x - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (y - a.y())) / det;
        const double w2 = ((b.x() - a.x()) * (y - a.y()) - (x - a.x()) * (b.y() - a.y())) / det;
        const double w0 = 1.0 - w1 - w2;
        if (w0 < -1e-6 || w1 < -1e-6 || w2 < -1e-6) continue;
        const double z = w0 * a.z() + w1 * b.z() + w2 * c.z();
        if (z > best_z) {
            best_z = z;
            best = {{t[0], t[1], t[2]}, {static_cast<float>(w0), static_cast<float>(w1), static_cast<float>(w2)}};
        }
    }
    if (best_z == -1e9) throw core::Error("builtin model: no surface under landmark position (" + std::to_string(x) + ", " + std::to_string(y) + ")");
    return best;
}

// Frontal silhouette of the subject's right side: per row, the vertex furthest from the midline.
std::vector<int> right_silhouette(const Eigen::Matrix3Xf& v, int first_row, int last_row) {
    std::vector<int> chain;
    for (int r = first_row; r <= last_row; ++r) {
        int best = vertex_id(r, kMidColumn);
        for (int c = 0; c < kMidColumn; ++c)
            if (v(2, vertex_id(r, c)) > -2.0 && v(0, vertex_id(r, c)) < v(0, best)) best = vertex_id(r, c);
        chain.push_back(best);
    }
    return chain;
}

int row_at_height(const Eigen::Matrix3Xf& v, double y) {
    int best = 0;
    for (int r = 0; r < kRows; ++r)
        if (std::abs(v(1, vertex_id(r, 0)) - y) < std::abs(v(1, vertex_id(best, 0)) - y)) best = r;
    return best;
}

int mirror_vertex(int id) { return vertex_id(id / kColumns, kColumns - 1 - id % kColumns); }

SurfacePoint mirrored(const SurfacePoint& p) {
    return {{mirror_vertex(p.vertices[0]), mirror_vertex(p.vertices[1]), mirror_vertex(p.vertices[2])}, p.weights};
}

// Points along a vertex chain at the given fractions (ascending, in [0, 1]) of its frontal arc length.
std::vector<SurfacePoint> along_chain(const Eigen::Matrix3Xf& v, const std::vector<int>& chain, std::span<const double> fractions) {
    std::vector<double> arc(chain.size(), 0.0);
    for (std::size_t i = 1; i < chain.size(); ++i)
        arc[i] = arc[i - 1] + (v.col(chain[i]).head<2>() - v.col(chain[i - 1]).head<2>()).norm();
    std::vector<SurfacePoint> out;
    std::size_t j = 0;
    for (const double fraction : fractions) {
        const double target = arc.back() * fraction;
        while (j + 2 < arc.size() && arc[j + 1] < target) ++j;
        const float f = static_cast<float>(std::clamp((target - arc[j]) / std::max(1e-9, arc[j + 1] - arc[j]), 0.0, 1.0));
        out.push_back({{chain[j], chain[j + 1], chain[j + 1]}, {1.0f - f, f, 0.0f}});
    }
    return out;
}

// `count` points evenly spaced by frontal arc length along a vertex chain.
std::vector<SurfacePoint> along_chain(const Eigen::Matrix3Xf& v, const std::vector<int>& chain, int count) {
    std::vector<double> fractions(static_cast<std::size_t>(count));
    for (int k = 0; k < count; ++k) fractions[static_cast<std::size_t>(k)] = double(k) / (count - 1);
    return along_chain(v, chain, fractions);
}

// Where 300-W's annotators put the points that the anatomical definitions above miss: a shift in mm in
// the frontal plane (x towards the subject's left, y up) of the points of the subject's right side and
// the midline (the left side is mirrored). Measured, not chosen: the model fitted to helen_train's
// annotations (`facesynth eval conventions`), its mean residual per landmark symmetrised and added, and
// repeated until the residuals stopped falling (tools/landmark_conventions.py, docs/builtin-model.md
// "Where annotators put the points"). Only points whose place is a convention move; the lids and outer
// lips stay on their margins and borders, the jaw (1-17) on the outline.
struct AnnotatorShift {
    int id;  // 1-based iBUG id
    double dx, dy;
};
// BEGIN annotator shifts (tools/landmark_conventions.py rewrites this block)
constexpr std::array<AnnotatorShift, 20> kAnnotatorShifts{{
    {18, -1.7, 2.1},
    {19, -1.5, 1.3},
    {20, -0.9, 0.2},
    {21, -0.5, 0.1},
    {22, -0.5, 0.1},
    {28, 0.0, -0.5},
    {29, 0.0, 0.5},
    {30, 0.0, 1.9},
    {31, 0.0, 2.7},
    {32, -2.3, -1.9},
    {33, -1.0, -2.2},
    {34, 0.0, -3.2},
    {37, 1.2, 0.2},
    {40, -2.3, 0.3},
    {49, 1.1, 0.0},
    {61, 2.1, 0.0},
    {62, 5.2, 0.0},
    {63, 0.0, 0.0},
    {67, 0.0, 0.0},
    {68, 5.1, 0.0},
}};
// END annotator shifts

// Where jaw points 1-9 lie along the outline from its top to gnathion (fractions of its frontal arc
// length): evenly spaced, except 7 and 8, which helen_train's annotators put nearer the chin
// (`facesynth eval conventions`; docs/builtin-model.md "Landmarks and contours").
constexpr std::array<double, 9> kJawArcFractions = {0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.775, 0.91, 1.0};

std::vector<SurfacePoint> ibug_landmarks(const Eigen::Matrix3Xf& v, const std::vector<Triangle>& triangles, const Layout& l) {
    std::vector<SurfacePoint> lm(kNumIbugLandmarks);
    const auto set_pair = [&](int right_id, SurfacePoint right) {  // 1-based id on the subject's right
        lm[static_cast<std::size_t>(right_id - 1)] = right;
        lm[static_cast<std::size_t>(ibug_mirror_pairs()[static_cast<std::size_t>(right_id - 1)])] = mirrored(right);
    };
    const auto front = [&](double x, double y) { return frontal_point(v, triangles, x, y); };
    // Jaw: the frontal outline from 4 mm above the eye line down to the chin. The top is where helen_train's
    // annotators put point 1 beside the eyes (0.04 inter-ocular distances below their centre); from
    // 4 mm below the eye line it sat 0.05 lower in near-frontal renders (and dlib put it higher there).
    const int first = row_at_height(v, l.y_eye + 4.0);
    std::vector<int> outline = right_silhouette(v, first, kRowGnathion - 1);
    outline.push_back(vertex_id(kRowGnathion, kMidColumn));
    const auto jaw = along_chain(v, outline, kJawArcFractions);
    for (int i = 0; i < 8; ++i) set_pair(i + 1, jaw[static_cast<std::size_t>(i)]);
    lm[kChinLandmark] = SurfacePoint::at_vertex(vertex_id(kRowGnathion, kMidColumn));
    // Brows (18 outer .. 22 inner), on the brow's upper half, at fractions of its length.
    const std::array<double, 5> brow_at = {0.98, 0.79, 0.53, 0.26, 0.0};
    for (int i = 0; i < 5; ++i) {
        const double x = brow_x(l, brow_at[static_cast<std::size_t>(i)]);
        set_pair(18 + i, front(-x, brow_centre(l, x) + 1.2));
    }
    // Nose bridge 28-31 and base 32-36.
    const double y28 = l.y_eye + 3.0, y31 = l.y_prn;
    for (int i = 0; i < 4; ++i) lm[27 + static_cast<std::size_t>(i)] = front(0.0, lerp(y28, y31, i / 3.0));
    lm[33] = front(0.0, l.y_sn + 0.3);
    set_pair(32, front(-0.72 * l.x_al, l.y_sn + 2.6));
    set_pair(33, front(-0.38 * l.x_al, l.y_sn + 1.0));
    // Eyes: corners on the fissure's centre row, lid points on the margin rows.
    const auto eye_x = [&](double t) { return -(l.x_ec + t * l.eye_half); };
    set_pair(37, on_row(v, kRowEye, eye_x(1.0)));
    set_pair(38, on_row(v, kRowEye - kFissureRows, eye_x(1.0 / 3.0)));
    set_pair(39, on_row(v, kRowEye - kFissureRows, eye_x(-1.0 / 3.0)));
    set_pair(40, on_row(v, kRowEye, eye_x(-1.0)));
    set_pair(41, on_row(v, kRowEye + kFissureRows, eye_x(-1.0 / 3.0)));
    set_pair(42, on_row(v, kRowEye + kFissureRows, eye_x(1.0 / 3.0)));
    // Outer lips: corners on the mouth line, the rest on the vermilion borders.
    set_pair(49, on_row(v, kRowStomion, -l.x_ch));
    for (const auto& [id, fx] : std::array<std::pair<int, double>, 2>{{{50, 0.62}, {51, 0.2}}})
        set_pair(id, front(-fx * l.x_ch, l.upper_vermilion(fx * l.x_ch)));
    lm[51] = front(0.0, l.upper_vermilion(0.0));
    for (const auto& [id, fx] : std::array<std::pair<int, double>, 2>{{{60, 0.6}, {59, 0.28}}})
        set_pair(id, front(-fx * l.x_ch, l.lower_vermilion(fx * l.x_ch)));
    lm[57] = front(0.0, l.lower_vermilion(0.0));
    // Inner lips: corners on the mouth line, upper and lower inner edges on the rows beside it.
    set_pair(61, on_row(v, kRowStomion, -(l.x_ch - 3.0)));
    set_pair(62, on_row(v, kRowStomion - 1, -0.45 * l.x_ch));
    lm[62] = on_row(v, kRowStomion - 1, 0.0);
    set_pair(68, on_row(v, kRowStomion + 1, -0.45 * l.x_ch));
    lm[66] = on_row(v, kRowStomion + 1, 0.0);
    for (const auto& shift : kAnnotatorShifts) {
        const auto index = static_cast<std::size_t>(shift.id - 1);
        const Eigen::Vector3f p = lm[index].position(v);
        const SurfacePoint moved = front(p.x() + shift.dx, p.y() + shift.dy);
        if (ibug_mirror_pairs()[index] == static_cast<int>(index)) lm[index] = moved;
        else set_pair(shift.id, moved);
    }
    return lm;
}


// Where each colour region lies on the mesh, as per-vertex weights in [0, 1] (computed once on the
// mean face, so the regions are in correspondence across the colour population).
struct ColourRegions {
    std::vector<float> sclera, iris, pupil, lashes, lid_margin, lips, mouth, nostrils, brows, hair, eye_shadow, cheeks, beard;
    std::vector<float> cavity;  // how deep in a crease (nostrils, mouth line, alar groove, canthi): baked-in occlusion
};

ColourRegions colour_regions(const Eigen::Matrix3Xf& v, const Layout& l) {
    ColourRegions g;
    for (auto* w : {&g.sclera, &g.iris, &g.pupil, &g.lashes, &g.lid_margin, &g.lips, &g.mouth, &g.nostrils, &g.brows, &g.hair,
                    &g.eye_shadow, &g.cheeks, &g.beard, &g.cavity})
        w->assign(kNumVertices, 0.0f);
    for (int r = 0; r < kRows; ++r)
        for (int c = 0; c < kColumns; ++c) {
            const int id = vertex_id(r, c);
            const auto i = static_cast<std::size_t>(id);
            const double x = v(0, id), y = v(1, id), ax = std::abs(x);
            const bool front = v(2, id) > 0;
            const double t = (ax - l.x_ec) / l.eye_half;
            const int k = r - kRowEye;
            // Eye: the rows between the lid margins, inside the corners.
            if (front && std::abs(k) < kFissureRows && std::abs(t) < 1.0) {
                g.sclera[i] = 1.0f;
                const double dx = ax - l.x_ec, dy = y - l.eye_centre_y(0.0) - 0.3;
                const double rho = std::hypot(dx, dy);
                g.iris[i] = static_cast<float>(smoothstep(6.8, 5.6, rho));
                g.pupil[i] = static_cast<float>(smoothstep(2.6, 1.8, rho));
            }
            if (front && std::abs(t) < 1.15) {
                if (k == -kFissureRows || k == -kFissureRows - 1) g.lashes[i] = static_cast<float>(k == -kFissureRows ? 1.0 : 0.55);
                if (k == kFissureRows) g.lid_margin[i] = 1.0f;
                if (std::abs(k) < kFissureRows && std::abs(t) >= 0.88) g.lid_margin[i] = 1.0f;  // canthi, caruncle
            }
            g.eye_shadow[i] = static_cast<float>(front ? gauss2(ax - l.x_ec, y - (l.y_eye + 1.0), 15.0, 9.0) : 0.0);
            // Lips: between the vermilion borders, inside the corners; the mouth line row is the mouth's inside.
            const double inside_mouth = smoothstep(l.x_ch + 1.0, l.x_ch - 1.0, ax);
            if (front && ax < l.x_ch + 1.0) {
                const double up = l.upper_vermilion(x), down = l.lower_vermilion(x);
                const double in_lip = smoothstep(up + 0.6, up - 0.6, y) * smoothstep(down - 0.8, down + 0.8, y);
                g.lips[i] = static_cast<float>(in_lip * inside_mouth);
                const double mouth_row = r == kRowStomion ? 1.0 : (std::abs(r - kRowStomion) == 1 ? 0.55 : 0.0);
                g.mouth[i] = static_cast<float>(mouth_row * smoothstep(l.x_ch - 1.0, l.x_ch - 4.0, ax));
            }
            g.nostrils[i] = static_cast<float>(front ? gauss2(ax - 0.42 * l.x_al, y - (l.y_sn + 2.2), 2.4, 1.4) : 0.0);
            const double thickness = brow_thickness(l, ax);
            if (front && thickness > 0) {
                const double d = std::abs(y - brow_centre(l, ax));
                g.brows[i] = static_cast<float>(smoothstep(0.5 * thickness + 0.8, 0.5 * thickness - 0.8, d));
            }
            // Scalp hair above the hairline, down to the temples at the sides.
            double hairline = l.y_tr - 4.0 * (1.0 - std::exp(-ax / 20.0)) - 30.0 * smoothstep(l.x_ex + 10.0, l.x_ex + 40.0, ax);
            hairline = std::min(hairline, lerp(hairline, lerp(l.y_eye + 17.0, l.y_sn, smoothstep(-35.0, -80.0, v(2, id))),
                                                smoothstep(30.0, 5.0, v(2, id))));
            g.hair[i] = static_cast<float>(smoothstep(hairline - 4.0, hairline + 5.0, y));
            g.cheeks[i] = static_cast<float>(front ? gauss2(ax - (l.x_ec + 6.0), y - (l.y_eye - 24.0), 12.0, 10.0) : 0.0);
            const double jaw_region = smoothstep(l.y_sn - 3.0, l.y_sn - 10.0, y) * smoothstep(l.x_ch + 35.0, l.x_ch + 15.0, ax);
            g.beard[i] = static_cast<float>(jaw_region * (1.0 - g.lips[i]) * (front ? 1.0 : 0.0));
        }
    // Concavity: the grid Laplacian along the outward normal, in mm, smoothed once.
    const Eigen::Matrix3Xf normals = vertex_normals(v, grid_triangles());
    std::vector<float> depth(kNumVertices, 0.0f);
    for (int r = 1; r + 1 < kRows; ++r)
        for (int c = 1; c + 1 < kColumns; ++c) {
            const int id = vertex_id(r, c);
            const Eigen::Vector3f average = 0.25f * (v.col(vertex_id(r - 1, c)) + v.col(vertex_id(r + 1, c)) +
                                                     v.col(vertex_id(r, c - 1)) + v.col(vertex_id(r, c + 1)));
            depth[static_cast<std::size_t>(id)] = std::max(0.0f, (average - v.col(id)).dot(normals.col(id)));
        }
    for (int r = 1; r + 1 < kRows; ++r)
        for (int c = 1; c + 1 < kColumns; ++c) {
            const auto at = [&](int rr, int cc) { return depth[static_cast<std::size_t>(vertex_id(rr, cc))]; };
            const float smooth = 0.5f * at(r, c) + 0.125f * (at(r - 1, c) + at(r + 1, c) + at(r, c - 1) + at(r, c + 1));
            const auto i = static_cast<std::size_t>(vertex_id(r, c));
            g.cavity[i] = std::clamp(0.5f * smooth, 0.0f, 0.45f) * (1.0f - g.sclera[i]);
        }
    return g;
}

// Semantic region of each vertex (morph/regions.h), from the construction: the painted colour
// regions (eyes, lips, mouth line, brows, scalp hair), the nose and ear displacement fields, and
// the rows under the chin and the back below the ears as neck. Computed once on the mean face.
std::vector<std::uint8_t> region_labels(const Eigen::Matrix3Xf& v, const Layout& l, const ColourRegions& g,
                                        const FaceBuilder::FeatureMasks& features) {
    std::vector<std::uint8_t> labels(kNumVertices, static_cast<std::uint8_t>(Region::kSkin));
    for (int r = 0; r < kRows; ++r)
        for (int c = 0; c < kColumns; ++c) {
            const int id = vertex_id(r, c);
            const auto i = static_cast<std::size_t>(id);
            Region region = Region::kSkin;
            if (r > kRowGnathion || (v(2, id) < -5.0 && v(1, id) < l.y_sn - 8.0)) region = Region::kNeck;
            if (g.hair[i] > 0.5f) region = Region::kHair;
            if (features.ears[i]) region = Region::kEars;
            if (features.nose[i]) region = Region::kNose;
            if (g.brows[i] > 0.5f) region = Region::kBrows;
            if (g.lips[i] > 0.3f) region = Region::kLips;  // the vermilion border (where the lip landmarks lie) too
            // The eye opening: the rows between the lid margins and the margins themselves, inside the canthi.
            const double t = (std::abs(v(0, id)) - l.x_ec) / l.eye_half;
            if (v(2, id) > 0 && std::abs(r - kRowEye) <= kFissureRows && std::abs(t) <= 1.0) region = Region::kEyes;
            if (g.mouth[i] > 0.5f) region = Region::kMouthInterior;
            labels[i] = static_cast<std::uint8_t>(region);
        }
    return labels;
}

Eigen::Vector3d lerp_vec(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double t) { return a + (b - a) * t; }

Eigen::Vector3d srgb_to_linear(const Eigen::Vector3d& srgb) {
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) {
        const double c = std::clamp(srgb[i], 0.0, 1.0);
        out[i] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
    }
    return out;
}

// One random colouring: skin tone from light to dark, hair, iris, lips, make-up-free regional tints.
Eigen::Matrix3Xf random_colouring(core::Rng& rng, const ColourRegions& g) {
    const double tone = rng.uniform();  // 0 light .. 1 dark
    const Eigen::Vector3d light(0.93, 0.76, 0.66), medium(0.76, 0.55, 0.42), dark(0.36, 0.23, 0.16);
    Eigen::Vector3d skin_srgb = tone < 0.5 ? (light + (medium - light) * (2 * tone)).eval() : (medium + (dark - medium) * (2 * tone - 1)).eval();
    // One draw per statement: the order of two draws in one expression is the compiler's choice. The
    // order here is the one GCC chose, so the model stays the one it was (docs/builtin-model.md).
    const double red_cast = rng.normal(), warmth = rng.normal();
    skin_srgb += Eigen::Vector3d(0.03, 0.0, -0.03) * warmth * 0.7 + Eigen::Vector3d(0.02, -0.01, -0.01) * red_cast * 0.7;
    const Eigen::Vector3d skin = srgb_to_linear(skin_srgb);
    const Eigen::Vector3d lip = srgb_to_linear(skin_srgb.cwiseProduct(Eigen::Vector3d(0.86, 0.58, 0.6) * (1.0 + 0.08 * rng.normal())));
    const double hair_b = rng.uniform(), hair_a = rng.uniform();
    const double hair_light = std::clamp(0.12 + 0.25 * (1.0 - tone) * hair_a * hair_b * 3.0, 0.05, 0.75);
    const Eigen::Vector3d hair = srgb_to_linear(Eigen::Vector3d(1.0, 0.8, 0.6) * hair_light);
    const std::array<Eigen::Vector3d, 5> irises = {Eigen::Vector3d(0.28, 0.16, 0.08), Eigen::Vector3d(0.18, 0.11, 0.06),
                                                   Eigen::Vector3d(0.40, 0.33, 0.18), Eigen::Vector3d(0.30, 0.40, 0.28),
                                                   Eigen::Vector3d(0.35, 0.48, 0.60)};
    // Iris from dark brown through hazel to blue-grey (light eyes only with lighter skin).
    const double lightness = std::clamp((1.0 - tone) * rng.uniform() * 1.3, 0.0, 1.0);
    const double hue = rng.uniform();
    const Eigen::Vector3d light_iris = hue < 0.5 ? lerp_vec(irises[2], irises[3], 2 * hue) : lerp_vec(irises[3], irises[4], 2 * hue - 1);
    const Eigen::Vector3d iris = srgb_to_linear(lerp_vec(irises[1], light_iris, lightness) * (1.0 + 0.08 * rng.normal()));
    const Eigen::Vector3d sclera = srgb_to_linear(Eigen::Vector3d(0.90, 0.87, 0.84) * (1.0 + 0.03 * rng.normal()));
    const Eigen::Vector3d mouth = srgb_to_linear(Eigen::Vector3d(0.30, 0.10, 0.10));
    const double flush = std::max(0.0, 0.12 + 0.06 * rng.normal());
    const double shadow = std::max(0.0, 0.15 + 0.07 * rng.normal());
    const double beard = std::max(0.0, rng.uniform() < 0.5 ? 0.12 * rng.uniform() : 0.0);
    const double brow_density = std::clamp(0.9 + 0.1 * rng.normal(), 0.5, 1.0);
    Eigen::Matrix3Xf colours(3, kNumVertices);
    for (int id = 0; id < kNumVertices; ++id) {
        const auto i = static_cast<std::size_t>(id);
        Eigen::Vector3d c = skin;
        c = c.cwiseProduct(Eigen::Vector3d(1.0 + flush * g.cheeks[i], 1.0 - 0.3 * flush * g.cheeks[i], 1.0 - 0.3 * flush * g.cheeks[i]));
        c *= 1.0 - shadow * g.eye_shadow[i];
        c *= 1.0 - beard * g.beard[i];
        c *= 1.0 - g.cavity[i];
        c = lerp_vec(c, lip, g.lips[i]);
        c = lerp_vec(c, hair, brow_density * g.brows[i]);
        c = lerp_vec(c, hair, g.hair[i]);
        c = lerp_vec(c, skin.cwiseProduct(Eigen::Vector3d(0.75, 0.45, 0.45)), g.lid_margin[i]);
        c = lerp_vec(c, sclera, g.sclera[i] * (1.0 - g.lid_margin[i]));
        c = lerp_vec(c, iris, g.iris[i] * g.sclera[i]);
        c = lerp_vec(c, Eigen::Vector3d(0.01, 0.01, 0.01), g.pupil[i] * g.sclera[i]);
        c = lerp_vec(c, hair.cwiseMin(Eigen::Vector3d(0.03, 0.02, 0.015)), 0.85 * g.lashes[i]);
        c = lerp_vec(c, skin * 0.12, g.nostrils[i]);
        c = lerp_vec(c, mouth, g.mouth[i]);
        colours.col(id) = c.cwiseMax(0.0).cwiseMin(1.0).cast<float>();
    }
    return colours;
}

}  // namespace

MorphableModel generate_builtin_model() {
    MorphableModel model;
    model.name = "builtin";
    model.triangles = grid_triangles();
    model.uv = grid_uv();

    // Shape: a population of anatomies in correspondence, through the same PCA as `model build`.
    std::vector<Eigen::VectorXf> population;
    population.reserve(kShapePopulation);
    for (int i = 0; i < kShapePopulation; ++i) {
        core::Rng rng = core::make_rng(kBuiltinSeed, static_cast<std::uint64_t>(i), core::RandomStream::kIdentity);
        population.push_back(stacked(FaceBuilder(random_anatomy(rng), {}).build()));
    }
    model.shape = build_pca(population, {.max_components = kShapeComponents});
    population.clear();

    // Expressions: each blendshape is the average face with that expression minus the neutral one.
    const Anatomy average;
    const Eigen::VectorXf neutral = stacked(FaceBuilder(average, {}).build());
    std::vector<Blendshape> blendshapes;
    const auto add = [&](const char* name, Expression e) {
        blendshapes.push_back({name, stacked(FaceBuilder(average, e).build()) - neutral});
    };
    add("jaw_open", {.jaw_open = 1});
    add("smile", {.smile = 1});
    add("brow_raise", {.brow_raise = 1});
    add("eye_close", {.eye_close = 1});
    add("pucker", {.pucker = 1});
    model.expression = std::move(blendshapes);

    // Landmarks, contours and colour regions are placed on the average face, whose layout is known.
    const Eigen::Matrix3Xf mean_points = as_points(neutral);
    const Layout layout = FaceBuilder(average, {}).layout();
    model.landmarks = ibug_landmarks(mean_points, model.triangles, layout);
    const auto chain = right_silhouette(mean_points, row_at_height(mean_points, layout.y_eye + 12.0), kRowGnathion - 1);
    std::vector<int> right;
    for (const auto& p : along_chain(mean_points, chain, 17)) right.push_back(p.weights[0] >= p.weights[1] ? p.vertices[0] : p.vertices[1]);
    model.contour.right = right;
    for (int id : right) model.contour.left.push_back(mirror_vertex(id));
    model.symmetry.resize(kNumVertices);
    for (int id = 0; id < kNumVertices; ++id) model.symmetry[static_cast<std::size_t>(id)] = mirror_vertex(id);

    // Colour: a population of colourings over fixed regions.
    const ColourRegions regions = colour_regions(mean_points, layout);
    std::vector<Eigen::VectorXf> colourings;
    colourings.reserve(kAlbedoPopulation);
    for (int i = 0; i < kAlbedoPopulation; ++i) {
        core::Rng rng = core::make_rng(kBuiltinSeed, static_cast<std::uint64_t>(i), core::RandomStream::kAlbedo);
        colourings.push_back(stacked(random_colouring(rng, regions)));
    }
    model.albedo = build_pca(colourings, {.max_components = kAlbedoComponents});
    model.vertex_labels = region_labels(mean_points, layout, regions, FaceBuilder(average, {}).feature_masks(mean_points, 1.0));

    model.validate("builtin model");
    return model;
}

bool builtin_model_is_embedded() { return facesynth_builtin_model_fsm_begin != nullptr; }

MorphableModel builtin_model() {
    if (!builtin_model_is_embedded()) return generate_builtin_model();
    const auto size = static_cast<std::size_t>(facesynth_builtin_model_fsm_end - facesynth_builtin_model_fsm_begin);
    return parse_model({reinterpret_cast<const char*>(facesynth_builtin_model_fsm_begin), size}, "the built-in model's embedded copy");
}

}  // namespace facesynth::morph
