#include "morph/bfm_io.h"

#include "core/error.h"

#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <limits>
#include <vector>

namespace facesynth::morph {
namespace {

// One HDF5 identifier, closed by its own close function.
class Handle {
public:
    Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    ~Handle() {
        if (id_ >= 0) close_(id_);
    }
    Handle(Handle&& other) noexcept : id_(other.id_), close_(other.close_) { other.id_ = -1; }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    Handle& operator=(Handle&&) = delete;
    [[nodiscard]] hid_t get() const { return id_; }
    [[nodiscard]] bool valid() const { return id_ >= 0; }

private:
    hid_t id_;
    herr_t (*close_)(hid_t);
};

// HDF5 prints its error stack to stderr by default; our errors say what went wrong instead.
class QuietHdf5Errors {
public:
    QuietHdf5Errors() {
        H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    }
    ~QuietHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, function_, data_); }
    QuietHdf5Errors(const QuietHdf5Errors&) = delete;
    QuietHdf5Errors& operator=(const QuietHdf5Errors&) = delete;

private:
    H5E_auto2_t function_ = nullptr;
    void* data_ = nullptr;
};

// Exit status of the checking child process when the reader threw (its message is in the pipe).
constexpr int kChildError = 3;

// No dataset of a face model comes near this; a larger size is a corrupt or hostile header.
constexpr hsize_t kMaxElements = hsize_t{1} << 30;

class Reader {
public:
    Reader(const std::filesystem::path& path, hid_t file) : path_(path.string()), file_(file) {}

    [[nodiscard]] bool exists(const std::string& name) const {
        // H5Lexists needs every parent link to exist, so walk the path from the root.
        std::size_t pos = 0;
        while ((pos = name.find('/', pos + 1)) != std::string::npos)
            if (H5Lexists(file_, name.substr(0, pos).c_str(), H5P_DEFAULT) <= 0) return false;
        return H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0;
    }

    [[nodiscard]] std::vector<hsize_t> dims(const std::string& name) const {
        const Handle set = open(name);
        return dims_of(set, name);
    }

    // All values of a dataset as float, row-major (C order), after checking its size is `expected`
    // elements and that the data is really stored in the file.
    [[nodiscard]] std::vector<float> read_floats(const std::string& name, hsize_t expected) const {
        const Handle set = open(name);
        check_storage(set, name, expected);
        std::vector<float> values(static_cast<std::size_t>(expected));
        if (expected && H5Dread(set.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
            throw error(name, "cannot be read as floating-point values");
        for (std::size_t i = 0; i < values.size(); ++i)
            if (!std::isfinite(values[i])) throw error(name, "value " + std::to_string(i) + " is NaN or infinite");
        return values;
    }

    [[nodiscard]] std::vector<long long> read_integers(const std::string& name, hsize_t expected) const {
        const Handle set = open(name);
        check_storage(set, name, expected);
        std::vector<long long> values(static_cast<std::size_t>(expected));
        if (expected && H5Dread(set.get(), H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
            throw error(name, "cannot be read as integers");
        return values;
    }

    [[nodiscard]] core::Error error(const std::string& name, const std::string& problem) const {
        return core::file_error(path_, name + ": " + problem);
    }

private:
    [[nodiscard]] Handle open(const std::string& name) const {
        if (!exists(name)) throw error(name, "missing (not a Basel Face Model 2017 / statismo file?)");
        Handle set(H5Dopen2(file_, name.c_str(), H5P_DEFAULT), H5Dclose);
        if (!set.valid()) throw error(name, "is not a dataset");
        return set;
    }

    [[nodiscard]] std::vector<hsize_t> dims_of(const Handle& set, const std::string& name) const {
        const Handle space(H5Dget_space(set.get()), H5Sclose);
        if (!space.valid()) throw error(name, "has no dataspace");
        const int rank = H5Sget_simple_extent_ndims(space.get());
        if (rank < 1 || rank > 2) throw error(name, "has " + std::to_string(rank) + " dimensions, expected 1 or 2");
        std::vector<hsize_t> d(static_cast<std::size_t>(rank));
        H5Sget_simple_extent_dims(space.get(), d.data(), nullptr);
        hsize_t total = 1;
        for (hsize_t n : d) {
            if (n != 0 && total > kMaxElements / n)
                throw error(name, "dimensions too large (" + std::to_string(d[0]) + (rank == 2 ? " x " + std::to_string(d[1]) : "") + ")");
            total *= n;
        }
        return d;
    }

    void check_storage(const Handle& set, const std::string& name, hsize_t expected) const {
        hsize_t total = 1;
        for (hsize_t n : dims_of(set, name)) total *= n;
        if (total != expected)
            throw error(name, "has " + std::to_string(total) + " values, expected " + std::to_string(expected));
        const Handle type(H5Dget_type(set.get()), H5Tclose);
        const H5T_class_t type_class = H5Tget_class(type.get());
        if (type_class != H5T_FLOAT && type_class != H5T_INTEGER) throw error(name, "is not numeric");
        // Uncompressed data must be present in full; a header claiming more is truncated or corrupt.
        const Handle plist(H5Dget_create_plist(set.get()), H5Pclose);
        if (plist.valid() && H5Pget_nfilters(plist.get()) == 0) {
            const hsize_t needed = total * H5Tget_size(type.get());
            if (H5Dget_storage_size(set.get()) < needed)
                throw error(name, "holds fewer bytes than its " + std::to_string(total) + " values need (truncated?)");
        }
    }

    std::string path_;
    hid_t file_;
};

// One statismo model under `group` (/shape, /color or /expression) with `vertices` points.
PcaModel read_statismo_pca(const Reader& in, const std::string& group, hsize_t vertices) {
    const std::string mean_name = group + "/model/mean", basis_name = group + "/model/pcaBasis",
                      variance_name = group + "/model/pcaVariance";
    const auto mean_dims = in.dims(mean_name);
    hsize_t mean_size = 1;
    for (hsize_t n : mean_dims) mean_size *= n;
    if (mean_size != 3 * vertices)
        throw in.error(mean_name, "has " + std::to_string(mean_size) + " values for " + std::to_string(vertices) + " points");
    const auto basis_dims = in.dims(basis_name);
    if (basis_dims.size() != 2 || basis_dims[0] != 3 * vertices)
        throw in.error(basis_name, "must be (3 x points) x components");
    const hsize_t components = basis_dims[1];
    if (components == 0) throw in.error(basis_name, "has no components");

    PcaModel pca;
    const std::vector<float> mean = in.read_floats(mean_name, 3 * vertices);
    pca.mean = Eigen::Map<const Eigen::VectorXf>(mean.data(), static_cast<Eigen::Index>(mean.size()));
    const std::vector<float> basis = in.read_floats(basis_name, 3 * vertices * components);
    using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    pca.basis = Eigen::Map<const RowMajor>(basis.data(), static_cast<Eigen::Index>(3 * vertices),
                                           static_cast<Eigen::Index>(components));
    const std::vector<float> variance = in.read_floats(variance_name, components);
    pca.eigenvalues = Eigen::Map<const Eigen::VectorXf>(variance.data(), static_cast<Eigen::Index>(variance.size()));
    if ((pca.eigenvalues.array() < 0).any()) throw in.error(variance_name, "has negative variances");
    return pca;
}

hsize_t point_count(const Reader& in, const std::string& group) {
    const std::string name = group + "/representer/points";
    const auto d = in.dims(name);
    if (d.size() != 2 || d[0] != 3 || d[1] == 0) throw in.error(name, "must be 3 x points");
    return d[1];
}

}  // namespace

double unit_scale_to_mm(const Eigen::VectorXf& stacked_points, const std::string& source) {
    if (stacked_points.size() < 3) throw core::Error(source + ": no points to judge units from");
    const auto points = as_points(stacked_points);
    const double diagonal = (points.rowwise().maxCoeff() - points.rowwise().minCoeff()).cast<double>().norm();
    if (diagonal >= 30.0 && diagonal <= 3000.0) return 1.0;
    if (diagonal >= 30e3 && diagonal <= 3e6) return 1e-3;
    if (diagonal >= 0.03 && diagonal <= 3.0) return 1e3;
    throw core::Error(source + ": cannot tell the units: the mean shape's bounding box diagonal is " +
                std::to_string(diagonal) + " (expected a head in mm, um or m)");
}

void scale_model_lengths(MorphableModel& model, double factor) {
    const auto f = static_cast<float>(factor);
    const auto scale_pca = [f](PcaModel& pca) {
        pca.mean *= f;
        pca.eigenvalues *= f * f;
    };
    scale_pca(model.shape);
    if (model.expression) {
        if (auto* pca = std::get_if<PcaModel>(&*model.expression)) scale_pca(*pca);
        else
            for (auto& b : std::get<std::vector<Blendshape>>(*model.expression)) b.offsets *= f;
    }
}

namespace {

MorphableModel read_in_this_process(const std::filesystem::path& path) {
    const QuietHdf5Errors quiet;
    const std::string name = path.string();
    if (!std::filesystem::is_regular_file(path)) throw core::file_error(name, "no such file");
    if (std::filesystem::file_size(path) == 0) throw core::file_error(name, "empty file (expected an HDF5 model)");
    if (H5Fis_hdf5(name.c_str()) <= 0) throw core::file_error(name, "not an HDF5 file (expected a Basel Face Model 2017 .h5)");
    const Handle file(H5Fopen(name.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!file.valid()) throw core::file_error(name, "cannot open as HDF5 (truncated or corrupt?)");
    const Reader in(path, file.get());

    MorphableModel model;
    model.name = path.stem().string();
    const hsize_t vertices = point_count(in, "/shape");
    model.shape = read_statismo_pca(in, "/shape", vertices);

    const std::string cells_name = "/shape/representer/cells";
    const auto cell_dims = in.dims(cells_name);
    if (cell_dims.size() != 2 || cell_dims[0] != 3) throw in.error(cells_name, "must be 3 x triangles");
    const std::vector<long long> cells = in.read_integers(cells_name, 3 * cell_dims[1]);
    const auto triangles = static_cast<std::size_t>(cell_dims[1]);
    model.triangles.resize(triangles);
    for (std::size_t t = 0; t < triangles; ++t)
        for (std::size_t k = 0; k < 3; ++k) {
            const long long id = cells[k * triangles + t];  // row k holds corner k of every triangle
            if (id < 0 || static_cast<hsize_t>(id) >= vertices)
                throw in.error(cells_name, "triangle " + std::to_string(t) + " refers to vertex " + std::to_string(id) +
                                               " of " + std::to_string(vertices));
            model.triangles[t][k] = static_cast<int>(id);
        }

    for (const char* group : {"/color", "/expression"}) {
        if (!in.exists(std::string(group) + "/model/mean")) continue;
        const hsize_t group_vertices = in.exists(std::string(group) + "/representer/points") ? point_count(in, group) : vertices;
        if (group_vertices != vertices)
            throw in.error(group, "has " + std::to_string(group_vertices) + " points, the shape has " + std::to_string(vertices));
        PcaModel pca = read_statismo_pca(in, group, vertices);
        if (std::string(group) == "/color") model.albedo = std::move(pca);
        else model.expression = std::move(pca);
    }

    const double scale = unit_scale_to_mm(model.shape.mean, name);
    if (scale != 1.0) {
        std::fprintf(stderr, "facesynth: warning: %s: coordinates look like %s (bounding box); converted to mm\n",
                     name.c_str(), scale < 1.0 ? "micrometres" : "metres");
        scale_model_lengths(model, scale);
    }
    model.validate(name);
    return model;
}

// HDF5 1.10.8 (Debian 12) crashes inside its own parser on some corrupt files: fuzz_bfm found a
// SEGV in H5Lexists on a damaged local heap, and a 12 EB allocation request from its metadata
// cache. So a child process reads the file first: a crash there becomes an error naming the file,
// and only a file the child has read cleanly is read in this process.
void read_in_a_child_process_first(const std::filesystem::path& path) {
    int fds[2];
    if (::pipe(fds) != 0) throw core::file_error(path.string(), std::string("cannot create a pipe: ") + std::strerror(errno));
    const pid_t child = ::fork();
    if (child < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        throw core::file_error(path.string(), std::string("cannot fork to read it: ") + std::strerror(errno));
    }
    if (child == 0) {
        ::close(fds[0]);
        int status = 0;
        try {
            (void)read_in_this_process(path);
        } catch (const std::exception& e) {
            const std::string message = e.what();
            const ssize_t written = ::write(fds[1], message.data(), message.size());
            status = written >= 0 ? kChildError : kChildError + 1;
        }
        ::_exit(status);
    }
    ::close(fds[1]);
    std::string message;
    std::array<char, 4096> buffer{};
    for (;;) {
        const ssize_t n = ::read(fds[0], buffer.data(), buffer.size());
        if (n > 0)
            message.append(buffer.data(), static_cast<std::size_t>(n));
        else if (n < 0 && errno == EINTR)
            continue;
        else
            break;
    }
    ::close(fds[0]);
    int status = 0;
    while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    if (WIFEXITED(status) && WEXITSTATUS(status) == kChildError && !message.empty())
        throw message.find(path.string()) == std::string::npos ? core::file_error(path.string(), message) : core::Error(message);
    throw core::file_error(path.string(), "the HDF5 library crashed reading it (corrupt file?)");
}

}  // namespace

MorphableModel read_bfm2017(const std::filesystem::path& path) {
    read_in_a_child_process_first(path);
    return read_in_this_process(path);
}

}  // namespace facesynth::morph
