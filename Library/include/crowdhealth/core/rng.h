// CrowdHealth — seeded random streams that do not depend on thread count or agent order.
// Every draw is a pure function of (run seed, agent id, step number, stream id, counter), so the
// same seed gives bit-identical runs with any number of threads.
#pragma once

#include <cstdint>

namespace ch {

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a strong 64-bit mixing function.
inline std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/// A small counter-based generator: state = hash of its key, each call advances a counter.
class Rng {
public:
    Rng(std::uint64_t seed, std::uint64_t a = 0, std::uint64_t b = 0, std::uint64_t c = 0)
        : key_(mix64(mix64(mix64(seed) ^ a) ^ (b * 0x632be59bd9b4e019ULL)) ^ (c * 0x85157af5ULL)) {}
    std::uint64_t nextU64() { return mix64(key_ + 0x9e3779b97f4a7c15ULL * (++counter_)); }
    /// Uniform in [0, 1).
    double uniform() { return static_cast<double>(nextU64() >> 11) * 0x1.0p-53; }
    /// Uniform in [lo, hi).
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    /// Standard normal (Box–Muller; uses two uniforms).
    double normal();

private:
    std::uint64_t key_;
    std::uint64_t counter_ = 0;
};

/// Identifiers of independent random streams, so adding a new use never shifts an existing one.
enum RngStream : std::uint64_t {
    kStreamSampling = 1,
    kStreamCostFunction = 2,
    kStreamSpawn = 3,
    kStreamPanic = 4,
    kStreamSymmetry = 5,  ///< symmetry breaking of the preferred direction (ScenarioSpec::symmetryBreaking)
    kStreamExitChoice = 6,  ///< weighted exit choice (crowdhealth/navigation/navigation.h)
    kStreamSource = 7,      ///< attributes and places of agents created by sources
    kStreamSourceGroup = 8, ///< groups drawn by sources: sizes, and members' places beside the first
    kStreamHelp = 9,        ///< whether an agent helps a casualty (crowdhealth/health/health.h)
    kStreamUser = 100  ///< first id free for new components
};

}  // namespace ch
