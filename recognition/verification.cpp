#include "recognition/verification.h"

#include "core/error.h"

#include <algorithm>
#include <cmath>

namespace facesynth::recognition {
namespace {

void require_scores(const MatchScores& scores) {
    if (scores.genuine.empty() || scores.impostor.empty())
        throw core::Error("verification needs genuine and impostor pairs (" + std::to_string(scores.genuine.size()) + " genuine, " +
                    std::to_string(scores.impostor.size()) + " impostor)");
}

// Share of `sorted` values >= threshold.
double share_at_or_above(const std::vector<double>& sorted, double threshold) {
    const auto first = std::lower_bound(sorted.begin(), sorted.end(), threshold);
    return static_cast<double>(sorted.end() - first) / static_cast<double>(sorted.size());
}

// FRR when at most `accepted` impostors may be accepted (accept d < the accepted-th smallest impostor).
double frr_accepting(const std::vector<double>& genuine, const std::vector<double>& impostor, std::size_t accepted) {
    if (accepted >= impostor.size()) return 0;
    return share_at_or_above(genuine, impostor[accepted]);
}

}  // namespace

double frr_at_far(const MatchScores& scores, double far) {
    require_scores(scores);
    std::vector<double> genuine = scores.genuine, impostor = scores.impostor;
    std::sort(genuine.begin(), genuine.end());
    std::sort(impostor.begin(), impostor.end());
    const auto accepted = static_cast<std::size_t>(std::floor(far * static_cast<double>(impostor.size()) + 1e-9));
    return frr_accepting(genuine, impostor, accepted);
}

std::vector<DetPoint> det_curve(const MatchScores& scores, int points) {
    require_scores(scores);
    std::vector<double> genuine = scores.genuine, impostor = scores.impostor;
    std::sort(genuine.begin(), genuine.end());
    std::sort(impostor.begin(), impostor.end());
    const double n = static_cast<double>(impostor.size());
    std::vector<DetPoint> curve{{0.0, frr_accepting(genuine, impostor, 0)}};
    std::size_t last = 0;
    for (int i = 0; i < points; ++i) {
        const double far = std::pow(n, -1.0 + static_cast<double>(i) / std::max(points - 1, 1));  // 1/n .. 1
        const auto accepted = std::max<std::size_t>(static_cast<std::size_t>(std::floor(far * n + 1e-9)), 1);
        if (accepted == last) continue;
        last = accepted;
        curve.push_back({static_cast<double>(accepted) / n, frr_accepting(genuine, impostor, accepted)});
    }
    return curve;
}

double separation_auc(const MatchScores& scores) {
    require_scores(scores);
    std::vector<double> impostor = scores.impostor;
    std::sort(impostor.begin(), impostor.end());
    double wins = 0;
    for (double g : scores.genuine) {
        const auto below = std::lower_bound(impostor.begin(), impostor.end(), g);
        const auto above = std::upper_bound(impostor.begin(), impostor.end(), g);
        wins += static_cast<double>(impostor.end() - above) + 0.5 * static_cast<double>(above - below);
    }
    return wins / (static_cast<double>(scores.genuine.size()) * static_cast<double>(impostor.size()));
}

}  // namespace facesynth::recognition
