#pragma once
// Verification metrics from match distances (lower = more alike): a pair is accepted when its
// distance is below a threshold. FAR = share of impostor pairs accepted, FRR = share of genuine
// pairs rejected; the DET curve is FRR against FAR over all thresholds (Martin et al., 1997).
#include <span>
#include <vector>

namespace facesynth::recognition {

struct MatchScores {
    std::vector<double> genuine;   // distances of same-identity pairs
    std::vector<double> impostor;  // distances of different-identity pairs
};

// FRR at the strictest threshold whose FAR does not exceed `far` (ties never push FAR above it):
// accept d < t with t = the (floor(far · impostors) + 1)-th smallest impostor distance.
// Throws core::Error when either list is empty.
[[nodiscard]] double frr_at_far(const MatchScores& scores, double far);

struct DetPoint {
    double far = 0;
    double frr = 0;
};
// `points` thresholds spaced evenly in log FAR from 1 / impostors to 1, plus FAR = 0.
[[nodiscard]] std::vector<DetPoint> det_curve(const MatchScores& scores, int points = 40);

// Probability that a genuine pair is closer than an impostor pair (ties count half): 0.5 is chance.
[[nodiscard]] double separation_auc(const MatchScores& scores);

}  // namespace facesynth::recognition
