#pragma once
// Landmark accuracy summaries (docs/conventions.md, Metrics): NME = mean point-to-point error / inter-ocular distance
// (outer eye corners), with detector misses counted as NME = +inf.
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace facesynth::train {

struct NmeSummary {
    int count = 0;               // faces evaluated, misses included
    double mean = 0;             // over faces with a prediction (misses excluded; they have no error)
    double median = 0;           // over all faces, misses as +inf
    double auc_008 = 0;          // area under the CED curve on [0, 0.08], divided by 0.08
    double failure_rate_008 = 0; // share with NME > 0.08, misses included
};

[[nodiscard]] NmeSummary summarise_nme(std::span<const double> nmes, double threshold = 0.08);

// Share of faces with NME <= x (the cumulative error distribution).
[[nodiscard]] double ced_at(std::span<const double> nmes, double x);

// One CED curve per method on [0, max_nme], as PNG bytes drawn with OpenCV (the SVG version is
// report::ced_plot).
struct CedCurve {
    std::string label;
    std::vector<double> nmes;
};
[[nodiscard]] std::string ced_png(std::span<const CedCurve> curves, double max_nme = 0.08);

}  // namespace facesynth::train
