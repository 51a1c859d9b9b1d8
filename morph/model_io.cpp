#include "morph/model_io.h"

#include "core/atomic_file.h"
#include "morph/bfm_io.h"
#include "morph/builtin.h"
#include "core/byte_io.h"
#include "morph/eos_io.h"
#include "core/error.h"
#include "morph/landmarks.h"
#include "morph/region_labels.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <functional>
#include <optional>

namespace facesynth::morph {
namespace {

// .fsm layout (docs/model-format.md): magic, uint32 version, uint32 section count, 16-character
// model checksum, sections (uint32 tag, uint64 size, payload), uint64 FNV-1a of all bytes before it.
constexpr std::array<char, 8> kMagic = {'\x89', 'F', 'S', 'M', '\r', '\n', '\x1a', '\n'};
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::size_t kHeaderSize = 8 + 4 + 4 + 16;

constexpr std::uint32_t tag(const char (&name)[5]) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(name[0])) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[1])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[2])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[3])) << 24;
}
constexpr std::uint32_t kName = tag("NAME"), kShape = tag("SHAP"), kExpressionPca = tag("EXPP"),
                        kBlendshapes = tag("EXPB"), kAlbedo = tag("ALBD"), kTriangles = tag("TRIS"),
                        kUv = tag("UVCO"), kLandmarks = tag("LMKS"), kContour = tag("CONT"), kSymmetry = tag("SYMM"),
                        kLabels = tag("LABL");

std::string tag_name(std::uint32_t t) {
    std::string s(4, ' ');
    for (int i = 0; i < 4; ++i) {
        const char c = static_cast<char>((t >> (8 * i)) & 0xff);
        s[static_cast<std::size_t>(i)] = (c >= 32 && c < 127) ? c : '?';
    }
    return s;
}

std::uint64_t fnv1a(std::string_view bytes) {
    std::uint64_t hash = 14695981039346656037ull;
    for (unsigned char c : bytes) hash = (hash ^ c) * 1099511628211ull;
    return hash;
}

void write_pca(core::ByteWriter& out, const PcaModel& pca) {
    out.write(static_cast<std::uint32_t>(pca.num_vertices()));
    out.write(static_cast<std::uint32_t>(pca.num_components()));
    out.write_floats(pca.mean);
    out.write_floats(pca.basis);
    out.write_floats(pca.eigenvalues);
}

PcaModel read_pca(core::ByteReader& in) {
    const auto vertices = in.read<std::uint32_t>("vertex count");
    const auto components = in.read<std::uint32_t>("component count");
    const std::uint64_t rows = 3ull * vertices;
    in.check_fits(rows, sizeof(float), "PCA mean");
    in.check_fits(components, sizeof(float), "PCA eigenvalues");
    if (components != 0 && rows > in.remaining() / sizeof(float) / components)
        throw in.error("PCA basis " + std::to_string(rows) + " x " + std::to_string(components) +
                       " exceeds the bytes left in the file (truncated or corrupt)");
    PcaModel pca;
    pca.mean.resize(static_cast<Eigen::Index>(rows));
    pca.basis.resize(static_cast<Eigen::Index>(rows), components);
    pca.eigenvalues.resize(components);
    in.read_floats(pca.mean, "mean");
    in.read_floats(pca.basis, "basis");
    in.read_floats(pca.eigenvalues, "eigenvalues");
    return pca;
}

template <typename T>
void write_ints(core::ByteWriter& out, const std::vector<T>& values) {
    out.write(static_cast<std::uint32_t>(values.size()));
    out.write_bytes(values.data(), values.size() * sizeof(T));
}

template <typename T>
std::vector<T> read_ints(core::ByteReader& in, const char* what) {
    const auto count = in.read<std::uint32_t>(what);
    in.check_fits(count, sizeof(T), what);
    std::vector<T> values(count);
    in.read_bytes(values.data(), values.size() * sizeof(T), what);
    return values;
}

void add_section(core::ByteWriter& file, std::uint32_t section_tag, const core::ByteWriter& payload, std::uint32_t& count) {
    file.write(section_tag);
    file.write(static_cast<std::uint64_t>(payload.bytes().size()));
    file.write_bytes(payload.bytes().data(), payload.bytes().size());
    ++count;
}

std::string serialise(const MorphableModel& model) {
    core::ByteWriter file;
    file.write_bytes(kMagic.data(), kMagic.size());
    file.write(kFormatVersion);
    const std::size_t count_offset = file.bytes().size();
    file.write(std::uint32_t{0});
    const std::string checksum = model.checksum();
    file.write_bytes(checksum.data(), 16);

    std::uint32_t sections = 0;
    {
        core::ByteWriter s;
        s.write_bytes(model.name.data(), model.name.size());
        add_section(file, kName, s, sections);
    }
    {
        core::ByteWriter s;
        write_pca(s, model.shape);
        add_section(file, kShape, s, sections);
    }
    if (model.expression) {
        core::ByteWriter s;
        if (const auto* pca = std::get_if<PcaModel>(&*model.expression)) {
            write_pca(s, *pca);
            add_section(file, kExpressionPca, s, sections);
        } else {
            const auto& shapes = std::get<std::vector<Blendshape>>(*model.expression);
            s.write(static_cast<std::uint32_t>(shapes.size()));
            for (const auto& b : shapes) {
                s.write(static_cast<std::uint32_t>(b.name.size()));
                s.write_bytes(b.name.data(), b.name.size());
                s.write(static_cast<std::uint32_t>(b.offsets.size()));
                s.write_floats(b.offsets);
            }
            add_section(file, kBlendshapes, s, sections);
        }
    }
    if (model.albedo) {
        core::ByteWriter s;
        write_pca(s, *model.albedo);
        add_section(file, kAlbedo, s, sections);
    }
    {
        core::ByteWriter s;
        write_ints(s, model.triangles);
        add_section(file, kTriangles, s, sections);
    }
    if (model.uv.cols() > 0) {
        core::ByteWriter s;
        s.write(static_cast<std::uint32_t>(model.uv.cols()));
        s.write_floats(model.uv);
        add_section(file, kUv, s, sections);
    }
    if (!model.landmarks.empty()) {
        core::ByteWriter s;
        write_ints(s, model.landmarks);
        add_section(file, kLandmarks, s, sections);
    }
    if (!model.contour.right.empty() || !model.contour.left.empty()) {
        core::ByteWriter s;
        write_ints(s, model.contour.right);
        write_ints(s, model.contour.left);
        add_section(file, kContour, s, sections);
    }
    if (!model.symmetry.empty()) {
        core::ByteWriter s;
        write_ints(s, model.symmetry);
        add_section(file, kSymmetry, s, sections);
    }
    if (!model.vertex_labels.empty()) {
        core::ByteWriter s;
        s.write(static_cast<std::uint32_t>(model.vertex_labels.size()));
        s.write_bytes(model.vertex_labels.data(), model.vertex_labels.size());
        add_section(file, kLabels, s, sections);
    }
    std::memcpy(file.bytes().data() + count_offset, &sections, sizeof sections);
    file.write(fnv1a(file.bytes()));
    return std::move(file.bytes());
}

void read_section(MorphableModel& model, std::uint32_t section_tag, core::ByteReader& in) {
    if (section_tag == kName) {
        model.name.resize(in.remaining());
        in.read_bytes(model.name.data(), model.name.size(), "name");
    } else if (section_tag == kShape) {
        model.shape = read_pca(in);
    } else if (section_tag == kExpressionPca) {
        model.expression = read_pca(in);
    } else if (section_tag == kBlendshapes) {
        const auto count = in.read<std::uint32_t>("blendshape count");
        in.check_fits(count, 8, "blendshape count");
        std::vector<Blendshape> shapes(count);
        for (auto& b : shapes) {
            const auto name_size = in.read<std::uint32_t>("blendshape name length");
            in.check_fits(name_size, 1, "blendshape name");
            b.name.resize(name_size);
            in.read_bytes(b.name.data(), name_size, "blendshape name");
            const auto values = in.read<std::uint32_t>("blendshape size");
            in.check_fits(values, sizeof(float), "blendshape offsets");
            b.offsets.resize(values);
            in.read_floats(b.offsets, "blendshape offsets");
        }
        model.expression = std::move(shapes);
    } else if (section_tag == kAlbedo) {
        model.albedo = read_pca(in);
    } else if (section_tag == kTriangles) {
        model.triangles = read_ints<Triangle>(in, "triangles");
    } else if (section_tag == kUv) {
        const auto count = in.read<std::uint32_t>("uv count");
        in.check_fits(2ull * count, sizeof(float), "uv");
        model.uv.resize(2, count);
        in.read_floats(model.uv, "uv");
    } else if (section_tag == kLandmarks) {
        model.landmarks = read_ints<SurfacePoint>(in, "landmarks");
    } else if (section_tag == kContour) {
        model.contour.right = read_ints<int>(in, "right contour");
        model.contour.left = read_ints<int>(in, "left contour");
    } else if (section_tag == kSymmetry) {
        model.symmetry = read_ints<int>(in, "symmetry");
    } else if (section_tag == kLabels) {
        const auto count = in.read<std::uint32_t>("label count");
        in.check_fits(count, 1, "labels");
        model.vertex_labels.resize(count);
        in.read_bytes(model.vertex_labels.data(), count, "labels");
    } else {
        in.skip(in.remaining(), "unknown section");  // a later minor addition: ignored by this reader
        return;
    }
    if (!in.at_end()) throw in.error(std::to_string(in.remaining()) + " unexpected bytes at the end of the section");
}

bool has_extension(const std::filesystem::path& path, std::initializer_list<const char*> extensions) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return std::any_of(extensions.begin(), extensions.end(), [&](const char* e) { return ext == e; });
}

bool starts_with_bytes(const std::filesystem::path& path, std::string_view prefix) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    std::string head(prefix.size(), '\0');
    const std::size_t n = std::fread(head.data(), 1, head.size(), f);
    std::fclose(f);
    return n == prefix.size() && head == prefix;
}

constexpr std::string_view kHdf5Signature{"\x89HDF\r\n\x1a\n", 8};

MorphableModel load_model_file(const std::filesystem::path& path) {
    if (has_extension(path, {".fsm"}) || starts_with_bytes(path, {kMagic.data(), kMagic.size()})) return read_model(path);
    if (has_extension(path, {".h5", ".hdf5"}) || starts_with_bytes(path, kHdf5Signature)) return read_bfm2017(path);
    if (has_extension(path, {".bin"})) {
        EosModelFile eos = read_eos_model(path);
        if (eos.landmarks.size() == static_cast<std::size_t>(kNumIbugLandmarks))
            eos.model.landmarks = ibug68_from_mapping(eos.landmarks, path.string());
        return std::move(eos.model);
    }
    throw core::file_error(path.string(), "unknown model format (expected .fsm, .h5 or an eos .bin)");
}

// The single file in `dir` matching `accept`, or nothing; several matches are an error.
std::optional<std::filesystem::path> find_one(const std::filesystem::path& dir, const char* what,
                                              const std::function<bool(const std::filesystem::path&)>& accept) {
    std::vector<std::filesystem::path> found;
    for (const auto& entry : std::filesystem::directory_iterator(dir))
        if (entry.is_regular_file() && accept(entry.path())) found.push_back(entry.path());
    if (found.empty()) return std::nullopt;
    if (found.size() > 1) {
        std::sort(found.begin(), found.end());
        std::string names;
        for (const auto& p : found) {
            names += ' ';
            names += p.filename().string();
        }
        throw core::file_error(dir.string(), std::string("several ") + what + " files:" + names + " (keep one)");
    }
    return found.front();
}

bool name_contains(const std::filesystem::path& p, const char* part) {
    return p.filename().string().find(part) != std::string::npos;
}

MorphableModel load_model_folder(const std::filesystem::path& dir) {
    const auto model_path = find_one(dir, "model", [](const std::filesystem::path& p) {
        return has_extension(p, {".fsm", ".h5", ".hdf5"}) || (has_extension(p, {".bin"}) && !name_contains(p, "blendshape"));
    });
    if (!model_path) throw core::file_error(dir.string(), "no model file in the folder (expected .fsm, .h5 or an eos .bin)");

    MorphableModel model;
    LandmarkMapping mapping;
    if (has_extension(*model_path, {".bin"})) {
        EosModelFile eos = read_eos_model(*model_path);
        model = std::move(eos.model);
        mapping = std::move(eos.landmarks);
    } else {
        model = load_model_file(*model_path);
    }

    const auto blendshapes = find_one(dir, "blendshape", [](const std::filesystem::path& p) {
        return has_extension(p, {".bin"}) && name_contains(p, "blendshape");
    });
    if (blendshapes && !model.expression)
        model.expression = read_eos_blendshapes(*blendshapes, 3L * model.num_vertices());

    const auto mapping_file = find_one(dir, "landmark mapping", [](const std::filesystem::path& p) {
        return has_extension(p, {".txt", ".toml"}) && p.filename().string().rfind("ibug_to_", 0) == 0;
    });
    if (mapping_file)
        for (const auto& [id, vertex] : read_landmark_mapping(*mapping_file)) mapping[id] = vertex;
    if (!mapping.empty()) {
        const LandmarkCompletion& completion = sfm_landmark_completion();
        if (mapping.size() < static_cast<std::size_t>(kNumIbugLandmarks) && completion_applies(completion, model))
            for (const auto& [id, vertex] : completion.mapping) mapping.try_emplace(id, vertex);
        model.landmarks = ibug68_from_mapping(mapping, (mapping_file ? *mapping_file : *model_path).string());
    }

    const auto contours = find_one(dir, "contour", [](const std::filesystem::path& p) {
        return has_extension(p, {".json"}) && name_contains(p, "contour");
    });
    if (contours) model.contour = read_model_contours(*contours);
    const auto symmetry = find_one(dir, "symmetry", [](const std::filesystem::path& p) {
        return has_extension(p, {".txt"}) && name_contains(p, "symmetry");
    });
    if (symmetry) model.symmetry = read_symmetry(*symmetry, model.num_vertices());
    model.validate(dir.string());
    return model;
}

}  // namespace

void write_model(const MorphableModel& model, const std::filesystem::path& path) {
    model.validate(path.string());
    core::write_file_atomically(path, serialise(model));
}

MorphableModel read_model(const std::filesystem::path& path) { return parse_model(core::read_file(path), path.string()); }

MorphableModel parse_model(std::string_view bytes, const std::string& name) {
    if (bytes.empty()) throw core::file_error(name, "empty file (expected a facesynth .fsm model)");
    if (bytes.size() < kMagic.size() || bytes.compare(0, kMagic.size(), kMagic.data(), kMagic.size()) != 0)
        throw core::file_error(name, "not a facesynth model (wrong magic bytes)");
    core::ByteReader header(bytes, name);
    header.skip(kMagic.size(), "magic");
    const auto version = header.read<std::uint32_t>("format version");
    if (version != kFormatVersion)
        throw core::file_error(name, "unsupported .fsm format version " + std::to_string(version) + " (this build reads " +
                                   std::to_string(kFormatVersion) + ")");
    if (bytes.size() < kHeaderSize + sizeof(std::uint64_t)) throw core::file_error(name, "truncated (shorter than the header)");
    const std::string_view body(bytes.data(), bytes.size() - sizeof(std::uint64_t));
    std::uint64_t stored_hash = 0;
    std::memcpy(&stored_hash, bytes.data() + body.size(), sizeof stored_hash);
    if (stored_hash != fnv1a(body)) throw core::file_error(name, "file checksum mismatch (truncated or corrupt)");

    const auto sections = header.read<std::uint32_t>("section count");
    std::string checksum(16, '\0');
    header.read_bytes(checksum.data(), 16, "model checksum");
    core::ByteReader in(body, name);
    in.skip(kHeaderSize, "header");
    MorphableModel model;
    for (std::uint32_t i = 0; i < sections; ++i) {
        const auto section_tag = in.read<std::uint32_t>("section tag");
        const auto size = in.read<std::uint64_t>("section size");
        in.check_fits(size, 1, "section size");
        const std::size_t start = in.offset();
        core::ByteReader section(body.substr(start, static_cast<std::size_t>(size)), name + " section " + tag_name(section_tag));
        read_section(model, section_tag, section);
        in.skip(static_cast<std::size_t>(size), "section");
    }
    if (!in.at_end()) throw core::file_error(name, std::to_string(in.remaining()) + " bytes after the last section");
    if (model.shape.empty()) throw core::file_error(name, "no shape model section");
    model.validate(name);
    if (model.checksum() != checksum)
        throw core::file_error(name, "model checksum " + model.checksum() + " differs from the stored " + checksum);
    return model;
}

MorphableModel load_model(const std::string& spec) {
    if (spec == "builtin") return builtin_model();
    const std::filesystem::path path(spec);
    std::error_code ec;
    MorphableModel model;
    if (std::filesystem::is_directory(path, ec)) {
        model = load_model_folder(path);
    } else if (std::filesystem::exists(path, ec)) {
        model = load_model_file(path);
    } else {
        throw core::file_error(spec, "no such model file or folder (--model takes builtin, a model file or a folder)");
    }
    // Every reader's model without labels of its own (eos, Basel, an .fsm without LABL) gets them from
    // its landmarks, when it has the 68.
    if (model.vertex_labels.empty()) model.vertex_labels = derive_region_labels(model);
    return model;
}

}  // namespace facesynth::morph
