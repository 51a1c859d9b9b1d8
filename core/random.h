#pragma once
// Reproducible random numbers. Sample i of any job draws from Rng(seed, i, stream) only, so results
// never depend on thread count, shard or order. The generator and the distributions are our own
// (SplitMix64 seeding, xoshiro256**, Box-Muller) so that the numbers are the same with every
// standard library.
#include <array>
#include <cstdint>

namespace facesynth::core {

class Rng {
public:
    // `stream` separates independent uses for the same sample (identity, pose, lighting, ...).
    Rng(std::uint64_t seed, std::uint64_t index, std::uint64_t stream = 0);

    std::uint64_t next_u64();
    double uniform();                           // [0, 1)
    double uniform(double low, double high);    // [low, high)
    double normal();                            // N(0, 1)
    double normal(double mean, double stddev);
    // N(0, 1) restricted to [-limit, limit] by rejection (limit > 0).
    double truncated_normal(double limit);
    int uniform_int(int low, int high);         // inclusive range

private:
    std::array<std::uint64_t, 4> state_{};
    bool has_spare_normal_ = false;
    double spare_normal_ = 0;
};

// Named streams, so adding a new random quantity never changes the others.
enum class RandomStream : std::uint64_t {
    kIdentity = 1,
    kExpression,
    kAlbedo,
    kPose,
    kCamera,
    kLighting,
    kBackground,
    kDegradation,
    kOccluder,
    kTexture,
    kNoise,
    kSplit,
    kAlbedoRedraw,  // synth: colour draws that replace implausible ones (albedo.reject_implausible)
    kHead,          // synth: the head parts a sample wears (head.body)
    kSequence,      // synth: the keys of a clip's trajectories (sequence.frames)
    kExposure,      // synth: the face-metered exposure's target (lighting.face_luminance_mean)
    kTextureMix,    // synth: the second texture mixed in (albedo.texture_mix_probability)
};

[[nodiscard]] inline Rng make_rng(std::uint64_t seed, std::uint64_t index, RandomStream stream) {
    return Rng(seed, index, static_cast<std::uint64_t>(stream));
}

}  // namespace facesynth::core
