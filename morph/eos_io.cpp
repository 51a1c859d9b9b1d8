#include "morph/eos_io.h"

#include "core/atomic_file.h"
#include "core/byte_io.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/sfm_completion_data.h"  // generated from data/sfm_landmarks_completion.toml
#include "core/toml_file.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace facesynth::morph {
namespace {

// cereal writes an Eigen matrix as int32 rows, int32 cols, then the values column-major.
Eigen::MatrixXf read_eigen_matrix(core::ByteReader& in, const char* what) {
    const auto rows = in.read<std::int32_t>(what);
    const auto cols = in.read<std::int32_t>(what);
    if (rows < 0 || cols < 0)
        throw in.error(std::string(what) + ": negative dimensions " + std::to_string(rows) + " x " + std::to_string(cols));
    in.check_fits(static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(cols), sizeof(float), what);
    Eigen::MatrixXf m(rows, cols);
    in.read_floats(m, what);
    return m;
}

Eigen::VectorXf read_eigen_vector(core::ByteReader& in, const char* what) {
    const Eigen::MatrixXf m = read_eigen_matrix(in, what);
    if (m.size() == 0) return {};
    if (m.cols() != 1)
        throw in.error(std::string(what) + ": expected a column vector, got " + std::to_string(m.rows()) + " x " +
                       std::to_string(m.cols()));
    return m.col(0);
}

std::vector<Triangle> read_triangles(core::ByteReader& in, const char* what) {
    const std::size_t count = in.read_count(3 * sizeof(std::int32_t), what);
    std::vector<Triangle> triangles(count);
    if (count) in.read_bytes(triangles.data(), count * sizeof(Triangle), what);
    return triangles;
}

struct EosPca {
    PcaModel pca;
    std::vector<Triangle> triangles;
};

EosPca read_pca(core::ByteReader& in, const std::string& what) {
    EosPca result;
    const std::string mean_what = what + " mean", basis_what = what + " basis", ev_what = what + " eigenvalues",
                      tri_what = what + " triangle list";
    result.pca.mean = read_eigen_vector(in, mean_what.c_str());
    result.pca.basis = read_eigen_matrix(in, basis_what.c_str());
    result.pca.eigenvalues = read_eigen_vector(in, ev_what.c_str());
    result.triangles = read_triangles(in, tri_what.c_str());
    auto& p = result.pca;
    if (p.mean.size() == 0) {  // an empty model (the shape-only SFM's colour model) has no basis either
        if (p.basis.size() != 0 || p.eigenvalues.size() != 0)
            throw in.error(what + ": empty mean but a non-empty basis");
        p.basis.resize(0, 0);
        return result;
    }
    if (p.mean.size() % 3 != 0)
        throw in.error(what + ": mean has " + std::to_string(p.mean.size()) + " values, not a multiple of 3");
    if (p.basis.rows() != p.mean.size())
        throw in.error(what + ": basis has " + std::to_string(p.basis.rows()) + " rows for a mean of " +
                       std::to_string(p.mean.size()));
    if (p.eigenvalues.size() != p.basis.cols())
        throw in.error(what + ": " + std::to_string(p.basis.cols()) + " basis vectors but " +
                       std::to_string(p.eigenvalues.size()) + " eigenvalues");
    if ((p.eigenvalues.array() < 0).any()) throw in.error(what + ": negative eigenvalue (variances must be >= 0)");
    return result;
}

std::vector<Blendshape> read_blendshape_vector(core::ByteReader& in) {
    // Each blendshape takes at least its name length and matrix header.
    const std::size_t count = in.read_count(8 + 8, "blendshape count");
    std::vector<Blendshape> shapes;
    shapes.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
        Blendshape b;
        b.name = in.read_string("blendshape name");
        const std::string what = "blendshape '" + b.name + "'";
        b.offsets = read_eigen_vector(in, what.c_str());
        shapes.push_back(std::move(b));
    }
    return shapes;
}

// cereal's std::optional: a bool that is true when the optional is EMPTY.
bool read_optional_present(core::ByteReader& in, const char* what) {
    const auto empty_flag = in.read<std::uint8_t>(what);
    if (empty_flag > 1) throw in.error(std::string(what) + ": optional flag " + std::to_string(empty_flag) + " is not 0 or 1");
    return empty_flag == 0;
}

void check_ibug_id(int ibug_id, int vertex, const std::string& where) {
    if (ibug_id < 1 || ibug_id > kNumIbugLandmarks)
        throw core::Error(where + ": iBUG landmark id " + std::to_string(ibug_id) + " outside 1..68");
    if (vertex < 0) throw core::Error(where + ": landmark " + std::to_string(ibug_id) + " maps to negative vertex " + std::to_string(vertex));
}

LandmarkMapping mapping_from_toml(const toml::value& root, const std::string& source) {
    LandmarkMapping mapping;
    if (!root.contains("landmark_mappings")) throw core::file_error(source, "no [landmark_mappings] table");
    const auto& table = toml::find(root, "landmark_mappings");
    if (!table.is_table()) throw core::file_error(source, "landmark_mappings is not a table");
    for (const auto& [key, value] : table.as_table()) {
        int ibug_id = 0;
        try {
            std::size_t used = 0;
            ibug_id = std::stoi(key, &used);
            if (used != key.size()) throw std::invalid_argument(key);
        } catch (const std::exception&) {
            throw core::file_error(source, "landmark key '" + key + "' is not an iBUG id");
        }
        if (!value.is_integer()) throw core::file_error(source, "landmark " + key + " is not an integer vertex id");
        const auto vertex = value.as_integer();
        if (vertex > std::numeric_limits<int>::max()) throw core::file_error(source, "landmark " + key + ": vertex id too large");
        check_ibug_id(ibug_id, static_cast<int>(vertex), source);
        mapping[ibug_id] = static_cast<int>(vertex);
    }
    return mapping;
}

}  // namespace

EosModelFile read_eos_model(const std::filesystem::path& path) {
    const std::string bytes = core::read_file(path);
    core::ByteReader in(bytes, path.string());
    if (bytes.empty()) throw core::file_error(path.string(), "empty file (expected an eos MorphableModel)");
    EosModelFile result;
    const auto version = in.read<std::uint32_t>("model version");
    if (version < 1 || version > 4)
        throw core::file_error(path.string(), "unsupported eos MorphableModel version " + std::to_string(version) +
                                            " (this reader knows 1 to 4; is it an eos model file?)");
    result.version = static_cast<int>(version);
    MorphableModel& model = result.model;
    model.name = path.stem().string();

    EosPca shape = read_pca(in, "shape model");
    if (shape.pca.empty()) throw core::file_error(path.string(), "shape model is empty");
    model.shape = std::move(shape.pca);
    model.triangles = std::move(shape.triangles);

    EosPca colour = read_pca(in, "colour model");
    if (!colour.pca.empty()) model.albedo = std::move(colour.pca);

    if (version >= 2 && read_optional_present(in, "expression model flag")) {
        const auto index = in.read<std::int32_t>("expression model kind");
        if (index == 0) model.expression = read_pca(in, "expression model").pca;
        else if (index == 1) model.expression = read_blendshape_vector(in);
        else throw in.error("expression model kind " + std::to_string(index) + " is neither PCA (0) nor blendshapes (1)");
    }
    if (version >= 3 && read_optional_present(in, "landmark definitions flag")) {
        const std::size_t count = in.read_count(8 + 4, "landmark definition count");
        for (std::size_t i = 0; i < count; ++i) {
            const std::string name = in.read_string("landmark name");
            const auto vertex = in.read<std::int32_t>("landmark vertex");
            // Only iBUG ids ("1".."68") map onto our landmark list; other names are kept out.
            try {
                std::size_t used = 0;
                const int id = std::stoi(name, &used);
                if (used == name.size() && id >= 1 && id <= kNumIbugLandmarks && vertex >= 0) result.landmarks[id] = vertex;
            } catch (const std::exception&) {
            }
        }
    }

    const std::size_t uv_count = in.read_count(2 * sizeof(double), "texture coordinate count");
    if (uv_count) {
        std::vector<double> uv(2 * uv_count);
        in.read_bytes(uv.data(), uv.size() * sizeof(double), "texture coordinates");
        model.uv.resize(2, static_cast<Eigen::Index>(uv_count));
        for (std::size_t i = 0; i < uv_count; ++i) {
            if (!std::isfinite(uv[2 * i]) || !std::isfinite(uv[2 * i + 1]))
                throw core::file_error(path.string(), "texture coordinate " + std::to_string(i) + " is not finite");
            model.uv(0, static_cast<Eigen::Index>(i)) = static_cast<float>(uv[2 * i]);
            model.uv(1, static_cast<Eigen::Index>(i)) = static_cast<float>(uv[2 * i + 1]);
        }
    }
    // Version 4's separate texture triangulation: our models use per-vertex uv only, so it is
    // checked for size and skipped.
    if (version >= 4) (void)read_triangles(in, "texture triangle list");
    if (!in.at_end())
        throw core::file_error(path.string(), std::to_string(in.remaining()) + " unexpected bytes after the model (version " +
                                            std::to_string(version) + " ends at byte " + std::to_string(in.offset()) + ")");
    model.validate(path.string());
    return result;
}

std::vector<Blendshape> read_eos_blendshapes(const std::filesystem::path& path, long expected_values) {
    const std::string bytes = core::read_file(path);
    if (bytes.empty()) throw core::file_error(path.string(), "empty file (expected eos blendshapes)");
    core::ByteReader in(bytes, path.string());
    std::vector<Blendshape> shapes = read_blendshape_vector(in);
    if (!in.at_end()) throw core::file_error(path.string(), std::to_string(in.remaining()) + " unexpected bytes after the blendshapes");
    if (shapes.empty()) throw core::file_error(path.string(), "contains no blendshapes");
    for (const auto& b : shapes)
        if (expected_values > 0 && b.offsets.size() != expected_values)
            throw core::file_error(path.string(), "blendshape '" + b.name + "' has " + std::to_string(b.offsets.size()) +
                                                " values, the model needs " + std::to_string(expected_values));
    return shapes;
}

LandmarkMapping read_landmark_mapping(const std::filesystem::path& path) {
    const std::string text = core::read_file(path);
    if (text.empty()) throw core::file_error(path.string(), "empty landmark mapping file");
    const toml::value root = core::parse_toml(text, path.string());
    try {
        return mapping_from_toml(root, path.string());
    } catch (const toml::exception& e) {
        throw core::file_error(path.string(), std::string("TOML error: ") + e.what());
    }
}

ContourChains read_model_contours(const std::filesystem::path& path) {
    const std::string text = core::read_file(path);
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        throw core::file_error(path.string(), std::string("JSON error: ") + e.what());
    }
    ContourChains chains;
    const auto read_chain = [&](const char* key, std::vector<int>& out) {
        if (!json.is_object() || !json.contains("model_contour") || !json["model_contour"].is_object() ||
            !json["model_contour"].contains(key) || !json["model_contour"][key].is_array())
            throw core::file_error(path.string(), std::string("missing array model_contour.") + key);
        for (const auto& id : json["model_contour"][key]) {
            if (!id.is_number_integer() || id.get<long long>() < 0 || id.get<long long>() > std::numeric_limits<int>::max())
                throw core::file_error(path.string(), std::string("model_contour.") + key + " holds a value that is not a vertex id");
            out.push_back(id.get<int>());
        }
    };
    read_chain("right_contour", chains.right);
    read_chain("left_contour", chains.left);
    return chains;
}

std::vector<int> read_symmetry(const std::filesystem::path& path, int num_vertices) {
    const std::string text = core::read_file(path);
    if (text.empty()) throw core::file_error(path.string(), "empty symmetry file");
    std::vector<int> symmetry(static_cast<std::size_t>(num_vertices), -1);
    std::istringstream lines(text);
    std::string line;
    int vertex = 0;
    while (std::getline(lines, line)) {
        std::istringstream fields(line);
        long mirror = 0;
        if (!(fields >> mirror)) {
            if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank line
            throw core::file_error(path.string(), "line " + std::to_string(vertex + 1) + ": expected a vertex id");
        }
        if (vertex >= num_vertices)
            throw core::file_error(path.string(), "more lines than the model's " + std::to_string(num_vertices) + " vertices");
        if (mirror < 1 || mirror > num_vertices)
            throw core::file_error(path.string(), "line " + std::to_string(vertex + 1) + ": mirror vertex " + std::to_string(mirror) +
                                                " outside 1.." + std::to_string(num_vertices));
        symmetry[static_cast<std::size_t>(vertex)] = static_cast<int>(mirror - 1);  // the file is 1-based
        ++vertex;
    }
    if (vertex == 0) throw core::file_error(path.string(), "no symmetry entries");
    return symmetry;
}

LandmarkCompletion parse_landmark_completion(const std::string& toml_text, const std::string& source_name) {
    const toml::value root = core::parse_toml(toml_text, source_name);
    try {
        LandmarkCompletion completion;
        completion.model_vertices = toml::find<int>(root, "model_vertices");
        completion.model_triangles = toml::find<int>(root, "model_triangles");
        completion.mapping = mapping_from_toml(root, source_name);
        for (const auto& [id, vertex] : completion.mapping)
            if (vertex >= completion.model_vertices)
                throw core::file_error(source_name, "landmark " + std::to_string(id) + " vertex " + std::to_string(vertex) +
                                                  " outside the model's " + std::to_string(completion.model_vertices));
        return completion;
    } catch (const toml::exception& e) {
        throw core::file_error(source_name, std::string("TOML error: ") + e.what());
    } catch (const std::out_of_range& e) {  // toml::find's answer to a missing key
        throw core::file_error(source_name, std::string("missing key: ") + e.what());
    }
}

const LandmarkCompletion& sfm_landmark_completion() {
    static const LandmarkCompletion completion =
        parse_landmark_completion(kSfmLandmarkCompletionToml, "data/sfm_landmarks_completion.toml");
    return completion;
}

bool completion_applies(const LandmarkCompletion& completion, const MorphableModel& model) {
    return model.num_vertices() == completion.model_vertices &&
           static_cast<int>(model.triangles.size()) == completion.model_triangles;
}

std::vector<SurfacePoint> ibug68_from_mapping(const LandmarkMapping& mapping, const std::string& context) {
    std::vector<SurfacePoint> points;
    std::string missing;
    for (int id = 1; id <= kNumIbugLandmarks; ++id) {
        const auto it = mapping.find(id);
        if (it == mapping.end()) {
            if (!missing.empty()) missing += ',';
            missing += std::to_string(id);
            continue;
        }
        points.push_back(SurfacePoint::at_vertex(it->second));
    }
    if (!missing.empty()) throw core::Error(context + ": no vertex for iBUG landmarks " + missing);
    return points;
}

}  // namespace facesynth::morph
