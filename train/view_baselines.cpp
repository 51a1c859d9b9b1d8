#include "train/view_baselines.h"

#include "core/atomic_file.h"
#include "core/byte_io.h"
#include "core/error.h"
#include "train/model_file.h"

#include <opencv2/core.hpp>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <unistd.h>

namespace facesynth::train {
namespace {

constexpr char kViewBaselinesMagic[8] = {'F', 'S', 'Y', 'N', 'V', 'W', 'B', '\0'};
constexpr std::uint32_t kBundleVersion = 1;

const char* method_name(BaselineMethod method) { return method == BaselineMethod::kErt ? "ERT" : "LBF"; }

// Removes a file on scope exit (a trainer's output once its bytes are read, or after a failure).
struct RemoveOnExit {
    std::filesystem::path path;
    ~RemoveOnExit() {
        std::error_code ignored;
        std::filesystem::remove(path, ignored);
    }
};

}  // namespace

void write_view_baseline_bundle(const std::filesystem::path& path, const ViewBaselineBundle& bundle) {
    core::ByteWriter body;
    body.write_string(detector_name(bundle.detector));
    body.write(static_cast<std::uint64_t>(bundle.frontal_model.size()));
    body.write(static_cast<std::uint64_t>(bundle.profile_model.size()));
    core::ByteWriter models;
    models.write_bytes(bundle.frontal_model.data(), bundle.frontal_model.size());
    models.write_bytes(bundle.profile_model.data(), bundle.profile_model.size());
    core::ByteWriter file;
    file.write_bytes(kViewBaselinesMagic, sizeof kViewBaselinesMagic);
    file.write(kBundleVersion);
    file.write(static_cast<std::uint32_t>(bundle.method));
    const std::string checked = body.bytes() + models.bytes();
    file.write(fnv1a_64(checked));
    file.write_bytes(checked.data(), checked.size());
    core::write_file_atomically(path, file.bytes());
}

bool is_view_baseline_bundle(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    char magic[sizeof kViewBaselinesMagic] = {};
    return in.read(magic, sizeof magic) && std::memcmp(magic, kViewBaselinesMagic, sizeof kViewBaselinesMagic) == 0;
}

ViewBaselineBundle read_view_baseline_bundle(const std::filesystem::path& path, BaselineMethod expected) {
    const std::string bytes = core::read_file(path);
    core::ByteReader r(bytes, path.string());
    char magic[sizeof kViewBaselinesMagic];
    r.read_bytes(magic, sizeof magic, "magic");
    if (std::memcmp(magic, kViewBaselinesMagic, sizeof kViewBaselinesMagic) != 0) throw core::file_error(path.string(), "not a view-specific baseline bundle");
    const auto version = r.read<std::uint32_t>("format version");
    if (version != kBundleVersion)
        throw core::file_error(path.string(), "view-specific baseline bundle version " + std::to_string(version) +
                                            ", this build reads version " + std::to_string(kBundleVersion));
    const auto method = r.read<std::uint32_t>("method");
    if (method != static_cast<std::uint32_t>(expected))
        throw core::file_error(path.string(), std::string("view-specific baseline bundle is not of method ") + method_name(expected) +
                                            " (method code " + std::to_string(method) + ")");
    const auto checksum = r.read<std::uint64_t>("checksum");
    if (fnv1a_64(std::string_view(bytes).substr(r.offset())) != checksum)
        throw core::file_error(path.string(), "checksum mismatch (truncated or corrupt file)");
    ViewBaselineBundle bundle;
    bundle.method = expected;
    const std::string detector = r.read_string("detector name");
    try {
        bundle.detector = parse_detector_kind(detector);
    } catch (const core::Error& e) {
        throw core::file_error(path.string(), e.what());
    }
    const auto frontal_size = r.read<std::uint64_t>("frontal model size");
    const auto profile_size = r.read<std::uint64_t>("profile model size");
    if (frontal_size == 0 || profile_size == 0 || frontal_size > r.remaining() || profile_size != r.remaining() - frontal_size)
        throw r.error("model sizes " + std::to_string(frontal_size) + " + " + std::to_string(profile_size) + " do not match the " +
                      std::to_string(r.remaining()) + " bytes left (truncated or corrupt)");
    bundle.frontal_model = bytes.substr(r.offset(), frontal_size);
    bundle.profile_model = bytes.substr(r.offset() + frontal_size);
    return bundle;
}

ViewBaselineBundle train_view_baselines(BaselineMethod method, DetectorKind detector, const ViewFaceSets& sets,
                                        const std::filesystem::path& out, const TrainBaselineFile& train_one) {
    ViewBaselineBundle bundle;
    bundle.method = method;
    bundle.detector = detector;
    const auto where = [&](const char* view, const std::vector<TrainingFace>& faces) {
        return std::string("view-specific ") + method_name(method) + ": the " + view + " model (" +
               std::to_string(faces.size()) + " faces)";
    };
    // Both views are checked before the first (long) training starts.
    if (sets.frontal.empty()) throw core::Error(where("frontal", sets.frontal) + ": no training faces");
    if (sets.profile.empty()) throw core::Error(where("profile", sets.profile) + ": no training faces");
    const auto train_view = [&](const char* view, const std::vector<TrainingFace>& faces) {
        RemoveOnExit part{core::temporary_path_for(out).concat(std::string(".") + view)};
        try {
            train_one(faces, part.path);
        } catch (const core::Error& e) {
            throw core::Error(where(view, faces) + ": " + e.what());
        }
        return core::read_file(part.path);
    };
    bundle.frontal_model = train_view("frontal", sets.frontal);
    bundle.profile_model = train_view("profile", sets.profile);
    return bundle;
}

Eigen::Matrix2Xd predict_by_view(const cv::Mat& crop, FaceView view, const CanonicalPredict& frontal,
                                 const CanonicalPredict& profile) {
    switch (view) {
        case FaceView::kFrontal: return frontal(crop);
        case FaceView::kNoseLeft: return profile(crop);
        case FaceView::kNoseRight: {
            cv::Mat flipped;
            cv::flip(crop, flipped, 1);
            return mirror_canonical_shape(profile(flipped));
        }
    }
    throw core::Error("predict_by_view: unknown face view");
}

ScopedTemporaryFile::ScopedTemporaryFile(const std::string& contents, const std::string& label) {
    std::string name = (std::filesystem::temp_directory_path() / "facesynth-model-XXXXXX").string();
    const int fd = ::mkstemp(name.data());
    if (fd < 0) throw core::file_error(label, std::string("cannot create a temporary file: ") + std::strerror(errno));
    path_ = name;
    std::size_t written = 0;
    while (written < contents.size()) {
        const ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int error = errno;
            ::close(fd);
            std::filesystem::remove(path_);
            throw core::file_error(label, std::string("cannot write a temporary file: ") + std::strerror(error));
        }
        written += static_cast<std::size_t>(n);
    }
    ::close(fd);
}

ScopedTemporaryFile::~ScopedTemporaryFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
}

}  // namespace facesynth::train
