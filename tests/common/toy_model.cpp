#include "common/toy_model.h"

#include "core/random.h"

#include <Eigen/QR>

#include <cmath>
#include <numbers>

namespace facesynth::testkit {

Eigen::Matrix2Xd ibug68_frontal_template() {
    Eigen::Matrix2Xd t(2, 68);
    for (int i = 0; i < 17; ++i) {
        const double a = std::numbers::pi * i / 16.0;
        t.col(i) << -66.0 * std::cos(a), 30.0 - 95.0 * std::sin(a);
    }
    const double brow[5][2] = {{-55, 48}, {-45, 54}, {-35, 56}, {-24, 55}, {-13, 52}};
    for (int i = 0; i < 5; ++i) {
        t.col(17 + i) << brow[i][0], brow[i][1];
        t.col(26 - i) << -brow[i][0], brow[i][1];
    }
    const double bridge[4] = {35, 24, 12, 0};
    for (int i = 0; i < 4; ++i) t.col(27 + i) << 0.0, bridge[i];
    const double base[5][2] = {{-15, -8}, {-8, -10}, {0, -11}, {8, -10}, {15, -8}};
    for (int i = 0; i < 5; ++i) t.col(31 + i) << base[i][0], base[i][1];
    const double eye[6][2] = {{-47, 35}, {-38, 40}, {-26, 40}, {-17, 35}, {-26, 31}, {-38, 31}};
    // Left eye mirrors the right: 43 inner, 44, 45, 46 outer, 47, 48.
    const int mirror_eye[6] = {45, 44, 43, 42, 47, 46};
    for (int i = 0; i < 6; ++i) {
        t.col(36 + i) << eye[i][0], eye[i][1];
        t.col(mirror_eye[i]) << -eye[i][0], eye[i][1];
    }
    const double mouth[12][2] = {{-25, -30}, {-16, -24}, {-6, -21}, {0, -22}, {6, -21}, {16, -24},
                                 {25, -30},  {16, -37},  {6, -40},  {0, -41}, {-6, -40}, {-16, -37}};
    for (int i = 0; i < 12; ++i) t.col(48 + i) << mouth[i][0], mouth[i][1];
    const double inner[8][2] = {{-21, -30}, {-7, -28}, {0, -28}, {7, -28}, {21, -30}, {7, -32}, {0, -32}, {-7, -32}};
    for (int i = 0; i < 8; ++i) t.col(60 + i) << inner[i][0], inner[i][1];
    return t;
}

namespace {

constexpr double kA = 75.0, kB = 100.0, kC = 90.0;  // semi-axes x, y, z (mm)

}  // namespace

morph::MorphableModel make_toy_model(const ToyModelOptions& o) {
    morph::MorphableModel m;
    m.name = "toy";
    const int lat = o.latitude_steps, lon = o.longitude_steps;
    // Vertices: two poles plus (lat - 1) rings of `lon` vertices; longitude 0 faces +z.
    std::vector<Eigen::Vector3f> points;
    points.emplace_back(0.0f, static_cast<float>(kB), 0.0f);
    for (int i = 1; i < lat; ++i) {
        const double theta = std::numbers::pi * i / lat;  // from +y down
        for (int j = 0; j < lon; ++j) {
            const double phi = 2.0 * std::numbers::pi * j / lon;
            Eigen::Vector3d p(kA * std::sin(theta) * std::sin(phi), kB * std::cos(theta), kC * std::sin(theta) * std::cos(phi));
            // A nose: a smooth bump in front, below the eyes.
            const double d2 = (p.x() * p.x()) / 200.0 + (p.y() - 12.0) * (p.y() - 12.0) / 500.0;
            if (p.z() > 0) p.z() += 22.0 * std::exp(-d2);
            points.emplace_back(p.cast<float>());
        }
    }
    points.emplace_back(0.0f, static_cast<float>(-kB), 0.0f);
    const int v = static_cast<int>(points.size());
    const int south = v - 1;
    auto ring = [lon](int i, int j) { return 1 + (i - 1) * lon + ((j % lon) + lon) % lon; };
    // Counter-clockwise seen from outside.
    for (int j = 0; j < lon; ++j) m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i < lat - 1; ++i)
        for (int j = 0; j < lon; ++j) {
            m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i, j + 1)});
            m.triangles.push_back({ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)});
        }
    for (int j = 0; j < lon; ++j) m.triangles.push_back({south, ring(lat - 1, j + 1), ring(lat - 1, j)});

    m.shape.mean.resize(3 * v);
    for (int i = 0; i < v; ++i) m.shape.mean.segment<3>(3 * i) = points[static_cast<std::size_t>(i)];

    // Smooth random components: low-order trigonometric fields along the outward direction.
    core::Rng rng(o.seed, 0, 99);
    const int k = o.shape_components;
    Eigen::MatrixXf raw(3 * v, k);
    for (int c = 0; c < k; ++c) {
        const double fx = rng.uniform(0.5, 2.5), fy = rng.uniform(0.5, 2.5), px = rng.uniform(0, 6.28), py = rng.uniform(0, 6.28);
        const Eigen::Vector3d shear(rng.normal(), rng.normal(), rng.normal());
        for (int i = 0; i < v; ++i) {
            const Eigen::Vector3d p = points[static_cast<std::size_t>(i)].cast<double>();
            const Eigen::Vector3d n = Eigen::Vector3d(p.x() / (kA * kA), p.y() / (kB * kB), p.z() / (kC * kC)).normalized();
            const double f = std::sin(fx * p.x() / kA + px) * std::cos(fy * p.y() / kB + py);
            raw.block<3, 1>(3 * i, c) = (n * f + 0.2 * shear * p.z() / kC).cast<float>();
        }
    }
    Eigen::HouseholderQR<Eigen::MatrixXf> qr(raw);
    m.shape.basis = qr.householderQ() * Eigen::MatrixXf::Identity(3 * v, k);
    m.shape.eigenvalues.resize(k);
    for (int c = 0; c < k; ++c) m.shape.eigenvalues[c] = static_cast<float>(100.0 / std::pow(c + 1.0, 1.5));

    // Blendshapes: jaw open (lower face moves down) and smile (mouth sides up and back).
    std::vector<morph::Blendshape> shapes(2);
    shapes[0].name = "jaw_open";
    shapes[1].name = "smile";
    for (auto& s : shapes) s.offsets = Eigen::VectorXf::Zero(3 * v);
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = points[static_cast<std::size_t>(i)];
        if (p.z() > 0 && p.y() < -20) shapes[0].offsets[3 * i + 1] = -12.0f * std::min(1.0f, (-20.0f - p.y()) / 30.0f);
        const float w = std::exp(-((std::abs(p.x()) - 25.0f) * (std::abs(p.x()) - 25.0f) / 150.0f + (p.y() + 30.0f) * (p.y() + 30.0f) / 150.0f));
        if (p.z() > 0) {
            shapes[1].offsets[3 * i + 1] = 6.0f * w;
            shapes[1].offsets[3 * i + 2] = -3.0f * w;
        }
    }
    m.expression = std::move(shapes);

    morph::PcaModel albedo;
    albedo.mean.resize(3 * v);
    for (int i = 0; i < v; ++i) albedo.mean.segment<3>(3 * i) = Eigen::Vector3f(0.72f, 0.52f, 0.42f);
    Eigen::MatrixXf albedo_raw(3 * v, 3);
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = points[static_cast<std::size_t>(i)];
        albedo_raw.block<3, 1>(3 * i, 0) = Eigen::Vector3f(1.0f, 0.8f, 0.7f);
        albedo_raw.block<3, 1>(3 * i, 1) = Eigen::Vector3f(1.0f, -0.5f, -0.5f) * (p.y() / 100.0f);
        albedo_raw.block<3, 1>(3 * i, 2) = Eigen::Vector3f(0.2f, 0.5f, 1.0f) * (p.x() / 75.0f);
    }
    Eigen::HouseholderQR<Eigen::MatrixXf> albedo_qr(albedo_raw);
    albedo.basis = albedo_qr.householderQ() * Eigen::MatrixXf::Identity(3 * v, 3);
    albedo.eigenvalues = Eigen::Vector3f(0.3f, 0.1f, 0.05f).cwiseAbs2() * static_cast<float>(v);
    albedo.eigenvalues /= static_cast<float>(v) * 10.0f;
    m.albedo = std::move(albedo);

    m.uv.resize(2, v);
    for (int i = 0; i < v; ++i) {
        const Eigen::Vector3f p = points[static_cast<std::size_t>(i)];
        m.uv.col(i) << 0.5f + static_cast<float>(std::atan2(p.x(), p.z()) / (2.0 * std::numbers::pi)),
            0.5f - p.y() / static_cast<float>(2.0 * kB);
    }

    m.symmetry.resize(static_cast<std::size_t>(v));
    m.symmetry[0] = 0;
    m.symmetry[static_cast<std::size_t>(south)] = south;
    for (int i = 1; i < lat; ++i)
        for (int j = 0; j < lon; ++j) m.symmetry[static_cast<std::size_t>(ring(i, j))] = ring(i, lon - j);

    // Landmarks: the front-facing vertex nearest each template point.
    const Eigen::Matrix2Xd tmpl = ibug68_frontal_template();
    auto nearest_front = [&](double x, double y) {
        int best = 0;
        double best_d = 1e30;
        for (int i = 0; i < v; ++i) {
            const Eigen::Vector3f p = points[static_cast<std::size_t>(i)];
            if (p.z() <= 0) continue;
            const double d = (p.x() - x) * (p.x() - x) + (p.y() - y) * (p.y() - y);
            if (d < best_d) { best_d = d; best = i; }
        }
        return best;
    };
    for (int l = 0; l < 68; ++l) m.landmarks.push_back(morph::SurfacePoint::at_vertex(nearest_front(tmpl(0, l), tmpl(1, l))));

    // Jaw contour chains: per height, the outermost front-half vertex on each side.
    for (int h = 0; h < 17; ++h) {
        const double y = 50.0 - 100.0 * h / 16.0;
        int right = 0, left = 0;
        double right_x = 1e30, left_x = -1e30;
        for (int i = 0; i < v; ++i) {
            const Eigen::Vector3f p = points[static_cast<std::size_t>(i)];
            if (p.z() < 0 || std::abs(p.y() - y) > kB / lat * 1.5) continue;
            if (p.x() < right_x) { right_x = p.x(); right = i; }
            if (p.x() > left_x) { left_x = p.x(); left = i; }
        }
        m.contour.right.push_back(right);
        m.contour.left.push_back(left);
    }
    return m;
}

void set_uniform_colour_model(morph::MorphableModel& model, const Eigen::Vector3f& mean, const Eigen::Vector3f& shift_per_sigma) {
    const int v = model.num_vertices();
    morph::PcaModel albedo;
    albedo.mean = mean.replicate(v, 1);
    albedo.basis = shift_per_sigma.replicate(v, 1);
    const float norm = albedo.basis.norm();
    albedo.basis /= norm;
    albedo.eigenvalues = Eigen::VectorXf::Constant(1, norm * norm);
    model.albedo = std::move(albedo);
}

}  // namespace facesynth::testkit
