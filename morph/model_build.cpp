#include "morph/model_build.h"

#include "morph/bfm_io.h"
#include "core/error.h"

namespace facesynth::morph {
namespace {

Eigen::VectorXf stacked(const Eigen::Matrix3Xf& points) {
    return Eigen::Map<const Eigen::VectorXf>(points.data(), points.size());
}

}  // namespace

ModelBuildResult build_model(const std::vector<Mesh>& meshes, const std::vector<std::string>& sources,
                             const ModelBuildOptions& options) {
    if (meshes.size() < 2) throw core::Error("model build needs at least 2 meshes, got " + std::to_string(meshes.size()));
    if (sources.size() != meshes.size()) throw core::Error("model build: one source name per mesh expected");
    const Mesh& first = meshes.front();
    bool all_coloured = true;
    for (std::size_t i = 0; i < meshes.size(); ++i) {
        const Mesh& m = meshes[i];
        if (m.num_vertices() != first.num_vertices())
            throw core::file_error(sources[i], "has " + std::to_string(m.num_vertices()) + " vertices, " + sources[0] + " has " +
                                             std::to_string(first.num_vertices()) + " (meshes must be in correspondence)");
        if (m.triangles != first.triangles)
            throw core::file_error(sources[i], "has different triangles from " + sources[0] + " (meshes must share one topology)");
        all_coloured = all_coloured && m.colours.cols() == m.num_vertices();
    }

    ModelBuildResult result;
    std::vector<Eigen::VectorXf> shapes;
    shapes.reserve(meshes.size());
    for (const Mesh& m : meshes) shapes.push_back(stacked(m.vertices));
    result.length_scale = unit_scale_to_mm(shapes.front(), sources.front());
    if (result.length_scale != 1.0)
        for (auto& s : shapes) s *= static_cast<float>(result.length_scale);

    MorphableModel& model = result.model;
    model.name = options.name;
    model.shape = build_pca(shapes, options.shape);
    model.triangles = first.triangles;
    model.uv = first.uv;
    if (all_coloured) {
        std::vector<Eigen::VectorXf> colours;
        colours.reserve(meshes.size());
        bool varies = false;
        for (const Mesh& m : meshes) {
            colours.push_back(stacked(m.colours));
            varies = varies || colours.back() != colours.front();
        }
        if (varies) {
            model.albedo = build_pca(colours, options.colour);
        } else {
            model.albedo = PcaModel{colours.front(), Eigen::MatrixXf(colours.front().size(), 0), Eigen::VectorXf(0)};
        }
    }
    model.validate(options.name);
    return result;
}

}  // namespace facesynth::morph
