// Writes the seed corpora of the fuzz harnesses: valid files made by facesynth's own writers and
// the test helpers (never the licensed data). Usage: make_seeds OUT_DIR; one folder per harness.
// The dataset meta seeds come from a 2-sample synth run on the toy model.
#include "common/model_files.h"
#include "common/toy_model.h"
#include "core/atomic_file.h"
#include "morph/landmarks.h"
#include "morph/model_io.h"
#include "synth/config.h"
#include "synth/dataset.h"
#include "train/model_file.h"
#include "train/hog.h"
#include "train/view_baselines.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using namespace facesynth;

namespace {

void put(const fs::path& dir, const std::string& name, const std::string& bytes) {
    fs::create_directories(dir);
    core::write_file_atomically(dir / name, bytes);
}

morph::MorphableModel small_toy(bool with_albedo) {
    testkit::ToyModelOptions o;
    o.shape_components = 3;
    o.latitude_steps = 6;
    o.longitude_steps = 8;
    morph::MorphableModel m = testkit::make_toy_model(o);
    if (!with_albedo) m.albedo.reset();
    return m;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_seeds OUT_DIR\n");
        return 2;
    }
    const fs::path out = argv[1];
    try {
        const morph::MorphableModel toy = small_toy(true);
        const morph::MorphableModel shape_only = small_toy(false);

        for (std::uint32_t version = 1; version <= 4; ++version) {
            put(out / "eos_model", "toy_v" + std::to_string(version) + ".bin", testkit::eos_model_bytes(toy, version));
            put(out / "eos_model", "shape_only_v" + std::to_string(version) + ".bin", testkit::eos_model_bytes(shape_only, version, false));
        }
        morph::MorphableModel pca_expression = shape_only;
        pca_expression.expression = shape_only.shape;
        put(out / "eos_model", "pca_expression_v3.bin", testkit::eos_model_bytes(pca_expression, 3));
        if (toy.expression && std::holds_alternative<std::vector<morph::Blendshape>>(*toy.expression))
            put(out / "eos_blendshapes", "toy.bin", testkit::eos_blendshape_bytes(std::get<std::vector<morph::Blendshape>>(*toy.expression)));
        put(out / "eos_blendshapes", "one.bin", testkit::eos_blendshape_bytes({{"smile", Eigen::VectorXf::Ones(6)}}));

        std::string mapping = "# iBUG id = vertex id\n[landmark_mappings]\n";
        for (std::size_t i = 0; i < toy.landmarks.size(); ++i)
            mapping += std::to_string(i + 1) + " = " + std::to_string(toy.landmarks[i].vertices[0]) + "\n";
        mapping += "\n[contour_landmarks]\nright = [ 1, 2, 3 ]\nleft = [ 17, 16, 15 ]\n";
        put(out / "landmark_mapping", "toy.txt", mapping);

        nlohmann::json contours;
        contours["model_contour"]["right_contour"] = toy.contour.right;
        contours["model_contour"]["left_contour"] = toy.contour.left;
        put(out / "contours", "toy.json", contours.dump(2));

        std::string symmetry;
        for (std::size_t v = 0; v < toy.symmetry.size() && v < 200; ++v) symmetry += std::to_string(toy.symmetry[v] + 1) + "\n";
        put(out / "symmetry", "toy.txt", symmetry);

        fs::create_directories(out / "fsm");
        morph::write_model(toy, out / "fsm" / "toy.fsm");
        morph::write_model(shape_only, out / "fsm" / "shape_only.fsm");

        morph::MorphableModel bfm = shape_only;
        bfm.albedo = toy.albedo;
        morph::PcaModel expression = shape_only.shape;
        expression.mean.setZero();
        bfm.expression = expression;
        fs::create_directories(out / "bfm");
        testkit::write_statismo(out / "bfm" / "toy.h5", bfm);
        morph::MorphableModel bfm_shape_only = shape_only;
        bfm_shape_only.expression.reset();  // statismo holds a PCA expression model or none
        testkit::write_statismo(out / "bfm" / "shape_only.h5", bfm_shape_only);

        fs::create_directories(out / "pts");
        Eigen::Matrix2Xd points = testkit::ibug68_frontal_template();
        points.row(0).array() += 128.0;
        points.row(1) = 128.0 - points.row(1).array();
        morph::write_pts(out / "pts" / "face.pts", points);
        put(out / "pts", "three.pts", "version: 1\nn_points: 3\n{\n1 2\n3.5 4\n5 6e1\n}\n");

        put(out / "synth_config", "defaults.toml", synth::to_commented_toml(synth::SynthConfig{}));
        put(out / "synth_config", "small.toml", "count = 4\nseed = 7\n[pose.yaw]\nmin = -30\nmax = 30\n[output]\nformats = \"folder,wds\"\n");

        train::SdmModel sdm;
        sdm.num_landmarks = morph::kNumIbugLandmarks;
        sdm.hog.cells = 1;
        sdm.mean_shape = Eigen::Matrix2Xd::Zero(2, morph::kNumIbugLandmarks);
        train::SdmStage stage;
        stage.settings.patch_relative = 0.5;
        stage.settings.cell_size = 8;
        stage.settings.jaw_features = false;
        stage.basis = Eigen::MatrixXf::Identity(2 * morph::kNumIbugLandmarks, 2);  // rank 2
        stage.weights = Eigen::MatrixXf::Zero(2, sdm.feature_dims(stage.settings));
        stage.bias = Eigen::VectorXf::Zero(2 * morph::kNumIbugLandmarks);
        sdm.stages.push_back(stage);
        fs::create_directories(out / "sdm");
        train::write_sdm_model(out / "sdm" / "one_stage.sdm", sdm);

        train::ViewBaselineBundle bundle;
        bundle.method = train::BaselineMethod::kLbf;
        bundle.detector = train::DetectorKind::kDlib;
        bundle.frontal_model = "frontal model bytes";
        bundle.profile_model = "profile";
        fs::create_directories(out / "view_bundle");
        train::write_view_baseline_bundle(out / "view_bundle" / "lbf_dlib.bundle", bundle);
        bundle.method = train::BaselineMethod::kErt;
        bundle.detector = train::DetectorKind::kMultiView;
        train::write_view_baseline_bundle(out / "view_bundle" / "ert_multiview.bundle", bundle);

        synth::RunOptions run;
        run.config.count = 2;
        run.config.seed = 3;
        run.config.camera.width = run.config.camera.height = 48;
        run.out = out / "seed-dataset";
        morph::MorphableModel with_landmarks = testkit::make_toy_model();
        (void)synth::run_synth(run, with_landmarks);
        fs::create_directories(out / "dataset_meta");
        for (const auto& entry : fs::directory_iterator(run.out / "meta"))
            fs::copy_file(entry.path(), out / "dataset_meta" / entry.path().filename(), fs::copy_options::overwrite_existing);
        fs::copy_file(run.out / "dataset.json", out / "dataset_meta" / "dataset.json", fs::copy_options::overwrite_existing);
        fs::copy_file(run.out / "manifest.jsonl", out / "dataset_meta" / "manifest.jsonl", fs::copy_options::overwrite_existing);
        fs::remove_all(run.out);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "make_seeds: %s\n", e.what());
        return 1;
    }
    return 0;
}
