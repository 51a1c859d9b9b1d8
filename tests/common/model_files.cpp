#include "common/model_files.h"

#include "core/byte_io.h"

#include <fstream>

namespace facesynth::testkit {
namespace {

// cereal-style pieces (int32 rows, int32 cols, column-major float32).
void put_matrix(core::ByteWriter& out, const Eigen::MatrixXf& m) {
    out.write(static_cast<std::int32_t>(m.rows()));
    out.write(static_cast<std::int32_t>(m.cols()));
    out.write_floats(m);
}

void put_pca(core::ByteWriter& out, const morph::PcaModel& pca, const std::vector<morph::Triangle>& triangles) {
    put_matrix(out, pca.mean);
    put_matrix(out, pca.basis);
    put_matrix(out, pca.eigenvalues);
    out.write(static_cast<std::uint64_t>(triangles.size()));
    out.write_bytes(triangles.data(), triangles.size() * sizeof(morph::Triangle));
}

void put_blendshapes(core::ByteWriter& out, const std::vector<morph::Blendshape>& shapes) {
    out.write(static_cast<std::uint64_t>(shapes.size()));
    for (const auto& b : shapes) {
        out.write_string(b.name);
        put_matrix(out, b.offsets);
    }
}

class H5Writer {
public:
    explicit H5Writer(const std::filesystem::path& path)
        : file_(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT)), links_(H5Pcreate(H5P_LINK_CREATE)) {
        H5Pset_create_intermediate_group(links_, 1);
    }
    ~H5Writer() {
        H5Pclose(links_);
        H5Fclose(file_);
    }
    H5Writer(const H5Writer&) = delete;
    H5Writer& operator=(const H5Writer&) = delete;

    void floats(const std::string& name, const DatasetSpec& spec) {
        const hid_t space = H5Screate_simple(static_cast<int>(spec.dims.size()), spec.dims.data(), nullptr);
        hid_t create = H5P_DEFAULT;
        if (spec.chunked_without_data) {
            create = H5Pcreate(H5P_DATASET_CREATE);
            std::vector<hsize_t> chunk(spec.dims.size(), 1);
            H5Pset_chunk(create, static_cast<int>(chunk.size()), chunk.data());
        }
        const hid_t set = H5Dcreate2(file_, name.c_str(), H5T_IEEE_F32LE, space, links_, create, H5P_DEFAULT);
        if (!spec.chunked_without_data) H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, spec.values.data());
        if (create != H5P_DEFAULT) H5Pclose(create);
        H5Dclose(set);
        H5Sclose(space);
    }

    void cells(const std::string& name, const std::vector<morph::Triangle>& triangles) {
        const hsize_t dims[2] = {3, triangles.size()};
        std::vector<std::uint32_t> values(3 * triangles.size());
        for (std::size_t t = 0; t < triangles.size(); ++t)
            for (std::size_t k = 0; k < 3; ++k) values[k * triangles.size() + t] = static_cast<std::uint32_t>(triangles[t][k]);
        const hid_t space = H5Screate_simple(2, dims, nullptr);
        const hid_t set = H5Dcreate2(file_, name.c_str(), H5T_STD_U32LE, space, links_, H5P_DEFAULT, H5P_DEFAULT);
        H5Dwrite(set, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
        H5Dclose(set);
        H5Sclose(space);
    }

private:
    hid_t file_;
    hid_t links_;
};

}  // namespace

std::string eos_model_bytes(const morph::MorphableModel& m, std::uint32_t version, bool with_landmarks) {
    core::ByteWriter out;
    out.write(version);
    put_pca(out, m.shape, m.triangles);
    if (m.albedo) put_pca(out, *m.albedo, {});
    else put_pca(out, morph::PcaModel{Eigen::VectorXf(0), Eigen::MatrixXf(0, 0), Eigen::VectorXf(0)}, {});
    if (version >= 2) {
        out.write(static_cast<std::uint8_t>(m.expression ? 0 : 1));  // cereal's optional: 1 = empty
        if (m.expression) {
            if (const auto* pca = std::get_if<morph::PcaModel>(&*m.expression)) {
                out.write(std::int32_t{0});
                put_pca(out, *pca, m.triangles);
            } else {
                out.write(std::int32_t{1});
                put_blendshapes(out, std::get<std::vector<morph::Blendshape>>(*m.expression));
            }
        }
    }
    if (version >= 3) {
        out.write(static_cast<std::uint8_t>(with_landmarks ? 0 : 1));
        if (with_landmarks) {
            out.write(static_cast<std::uint64_t>(m.landmarks.size() + 1));
            for (std::size_t i = 0; i < m.landmarks.size(); ++i) {
                out.write_string(std::to_string(i + 1));
                out.write(static_cast<std::int32_t>(m.landmarks[i].vertices[0]));
            }
            out.write_string("center.nose.tip");  // a non-iBUG name: ignored
            out.write(std::int32_t{0});
        }
    }
    out.write(static_cast<std::uint64_t>(m.uv.cols()));
    for (Eigen::Index i = 0; i < m.uv.cols(); ++i) {
        out.write(static_cast<double>(m.uv(0, i)));
        out.write(static_cast<double>(m.uv(1, i)));
    }
    if (version >= 4) {
        out.write(static_cast<std::uint64_t>(m.triangles.size()));
        out.write_bytes(m.triangles.data(), m.triangles.size() * sizeof(morph::Triangle));
    }
    return out.bytes();
}

std::string eos_blendshape_bytes(const std::vector<morph::Blendshape>& shapes) {
    core::ByteWriter out;
    put_blendshapes(out, shapes);
    return out.bytes();
}

DatasetSpec vector_spec(const Eigen::VectorXf& v) {
    return {{static_cast<hsize_t>(v.size())}, std::vector<float>(v.data(), v.data() + v.size())};
}

DatasetSpec matrix_spec(const Eigen::MatrixXf& m) {
    const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> row_major = m;
    return {{static_cast<hsize_t>(m.rows()), static_cast<hsize_t>(m.cols())},
            std::vector<float>(row_major.data(), row_major.data() + row_major.size())};
}

void write_statismo(const std::filesystem::path& path, const morph::MorphableModel& m, const StatismoOverrides& o) {
    H5Writer out(path);
    const auto put = [&](const std::string& name, const DatasetSpec& spec) {
        if (name == o.skip) return;
        const auto it = o.replace.find(name);
        out.floats(name, it != o.replace.end() ? it->second : spec);
    };
    const Eigen::MatrixXf points = morph::as_points(m.shape.mean);
    const auto group = [&](const std::string& g, const morph::PcaModel& pca) {
        put(g + "/model/mean", vector_spec(pca.mean));
        put(g + "/model/pcaBasis", matrix_spec(pca.basis));
        put(g + "/model/pcaVariance", vector_spec(pca.eigenvalues));
        put(g + "/model/noiseVariance", vector_spec(Eigen::VectorXf::Constant(1, 0.01f)));
        put(g + "/representer/points", matrix_spec(points));
        if (g + "/representer/cells" != o.skip) out.cells(g + "/representer/cells", m.triangles);
    };
    group("/shape", m.shape);
    if (m.albedo) group("/color", *m.albedo);
    if (m.expression) group("/expression", std::get<morph::PcaModel>(*m.expression));
}

void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace facesynth::testkit
