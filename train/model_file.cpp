#include "train/model_file.h"

#include "core/atomic_file.h"
#include "core/byte_io.h"
#include "core/error.h"
#include "train/hog.h"

#include <cmath>
#include <cstring>
#include <string_view>

namespace facesynth::train {

std::uint64_t fnv1a_64(std::string_view bytes) {
    std::uint64_t hash = 0xcbf29ce484222325ULL;
    for (unsigned char c : bytes) {
        hash ^= c;
        hash *= 0x100000001b3ULL;
    }
    return hash;
}

namespace {

constexpr char kSdmMagic[8] = {'F', 'S', 'Y', 'N', 'S', 'D', 'M', '\0'};

void write_doubles(core::ByteWriter& w, const double* values, std::size_t count) { w.write_bytes(values, count * sizeof(double)); }

void read_doubles(core::ByteReader& r, double* values, std::size_t count, const char* what) {
    r.read_bytes(values, count * sizeof(double), what);
    for (std::size_t i = 0; i < count; ++i)
        if (!std::isfinite(values[i])) throw r.error(std::string(what) + " contains NaN or infinite values");
}

void write_stage(core::ByteWriter& payload, const SdmModel& model, const SdmStage& stage, const std::filesystem::path& path) {
    const int outputs = 2 * model.num_landmarks;
    const int dims = model.feature_dims(stage.settings);
    const auto rank = stage.basis.cols();
    if (stage.basis.rows() != outputs || rank < 1 || rank > outputs || stage.weights.rows() != rank ||
        stage.weights.cols() != dims || stage.bias.size() != outputs)
        throw core::file_error(path.string(), "cannot write a model whose stage matrices do not match its header");
    payload.write(stage.settings.patch_relative);
    payload.write(static_cast<std::int32_t>(stage.settings.cell_size));
    payload.write(static_cast<std::int32_t>(stage.settings.jaw_features ? 1 : 0));
    payload.write(static_cast<std::int32_t>(rank));
    payload.write_floats(stage.basis);
    payload.write_floats(stage.weights);
    payload.write_floats(stage.bias);
}

SdmStage read_stage(core::ByteReader& r, const SdmModel& model, std::uint32_t version, const std::string& which) {
    const int outputs = 2 * model.num_landmarks;
    SdmStage stage;
    stage.settings.patch_relative = r.read<double>((which + " patch size").c_str());
    stage.settings.cell_size = r.read<std::int32_t>((which + " cell size").c_str());
    if (!(stage.settings.patch_relative > 0) || stage.settings.cell_size < 1 || stage.settings.cell_size > 64)
        throw r.error(which + " has invalid patch settings");
    if (version >= 2) {
        const auto jaw = r.read<std::int32_t>((which + " jaw features flag").c_str());
        if (jaw != 0 && jaw != 1) throw r.error(which + " has an invalid jaw features flag");
        stage.settings.jaw_features = jaw == 1;
    }
    const int dims = model.feature_dims(stage.settings);
    // Version 1 stored full-rank stages (2L x D weights, no basis).
    const int rank = version == 1 ? outputs : r.read<std::int32_t>((which + " rank").c_str());
    if (rank < 1 || rank > outputs) throw r.error(which + " has invalid rank " + std::to_string(rank));
    // The header's HOG cells and the rank set the matrix sizes: check them against the file before allocating.
    r.check_fits(static_cast<std::uint64_t>(rank) * static_cast<std::uint64_t>(dims + (version == 1 ? 0 : outputs)), sizeof(float),
                 (which + " weights").c_str());
    if (version == 1) {
        stage.basis = Eigen::MatrixXf::Identity(outputs, outputs);
    } else {
        stage.basis.resize(outputs, rank);
        r.read_floats(stage.basis, (which + " basis").c_str());
    }
    stage.weights.resize(rank, dims);
    r.read_floats(stage.weights, (which + " weights").c_str());
    stage.bias.resize(outputs);
    r.read_floats(stage.bias, (which + " bias").c_str());
    return stage;
}

}  // namespace

namespace {

constexpr char kEnsembleMagic[8] = {'F', 'S', 'Y', 'N', 'S', 'D', 'M', 'E'};
constexpr std::uint32_t kMaxEnsembleMembers = 64;

bool has_magic(std::string_view bytes, const char (&magic)[8]) {
    return bytes.size() >= sizeof(magic) && std::memcmp(bytes.data(), magic, sizeof(magic)) == 0;
}

// One model as the bytes of a model file; `path` names it in errors.
std::string sdm_model_bytes(const SdmModel& model, const std::filesystem::path& path) {
    core::ByteWriter payload;
    write_doubles(payload, model.mean_shape.data(), static_cast<std::size_t>(model.mean_shape.size()));
    const BoxStatistics& b = model.boxes;
    payload.write(static_cast<std::int32_t>(b.detector_matched));
    payload.write(static_cast<std::int32_t>(b.detector_missed));
    const double stats[] = {b.width_ratio_mean, b.width_ratio_std, b.offset_mean.x(), b.offset_mean.y(),
                            b.offset_std.x(), b.offset_std.y(), b.init_translation_std, b.init_scale_std,
                            b.init_rotation_std_deg};
    write_doubles(payload, stats, std::size(stats));
    payload.write(static_cast<std::uint32_t>(b.detector));
    payload.write(static_cast<std::uint32_t>(kFaceViews));
    for (std::size_t v = 0; v < kFaceViews; ++v) {
        const auto& view_mean = model.view_mean_shapes[v];
        if (view_mean.size() && (view_mean.rows() != 2 || view_mean.cols() != model.num_landmarks))
            throw core::file_error(path.string(), "cannot write a model whose view mean shape has the wrong size");
        payload.write(static_cast<std::int32_t>(b.view_matched[v]));
        payload.write(static_cast<std::int32_t>(model.view_faces[v]));
        payload.write(static_cast<std::int32_t>(view_mean.size() ? 1 : 0));
        if (view_mean.size()) write_doubles(payload, view_mean.data(), static_cast<std::size_t>(view_mean.size()));
    }
    for (const auto& stage : model.stages) write_stage(payload, model, stage, path);
    payload.write(static_cast<std::uint32_t>(model.profile ? 1 : 0));
    if (model.profile) {
        const ProfileCascade& profile = *model.profile;
        if (profile.stages.size() != model.stages.size() || profile.mean_shape.rows() != 2 ||
            profile.mean_shape.cols() != model.num_landmarks)
            throw core::file_error(path.string(), "cannot write a model whose profile cascade does not match its frontal one");
        payload.write(static_cast<std::int32_t>(profile.faces));
        const double spreads[] = {profile.init_translation_std, profile.init_scale_std, profile.init_rotation_std_deg};
        write_doubles(payload, spreads, std::size(spreads));
        write_doubles(payload, profile.mean_shape.data(), static_cast<std::size_t>(profile.mean_shape.size()));
        for (const auto& stage : profile.stages) write_stage(payload, model, stage, path);
    }
    payload.write(static_cast<std::uint32_t>(model.unit.kind));
    payload.write(model.unit.fixed_length);
    const auto write_realigned = [&](const std::vector<SdmStage>& realigned) {
        if (realigned.size() > model.stages.size())
            throw core::file_error(path.string(), "cannot write a model whose realigned cascade has more stages than its main one");
        payload.write(static_cast<std::uint32_t>(realigned.size()));
        for (const auto& stage : realigned) write_stage(payload, model, stage, path);
    };
    write_realigned(model.realigned_stages);
    if (model.profile) write_realigned(model.profile->realigned_stages);

    core::ByteWriter file;
    file.write_bytes(kSdmMagic, sizeof(kSdmMagic));
    file.write(kSdmModelVersion);
    file.write(static_cast<std::uint32_t>(model.num_landmarks));
    file.write(static_cast<std::uint32_t>(model.stages.size()));
    file.write(static_cast<std::uint32_t>(model.hog.cells));
    file.write(static_cast<std::uint32_t>(model.hog.orientations));
    file.write(static_cast<std::uint32_t>(model.hog.dims_per_cell()));
    file.write(static_cast<std::uint32_t>(kCanonicalCropSide));
    file.write(kCanonicalBoxWidth);
    file.write(model.training_checksum);
    file.write(model.training_faces);
    file.write(model.augment);
    file.write(static_cast<std::uint64_t>(payload.bytes().size()));
    file.write(fnv1a_64(payload.bytes()));
    file.bytes() += payload.bytes();
    return file.bytes();
}

// One model from the bytes of a model file; `path` names it in errors (for an ensemble's member, the
// file and the member).
SdmModel parse_sdm_model(std::string_view bytes, const std::string& path) {
    core::ByteReader r(bytes, path);
    if (!has_magic(bytes, kSdmMagic)) throw core::file_error(path, "not a facesynth SDM model (bad magic)");
    r.skip(sizeof(kSdmMagic), "magic");
    const auto version = r.read<std::uint32_t>("version");
    if (version < 1 || version > kSdmModelVersion)
        throw core::file_error(path, "unsupported SDM model version " + std::to_string(version) + " (this build reads 1 to " +
                                            std::to_string(kSdmModelVersion) + ")");
    SdmModel model;
    model.num_landmarks = static_cast<int>(r.read<std::uint32_t>("landmark count"));
    const auto stages = r.read<std::uint32_t>("stage count");
    model.hog.cells = static_cast<int>(r.read<std::uint32_t>("HOG cells"));
    const auto orientations = r.read<std::uint32_t>("HOG orientations");
    const auto dims_per_cell = r.read<std::uint32_t>("HOG dims per cell");
    const auto crop_side = r.read<std::uint32_t>("crop side");
    const auto box_width = r.read<double>("box width");
    if (model.num_landmarks != 68 || stages < 1 || stages > 16 || model.hog.cells < 1 || model.hog.cells > kMaxHogCells ||
        orientations < 1 || orientations > kMaxHogOrientations)
        throw core::file_error(path, "implausible header (landmarks " + std::to_string(model.num_landmarks) +
                                            ", stages " + std::to_string(stages) + ", HOG cells " +
                                            std::to_string(model.hog.cells) + ", HOG orientations " +
                                            std::to_string(orientations) + "): corrupt file");
    model.hog.orientations = static_cast<int>(orientations);
    if (dims_per_cell != static_cast<std::uint32_t>(model.hog.dims_per_cell()))
        throw core::file_error(path, "HOG values per cell " + std::to_string(dims_per_cell) + " do not match " +
                                         std::to_string(orientations) + " orientations (3·O + 4 = " +
                                         std::to_string(model.hog.dims_per_cell()) + "): corrupt file");
    if (crop_side != static_cast<std::uint32_t>(kCanonicalCropSide) || box_width != kCanonicalBoxWidth)
        throw core::file_error(path, "face frame differs from this build's; retrain the model");
    model.training_checksum = r.read<std::uint64_t>("training checksum");
    model.training_faces = r.read<std::uint32_t>("training faces");
    model.augment = r.read<std::uint32_t>("augment");
    const auto payload_size = r.read<std::uint64_t>("payload size");
    const auto payload_checksum = r.read<std::uint64_t>("payload checksum");
    if (payload_size != r.remaining())
        throw core::file_error(path, "payload is " + std::to_string(r.remaining()) + " bytes, header says " +
                                            std::to_string(payload_size) + " (truncated or corrupt)");
    if (fnv1a_64(std::string_view(bytes).substr(r.offset())) != payload_checksum)
        throw core::file_error(path, "payload checksum mismatch (corrupt file)");

    model.mean_shape.resize(2, model.num_landmarks);
    read_doubles(r, model.mean_shape.data(), static_cast<std::size_t>(model.mean_shape.size()), "mean shape");
    BoxStatistics& b = model.boxes;
    b.detector_matched = r.read<std::int32_t>("box statistics");
    b.detector_missed = r.read<std::int32_t>("box statistics");
    double stats[9];
    read_doubles(r, stats, 9, "box statistics");
    b.width_ratio_mean = stats[0];
    b.width_ratio_std = stats[1];
    b.offset_mean = {stats[2], stats[3]};
    b.offset_std = {stats[4], stats[5]};
    b.init_translation_std = stats[6];
    b.init_scale_std = stats[7];
    b.init_rotation_std_deg = stats[8];
    if (version >= 3) {
        const auto detector = r.read<std::uint32_t>("face detector");
        if (detector > static_cast<std::uint32_t>(kLastDetectorKind))
            throw r.error("unknown face detector " + std::to_string(detector) + " (corrupt file or a newer build's model)");
        b.detector = static_cast<DetectorKind>(detector);
        const auto views = r.read<std::uint32_t>("view count");
        if (views != static_cast<std::uint32_t>(kFaceViews))
            throw r.error("has " + std::to_string(views) + " detector views, this build knows " + std::to_string(kFaceViews));
        for (std::size_t v = 0; v < kFaceViews; ++v) {
            b.view_matched[v] = r.read<std::int32_t>("view statistics");
            model.view_faces[v] = r.read<std::int32_t>("view statistics");
            const auto has_mean = r.read<std::int32_t>("view mean shape flag");
            if (has_mean != 0 && has_mean != 1) throw r.error("invalid view mean shape flag for view " + std::string(view_name(static_cast<FaceView>(v))));
            if (has_mean) {
                model.view_mean_shapes[v].resize(2, model.num_landmarks);
                read_doubles(r, model.view_mean_shapes[v].data(), static_cast<std::size_t>(model.view_mean_shapes[v].size()),
                             "view mean shape");
            }
        }
    } else {
        b.view_matched[0] = b.detector_matched;  // the frontal cascade was the only detector
    }
    for (std::uint32_t k = 0; k < stages; ++k) model.stages.push_back(read_stage(r, model, version, "stage " + std::to_string(k + 1)));
    if (version >= 4) {
        const auto has_profile = r.read<std::uint32_t>("profile cascade flag");
        if (has_profile > 1) throw r.error("invalid profile cascade flag " + std::to_string(has_profile));
        if (has_profile) {
            ProfileCascade profile;
            profile.faces = r.read<std::int32_t>("profile cascade faces");
            double spreads[3];
            read_doubles(r, spreads, 3, "profile cascade statistics");
            profile.init_translation_std = spreads[0];
            profile.init_scale_std = spreads[1];
            profile.init_rotation_std_deg = spreads[2];
            profile.mean_shape.resize(2, model.num_landmarks);
            read_doubles(r, profile.mean_shape.data(), static_cast<std::size_t>(profile.mean_shape.size()), "profile mean shape");
            for (std::uint32_t k = 0; k < stages; ++k)
                profile.stages.push_back(read_stage(r, model, version, "profile stage " + std::to_string(k + 1)));
            model.profile = std::move(profile);
        }
    }
    if (version >= 5) {
        const auto unit = r.read<std::uint32_t>("shape unit");
        if (unit > static_cast<std::uint32_t>(ShapeUnitKind::kFixed)) throw r.error("unknown shape unit " + std::to_string(unit));
        model.unit.kind = static_cast<ShapeUnitKind>(unit);
        model.unit.fixed_length = r.read<double>("shape unit length");
        if (model.unit.kind == ShapeUnitKind::kFixed && !(model.unit.fixed_length > 0 && model.unit.fixed_length < 1e4))
            throw r.error("implausible shape unit length " + std::to_string(model.unit.fixed_length));
    }
    if (version >= 6) {
        const auto read_realigned = [&](const std::string& which) {
            const auto count = r.read<std::uint32_t>((which + " stage count").c_str());
            if (count > stages) throw r.error(which + " has " + std::to_string(count) + " stages, more than the main cascade's " + std::to_string(stages));
            std::vector<SdmStage> realigned;
            for (std::uint32_t k = 0; k < count; ++k) realigned.push_back(read_stage(r, model, version, which + " stage " + std::to_string(k + 1)));
            return realigned;
        };
        model.realigned_stages = read_realigned("realigned cascade");
        if (model.profile) model.profile->realigned_stages = read_realigned("profile realigned cascade");
    }
    if (!r.at_end()) throw r.error("unexpected bytes after the last stage");
    return model;
}

std::string read_model_bytes(const std::filesystem::path& path) {
    if (!std::filesystem::exists(path)) throw core::file_error(path.string(), "model file not found");
    return core::read_file(path);
}

}  // namespace

void write_sdm_model(const std::filesystem::path& path, const SdmModel& model) {
    core::write_file_atomically(path, sdm_model_bytes(model, path));
}

SdmModel read_sdm_model(const std::filesystem::path& path) {
    const std::string bytes = read_model_bytes(path);
    if (has_magic(bytes, kEnsembleMagic))
        throw core::file_error(path.string(), "is an ensemble of SDM models (train merge); one model is needed here");
    return parse_sdm_model(bytes, path.string());
}

void write_sdm_ensemble(const std::filesystem::path& path, std::span<const SdmModel> members) {
    if (members.size() < 2 || members.size() > kMaxEnsembleMembers)
        throw core::file_error(path.string(), "an ensemble holds 2 to " + std::to_string(kMaxEnsembleMembers) + " models, got " +
                                                  std::to_string(members.size()));
    core::ByteWriter file;
    file.write_bytes(kEnsembleMagic, sizeof(kEnsembleMagic));
    file.write(kSdmEnsembleVersion);
    file.write(static_cast<std::uint32_t>(members.size()));
    for (const SdmModel& member : members) {
        if (member.boxes.detector != members.front().boxes.detector || member.num_landmarks != members.front().num_landmarks)
            throw core::file_error(path.string(), "cannot join models trained with different face detectors or landmark counts");
        const std::string bytes = sdm_model_bytes(member, path);
        file.write(static_cast<std::uint64_t>(bytes.size()));
        file.bytes() += bytes;
    }
    core::write_file_atomically(path, file.bytes());
}

std::vector<SdmModel> read_sdm_members(const std::filesystem::path& path) {
    const std::string bytes = read_model_bytes(path);
    if (!has_magic(bytes, kEnsembleMagic)) return {parse_sdm_model(bytes, path.string())};
    core::ByteReader r(bytes, path.string());
    r.skip(sizeof(kEnsembleMagic), "magic");
    const auto version = r.read<std::uint32_t>("ensemble version");
    if (version != kSdmEnsembleVersion)
        throw core::file_error(path.string(), "unsupported SDM ensemble version " + std::to_string(version) + " (this build reads " +
                                                  std::to_string(kSdmEnsembleVersion) + ")");
    const auto count = r.read<std::uint32_t>("member count");
    if (count < 2 || count > kMaxEnsembleMembers) throw r.error("implausible member count " + std::to_string(count) + ": corrupt file");
    std::vector<SdmModel> members;
    for (std::uint32_t m = 0; m < count; ++m) {
        const std::string which = "member " + std::to_string(m + 1);
        const auto size = r.read<std::uint64_t>((which + " size").c_str());
        r.check_fits(size, 1, (which + " bytes").c_str());
        members.push_back(parse_sdm_model(std::string_view(bytes).substr(r.offset(), size), path.string() + " (" + which + ")"));
        r.skip(size, (which + " bytes").c_str());
        if (members.back().boxes.detector != members.front().boxes.detector)
            throw r.error(which + " was trained with another face detector than member 1");
    }
    if (!r.at_end()) throw r.error("unexpected bytes after the last member");
    return members;
}

}  // namespace facesynth::train
