#include "morph/mesh_io.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace facesynth::morph {
namespace {

constexpr int kArrayBuffer = 34962;         // GL_ARRAY_BUFFER
constexpr int kElementArrayBuffer = 34963;  // GL_ELEMENT_ARRAY_BUFFER

std::string lower_extension(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

void check_mesh(const Mesh& mesh, const std::filesystem::path& path) {
    const std::string name = path.string();
    if (mesh.num_vertices() == 0) throw core::file_error(name, "cannot write a mesh without vertices");
    if (!mesh.vertices.allFinite()) throw core::file_error(name, "mesh vertices contain NaN");
    for (const auto& t : mesh.triangles)
        for (int v : t)
            if (v < 0 || v >= mesh.num_vertices()) throw core::file_error(name, "triangle refers to vertex " + std::to_string(v));
    if (mesh.colours.cols() != 0 && mesh.colours.cols() != mesh.vertices.cols())
        throw core::file_error(name, "mesh has " + std::to_string(mesh.colours.cols()) + " colours for " +
                                   std::to_string(mesh.num_vertices()) + " vertices");
    if (mesh.uv.cols() != 0 && mesh.uv.cols() != mesh.vertices.cols())
        throw core::file_error(name, "mesh has " + std::to_string(mesh.uv.cols()) + " uv pairs for " +
                                   std::to_string(mesh.num_vertices()) + " vertices");
}

// Appends raw bytes to the buffer (4-byte aligned) with a buffer view; returns the view index.
int add_view(tinygltf::Model& model, const void* data, std::size_t size, int target) {
    auto& buffer = model.buffers[0].data;
    buffer.resize((buffer.size() + 3) & ~std::size_t{3}, 0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buffer.size();
    view.byteLength = size;
    view.target = target;
    const auto* bytes = static_cast<const unsigned char*>(data);
    buffer.insert(buffer.end(), bytes, bytes + size);
    model.bufferViews.push_back(view);
    return static_cast<int>(model.bufferViews.size() - 1);
}

// A float attribute accessor over a column-major matrix (one column per vertex).
int add_float_accessor(tinygltf::Model& model, const Eigen::MatrixXf& columns, int type, bool with_bounds) {
    tinygltf::Accessor accessor;
    accessor.bufferView = add_view(model, columns.data(), sizeof(float) * static_cast<std::size_t>(columns.size()), kArrayBuffer);
    accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    accessor.count = static_cast<std::size_t>(columns.cols());
    accessor.type = type;
    if (with_bounds) {
        const Eigen::VectorXf lo = columns.rowwise().minCoeff(), hi = columns.rowwise().maxCoeff();
        accessor.minValues.assign(lo.data(), lo.data() + lo.size());
        accessor.maxValues.assign(hi.data(), hi.data() + hi.size());
    }
    model.accessors.push_back(accessor);
    return static_cast<int>(model.accessors.size() - 1);
}

// --- glTF reading -------------------------------------------------------------------------------

// Element `i`, component `c` of an accessor as a double, after a bounds check done by the caller.
double accessor_value(const tinygltf::Model& model, const tinygltf::Accessor& accessor, std::size_t i, int c) {
    const auto& view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
    const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(accessor.componentType));
    const int components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
    const std::size_t stride = view.byteStride ? view.byteStride : static_cast<std::size_t>(component_size * components);
    const unsigned char* p = model.buffers[static_cast<std::size_t>(view.buffer)].data.data() + view.byteOffset +
                             accessor.byteOffset + i * stride + static_cast<std::size_t>(c * component_size);
    switch (accessor.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: { float v; std::memcpy(&v, p, 4); return v; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t v; std::memcpy(&v, p, 2); return accessor.normalized ? v / 65535.0 : v; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return accessor.normalized ? *p / 255.0 : *p;
        default: return std::nan("");
    }
}

const tinygltf::Accessor& checked_accessor(const tinygltf::Model& model, int index, const std::string& file,
                                           const char* what) {
    if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size())
        throw core::file_error(file, std::string(what) + ": accessor " + std::to_string(index) + " does not exist");
    const auto& accessor = model.accessors[static_cast<std::size_t>(index)];
    if (accessor.sparse.isSparse) throw core::file_error(file, std::string(what) + ": sparse accessors are not supported");
    if (accessor.bufferView < 0 || static_cast<std::size_t>(accessor.bufferView) >= model.bufferViews.size())
        throw core::file_error(file, std::string(what) + ": accessor has no valid buffer view");
    const auto& view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model.buffers.size())
        throw core::file_error(file, std::string(what) + ": buffer view has no valid buffer");
    const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(accessor.componentType));
    const int components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
    if (component_size <= 0 || components <= 0) throw core::file_error(file, std::string(what) + ": unknown component type");
    const std::size_t element = static_cast<std::size_t>(component_size) * static_cast<std::size_t>(components);
    const std::size_t stride = view.byteStride ? view.byteStride : element;
    const std::size_t buffer_size = model.buffers[static_cast<std::size_t>(view.buffer)].data.size();
    if (accessor.count > 0 &&
        (view.byteOffset + view.byteLength > buffer_size ||
         accessor.byteOffset + (accessor.count - 1) * stride + element > view.byteLength))
        throw core::file_error(file, std::string(what) + ": accessor reaches past the end of its buffer");
    return accessor;
}

Mesh read_gltf(const std::filesystem::path& path) {
    const std::string name = path.string();
    const std::string bytes = core::read_file(path);
    if (bytes.empty()) throw core::file_error(name, "empty file (expected glTF)");
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err, warn;
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
    const std::string base_dir = path.parent_path().string();
    const bool ok = lower_extension(path) == ".glb"
                        ? loader.LoadBinaryFromMemory(&model, &err, &warn, data, static_cast<unsigned int>(bytes.size()), base_dir)
                        : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()), base_dir);
    if (!ok) throw core::file_error(name, "invalid glTF: " + (err.empty() ? std::string("unknown error") : err));
    if (model.meshes.empty() || model.meshes[0].primitives.empty()) throw core::file_error(name, "glTF has no mesh");
    const auto& primitive = model.meshes[0].primitives[0];
    if (primitive.mode != TINYGLTF_MODE_TRIANGLES && primitive.mode != -1)
        throw core::file_error(name, "glTF primitive is not a triangle list");
    const auto position = primitive.attributes.find("POSITION");
    if (position == primitive.attributes.end()) throw core::file_error(name, "glTF primitive has no POSITION");
    const auto& positions = checked_accessor(model, position->second, name, "POSITION");
    if (positions.type != TINYGLTF_TYPE_VEC3 || positions.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
        throw core::file_error(name, "POSITION must be float VEC3");

    Mesh mesh;
    const auto count = static_cast<Eigen::Index>(positions.count);
    mesh.vertices.resize(3, count);
    for (Eigen::Index i = 0; i < count; ++i)
        for (int c = 0; c < 3; ++c) mesh.vertices(c, i) = static_cast<float>(accessor_value(model, positions, static_cast<std::size_t>(i), c));
    if (!mesh.vertices.allFinite()) throw core::file_error(name, "POSITION contains NaN");

    if (primitive.indices >= 0) {
        const auto& indices = checked_accessor(model, primitive.indices, name, "indices");
        if (indices.count % 3 != 0) throw core::file_error(name, "index count " + std::to_string(indices.count) + " is not a multiple of 3");
        mesh.triangles.resize(indices.count / 3);
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const double id = accessor_value(model, indices, 3 * t + static_cast<std::size_t>(k), 0);
                if (!(id >= 0 && id < static_cast<double>(count)))
                    throw core::file_error(name, "triangle " + std::to_string(t) + " refers to a vertex that does not exist");
                mesh.triangles[t][static_cast<std::size_t>(k)] = static_cast<int>(id);
            }
    } else {
        if (count % 3 != 0) throw core::file_error(name, "non-indexed triangle list with a vertex count not divisible by 3");
        for (int i = 0; i + 2 < count; i += 3) mesh.triangles.push_back({i, i + 1, i + 2});
    }

    const auto read_attribute = [&](const char* attribute, int rows, Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic>& out) {
        const auto it = primitive.attributes.find(attribute);
        if (it == primitive.attributes.end()) return;
        const auto& accessor = checked_accessor(model, it->second, name, attribute);
        if (static_cast<Eigen::Index>(accessor.count) != count) throw core::file_error(name, std::string(attribute) + " count differs from POSITION");
        out.resize(rows, count);
        for (Eigen::Index i = 0; i < count; ++i)
            for (int c = 0; c < rows; ++c) out(c, i) = static_cast<float>(accessor_value(model, accessor, static_cast<std::size_t>(i), c));
        if (!out.allFinite()) throw core::file_error(name, std::string(attribute) + " holds values this reader cannot convert");
    };
    Eigen::MatrixXf uv, colours;
    read_attribute("TEXCOORD_0", 2, uv);
    read_attribute("COLOR_0", 3, colours);
    mesh.uv = uv;
    mesh.colours = colours;
    return mesh;
}

// --- OBJ reading --------------------------------------------------------------------------------

// An OBJ index (1-based, or negative = relative to the end) as 0-based; -1 when absent.
int obj_index(const std::string& token, std::size_t count, const std::string& file, int line) {
    if (token.empty()) return -1;
    long value = 0;
    try {
        value = std::stol(token);
    } catch (const std::exception&) {
        throw core::file_error(file, "line " + std::to_string(line) + ": bad index '" + token + "'");
    }
    const long resolved = value < 0 ? static_cast<long>(count) + value : value - 1;
    if (value == 0 || resolved < 0 || resolved >= static_cast<long>(count))
        throw core::file_error(file, "line " + std::to_string(line) + ": index " + token + " out of range");
    return static_cast<int>(resolved);
}

Mesh read_obj(const std::filesystem::path& path) {
    const std::string name = path.string();
    const std::string text = core::read_file(path);
    std::vector<Eigen::Vector3f> positions, colours;
    std::vector<Eigen::Vector2f> texcoords;
    std::vector<Triangle> triangles;
    bool uv_per_vertex = true;  // every face corner uses vt index == v index
    bool any_uv = false;
    std::istringstream lines(text);
    std::string line;
    int line_number = 0;
    while (std::getline(lines, line)) {
        ++line_number;
        std::istringstream fields(line);
        std::string keyword;
        if (!(fields >> keyword) || keyword[0] == '#') continue;
        if (keyword == "v") {
            std::vector<float> values;
            float x = 0;
            while (fields >> x) values.push_back(x);
            if (values.size() != 3 && values.size() != 6)
                throw core::file_error(name, "line " + std::to_string(line_number) + ": 'v' needs x y z [r g b]");
            for (float value : values)
                if (!std::isfinite(value)) throw core::file_error(name, "line " + std::to_string(line_number) + ": value is not finite");
            positions.emplace_back(values[0], values[1], values[2]);
            if (values.size() == 6) colours.emplace_back(values[3], values[4], values[5]);
        } else if (keyword == "vt") {
            float u = 0, v = 0;
            if (!(fields >> u >> v)) throw core::file_error(name, "line " + std::to_string(line_number) + ": 'vt' needs u v");
            texcoords.emplace_back(u, 1.0f - v);  // OBJ's v points up; ours has v = 0 at the top
        } else if (keyword == "f") {
            std::vector<int> corners;
            std::string corner;
            while (fields >> corner) {
                const auto slash = corner.find('/');
                const int v = obj_index(corner.substr(0, slash), positions.size(), name, line_number);
                if (slash != std::string::npos) {
                    const auto slash2 = corner.find('/', slash + 1);
                    const int vt = obj_index(corner.substr(slash + 1, slash2 == std::string::npos ? std::string::npos : slash2 - slash - 1),
                                             texcoords.size(), name, line_number);
                    if (vt >= 0) any_uv = true;
                    if (vt != v) uv_per_vertex = false;
                } else {
                    uv_per_vertex = false;
                }
                corners.push_back(v);
            }
            if (corners.size() < 3) throw core::file_error(name, "line " + std::to_string(line_number) + ": face with fewer than 3 corners");
            for (std::size_t k = 1; k + 1 < corners.size(); ++k) triangles.push_back({corners[0], corners[k], corners[k + 1]});
        }
    }
    if (positions.empty()) throw core::file_error(name, "no vertices (not an OBJ mesh?)");
    Mesh mesh;
    mesh.vertices.resize(3, static_cast<Eigen::Index>(positions.size()));
    for (std::size_t i = 0; i < positions.size(); ++i) mesh.vertices.col(static_cast<Eigen::Index>(i)) = positions[i];
    mesh.triangles = std::move(triangles);
    if (colours.size() == positions.size()) {
        mesh.colours.resize(3, static_cast<Eigen::Index>(colours.size()));
        for (std::size_t i = 0; i < colours.size(); ++i) mesh.colours.col(static_cast<Eigen::Index>(i)) = colours[i];
    }
    if (any_uv && uv_per_vertex && texcoords.size() == positions.size()) {
        mesh.uv.resize(2, static_cast<Eigen::Index>(texcoords.size()));
        for (std::size_t i = 0; i < texcoords.size(); ++i) mesh.uv.col(static_cast<Eigen::Index>(i)) = texcoords[i];
    }
    return mesh;
}

}  // namespace

void write_obj(const Mesh& mesh, const std::filesystem::path& path) {
    check_mesh(mesh, path);
    const Eigen::Matrix3Xf normals = vertex_normals(mesh.vertices, mesh.triangles);
    const bool has_colours = mesh.colours.cols() > 0, has_uv = mesh.uv.cols() > 0;
    std::ostringstream out;
    out.precision(7);
    out << "# facesynth mesh: " << mesh.num_vertices() << " vertices, " << mesh.num_triangles() << " triangles (mm)\n";
    for (int i = 0; i < mesh.num_vertices(); ++i) {
        out << "v " << mesh.vertices(0, i) << ' ' << mesh.vertices(1, i) << ' ' << mesh.vertices(2, i);
        if (has_colours) out << ' ' << mesh.colours(0, i) << ' ' << mesh.colours(1, i) << ' ' << mesh.colours(2, i);
        out << '\n';
    }
    if (has_uv)
        for (int i = 0; i < mesh.num_vertices(); ++i) out << "vt " << mesh.uv(0, i) << ' ' << 1.0f - mesh.uv(1, i) << '\n';
    for (int i = 0; i < mesh.num_vertices(); ++i)
        out << "vn " << normals(0, i) << ' ' << normals(1, i) << ' ' << normals(2, i) << '\n';
    for (const auto& t : mesh.triangles) {
        out << 'f';
        for (int v : t) {
            const int id = v + 1;
            if (has_uv) out << ' ' << id << '/' << id << '/' << id;
            else out << ' ' << id << "//" << id;
        }
        out << '\n';
    }
    core::write_file_atomically(path, out.str());
}

void write_glb(const Mesh& mesh, const std::filesystem::path& path, std::span<const std::uint8_t> png_texture) {
    check_mesh(mesh, path);
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "facesynth";
    model.buffers.emplace_back();

    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = add_float_accessor(model, mesh.vertices, TINYGLTF_TYPE_VEC3, true);
    primitive.attributes["NORMAL"] =
        add_float_accessor(model, vertex_normals(mesh.vertices, mesh.triangles), TINYGLTF_TYPE_VEC3, false);
    if (mesh.uv.cols() > 0) primitive.attributes["TEXCOORD_0"] = add_float_accessor(model, mesh.uv, TINYGLTF_TYPE_VEC2, false);
    if (mesh.colours.cols() > 0)
        primitive.attributes["COLOR_0"] = add_float_accessor(model, mesh.colours.cwiseMax(0.0f).cwiseMin(1.0f), TINYGLTF_TYPE_VEC3, false);

    std::vector<std::uint32_t> indices;
    indices.reserve(3 * mesh.triangles.size());
    for (const auto& t : mesh.triangles)
        for (int v : t) indices.push_back(static_cast<std::uint32_t>(v));
    tinygltf::Accessor index_accessor;
    index_accessor.bufferView = add_view(model, indices.data(), indices.size() * sizeof(std::uint32_t), kElementArrayBuffer);
    index_accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    index_accessor.count = indices.size();
    index_accessor.type = TINYGLTF_TYPE_SCALAR;
    model.accessors.push_back(index_accessor);
    primitive.indices = static_cast<int>(model.accessors.size() - 1);

    tinygltf::Material material;
    material.name = "face";
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 0.8;
    if (!png_texture.empty()) {
        if (mesh.uv.cols() == 0) throw core::file_error(path.string(), "a texture needs texture coordinates, the mesh has none");
        tinygltf::Image image;
        image.mimeType = "image/png";
        image.bufferView = add_view(model, png_texture.data(), png_texture.size(), 0);
        model.images.push_back(image);
        tinygltf::Sampler sampler;
        sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
        sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
        sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
        sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
        model.samplers.push_back(sampler);
        tinygltf::Texture texture;
        texture.source = 0;
        texture.sampler = 0;
        model.textures.push_back(texture);
        material.pbrMetallicRoughness.baseColorTexture.index = 0;
    }
    model.materials.push_back(material);
    primitive.material = 0;

    tinygltf::Mesh gltf_mesh;
    gltf_mesh.name = "face";
    gltf_mesh.primitives.push_back(primitive);
    model.meshes.push_back(gltf_mesh);
    tinygltf::Node node;
    node.mesh = 0;
    model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.nodes.push_back(0);
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    model.buffers[0].data.resize((model.buffers[0].data.size() + 3) & ~std::size_t{3}, 0);

    std::ostringstream stream;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, stream, false, true)) throw core::file_error(path.string(), "glTF serialisation failed");
    core::write_file_atomically(path, stream.str());
}

bool is_mesh_file(const std::filesystem::path& path) {
    const std::string ext = lower_extension(path);
    return ext == ".obj" || ext == ".gltf" || ext == ".glb";
}

Mesh read_mesh(const std::filesystem::path& path) {
    const std::string ext = lower_extension(path);
    if (ext == ".obj") return read_obj(path);
    if (ext == ".gltf" || ext == ".glb") return read_gltf(path);
    throw core::file_error(path.string(), "unknown mesh format (expected .obj, .gltf or .glb)");
}

}  // namespace facesynth::morph
