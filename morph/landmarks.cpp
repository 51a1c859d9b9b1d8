#include "morph/landmarks.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>

namespace facesynth::morph {
namespace {

// 1-based lists as a person reads them, turned 0-based below.
constexpr std::array<int, 7> kSubset7 = {37, 40, 43, 46, 31, 49, 55};
constexpr std::array<int, 13> kSubset13 = {18, 22, 23, 27, 37, 40, 43, 46, 31, 34, 49, 55, 9};

template <std::size_t N>
constexpr std::array<int, N> zero_based(const std::array<int, N>& ids) {
    std::array<int, N> out{};
    for (std::size_t i = 0; i < N; ++i) out[i] = ids[i] - 1;
    return out;
}

constexpr auto kSubset7Zero = zero_based(kSubset7);
constexpr auto kSubset13Zero = zero_based(kSubset13);

constexpr std::array<int, 49> make_subset49() {
    std::array<int, 49> out{};
    std::size_t n = 0;
    for (int id = 18; id <= 68; ++id)
        if (id != 61 && id != 65) out[n++] = id - 1;
    return out;
}
constexpr auto kSubset49Zero = make_subset49();

constexpr std::array<int, 68> make_subset68() {
    std::array<int, 68> out{};
    for (int i = 0; i < 68; ++i) out[static_cast<std::size_t>(i)] = i;
    return out;
}
constexpr auto kSubset68Zero = make_subset68();

constexpr std::array<int, 68> make_mirror() {
    std::array<int, 68> m{};
    for (int i = 0; i < 68; ++i) m[static_cast<std::size_t>(i)] = i;
    auto pair = [&m](int a, int b) {  // 1-based
        m[static_cast<std::size_t>(a - 1)] = b - 1;
        m[static_cast<std::size_t>(b - 1)] = a - 1;
    };
    for (int k = 1; k <= 8; ++k) pair(k, 18 - k);
    for (int k = 0; k < 5; ++k) pair(18 + k, 27 - k);
    pair(32, 36);
    pair(33, 35);
    pair(37, 46);
    pair(38, 45);
    pair(39, 44);
    pair(40, 43);
    pair(41, 48);
    pair(42, 47);
    pair(49, 55);
    pair(50, 54);
    pair(51, 53);
    pair(56, 60);
    pair(57, 59);
    pair(61, 65);
    pair(62, 64);
    pair(66, 68);
    return m;
}
constexpr auto kMirror = make_mirror();

void require68(const Eigen::Matrix2Xd& p, const char* what) {
    if (p.cols() != kNumIbugLandmarks)
        throw core::Error(std::string(what) + " needs 68 landmarks, got " + std::to_string(p.cols()));
}

}  // namespace

std::span<const int> landmark_subset(LandmarkSubset subset) {
    switch (subset) {
        case LandmarkSubset::k7: return kSubset7Zero;
        case LandmarkSubset::k13: return kSubset13Zero;
        case LandmarkSubset::k49: return kSubset49Zero;
        case LandmarkSubset::k68: return kSubset68Zero;
    }
    return kSubset68Zero;
}

LandmarkSubset parse_landmark_subset(std::string_view name) {
    if (name == "7") return LandmarkSubset::k7;
    if (name == "13") return LandmarkSubset::k13;
    if (name == "49") return LandmarkSubset::k49;
    if (name == "68") return LandmarkSubset::k68;
    throw core::Error("unknown landmark subset '" + std::string(name) + "' (expected 7, 13, 49 or 68)");
}

std::span<const int> ibug_mirror_pairs() { return kMirror; }

double inter_eye_centre_distance(const Eigen::Matrix2Xd& p) {
    require68(p, "inter-eye distance");
    const Eigen::Vector2d right = 0.5 * (p.col(36) + p.col(39));
    const Eigen::Vector2d left = 0.5 * (p.col(42) + p.col(45));
    return (left - right).norm();
}

double inter_ocular_distance(const Eigen::Matrix2Xd& p) {
    require68(p, "inter-ocular distance");
    return (p.col(kLeftEyeOuterCorner) - p.col(kRightEyeOuterCorner)).norm();
}

namespace {

struct FaceFrame {
    Eigen::Vector2d x_axis, y_axis;
    double iod = 0;
};

FaceFrame face_frame_of(const Eigen::Matrix2Xd& reference) {
    require68(reference, "face frame");
    const Eigen::Vector2d left = reference.middleCols(36, 6).rowwise().mean();
    const Eigen::Vector2d right = reference.middleCols(42, 6).rowwise().mean();
    FaceFrame f;
    f.iod = inter_ocular_distance(reference);
    f.x_axis = right - left;
    if (!(f.x_axis.norm() > 0) || !(f.iod > 0)) throw core::Error("face frame: degenerate eye landmarks");
    f.x_axis.normalize();
    f.y_axis = Eigen::Vector2d(-f.x_axis.y(), f.x_axis.x());
    return f;
}

}  // namespace

Eigen::Matrix2Xd face_frame_offsets(const Eigen::Matrix2Xd& points, const Eigen::Matrix2Xd& reference) {
    require68(points, "face-frame offsets");
    const FaceFrame f = face_frame_of(reference);
    Eigen::Matrix2Xd out(2, kNumIbugLandmarks);
    for (int i = 0; i < kNumIbugLandmarks; ++i) {
        const Eigen::Vector2d d = points.col(i) - reference.col(i);
        out(0, i) = d.dot(f.x_axis) / f.iod;
        out(1, i) = d.dot(f.y_axis) / f.iod;
    }
    return out;
}

Eigen::Matrix2Xd apply_face_frame_offsets(const Eigen::Matrix2Xd& points, const Eigen::Matrix2Xd& offsets) {
    if (offsets.cols() != kNumIbugLandmarks || offsets.rows() != 2) throw core::Error("face-frame offsets: expected 2 x 68 offsets");
    const FaceFrame f = face_frame_of(points);
    Eigen::Matrix2Xd out = points;
    for (int i = 0; i < kNumIbugLandmarks; ++i) out.col(i) += f.iod * (offsets(0, i) * f.x_axis + offsets(1, i) * f.y_axis);
    return out;
}

Eigen::Matrix2Xd read_pts(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw core::file_error(path.string(), "cannot open landmark file");
    std::string line;
    long declared = -1;
    bool in_points = false;
    std::vector<Eigen::Vector2d> points;
    int line_number = 0;
    while (std::getline(in, line)) {
        ++line_number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string::npos) continue;
        const std::string trimmed = line.substr(first);
        if (!in_points) {
            if (trimmed.rfind("version", 0) == 0) continue;
            if (trimmed.rfind("n_points", 0) == 0) {
                const auto colon = trimmed.find(':');
                if (colon == std::string::npos) throw core::file_error(path.string(), "malformed n_points line");
                try {
                    declared = std::stol(trimmed.substr(colon + 1));
                } catch (const std::exception&) {
                    throw core::file_error(path.string(), "malformed n_points line");
                }
                if (declared <= 0 || declared > 100000)
                    throw core::file_error(path.string(), "n_points " + std::to_string(declared) + " out of range");
                continue;
            }
            if (trimmed[0] == '{') {
                in_points = true;
                continue;
            }
            throw core::file_error(path.string(), "line " + std::to_string(line_number) + ": unexpected '" + trimmed + "'");
        }
        if (trimmed[0] == '}') {
            in_points = false;
            break;
        }
        std::istringstream fields(trimmed);
        double x = 0, y = 0;
        if (!(fields >> x >> y))
            throw core::file_error(path.string(), "line " + std::to_string(line_number) + ": expected 'x y'");
        if (!std::isfinite(x) || !std::isfinite(y))
            throw core::file_error(path.string(), "line " + std::to_string(line_number) + ": coordinate is not finite");
        points.emplace_back(x - 1.0, y - 1.0);
        if (declared > 0 && static_cast<long>(points.size()) > declared)
            throw core::file_error(path.string(), "more points than n_points " + std::to_string(declared));
    }
    if (declared < 0) throw core::file_error(path.string(), "missing n_points header (not an iBUG .pts file)");
    if (in_points) throw core::file_error(path.string(), "missing closing '}'");
    if (static_cast<long>(points.size()) != declared)
        throw core::file_error(path.string(), "has " + std::to_string(points.size()) + " points, header says " +
                                            std::to_string(declared));
    Eigen::Matrix2Xd result(2, static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) result.col(static_cast<Eigen::Index>(i)) = points[i];
    return result;
}

std::string format_pts(const Eigen::Matrix2Xd& points) {
    std::string out = "version: 1\nn_points: " + std::to_string(points.cols()) + "\n{\n";
    // 9 significant digits, as printf's %.9g (an ostream's precision(9)) writes them.
    const auto append = [&out](double value, char separator) {
        char text[32];
        const auto end = std::to_chars(text, text + sizeof text, value, std::chars_format::general, 9).ptr;
        out.append(text, end);
        out += separator;
    };
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
        append(points(0, i) + 1.0, ' ');
        append(points(1, i) + 1.0, '\n');
    }
    out += "}\n";
    return out;
}

void write_pts(const std::filesystem::path& path, const Eigen::Matrix2Xd& points) {
    core::write_file_atomically(path, format_pts(points));
}

}  // namespace facesynth::morph
