// Fits the built-in model (pose, identity, expression) to one face's 68 landmarks and writes the
// fitted mesh as OBJ.
//   fit_pts LANDMARKS.pts OUT.obj
#include "fit/fit.h"
#include "morph/builtin.h"
#include "morph/landmarks.h"
#include "morph/mesh_io.h"

#include <cstdio>
#include <exception>

using namespace facesynth;

int main(int argc, char** argv) try {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s LANDMARKS.pts OUT.obj\n", argv[0]);
        return 2;
    }
    const Eigen::Matrix2Xd landmarks = morph::read_pts(argv[1]);  // 0-based pixels
    const morph::MorphableModel& model = morph::builtin_model();

    fit::FitOptions options;
    options.jaw = fit::JawMode::kContour;  // the jaw points follow the silhouette, as annotators mark them
    const fit::Fitter fitter(model);
    const fit::FitResult result = fitter.fit(landmarks, options);

    // The fitted shape in model space, with the model's colours, uv and triangles.
    morph::Mesh mesh = model.instance(result.alpha, result.psi);
    mesh.vertices = fit::fitted_shape(model, result);
    morph::write_obj(mesh, argv[2]);

    const morph::EulerAngles& angles = result.pose.angles;
    std::printf("%s: yaw %.1f° pitch %.1f° roll %.1f°, reprojection RMS %.2f px after %d iterations\n", argv[2],
                angles.yaw, angles.pitch, angles.roll, result.reprojection_rms_px, result.iterations);
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "fit_pts: %s\n", e.what());
    return 1;
}
