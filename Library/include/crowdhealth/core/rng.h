// CrowdHealth — seeded random streams that do not depend on thread count or agent order.
// Every draw is a pure function of (run seed, agent id, step number, stream id, counter), so the
// same seed gives bit-identical runs with any number of threads.
#pragma once

#include "crowdhealth/core/types.h"

#include <cmath>
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

/// The key of a stateless family of 64-bit draws (drawU64), one family per (seed, stream, index):
/// e.g. index = the fine step, computed once per step, then one draw per agent. Not Rng's key
/// (Rng keeps its own bits); one mix instead of Rng's three.
inline std::uint64_t drawKey(std::uint64_t seed, std::uint64_t stream, std::uint64_t index) {
    return mix64((seed ^ (stream * 0xd1b54a32d192ed03ULL)) + index * 0x632be59bd9b4e019ULL);
}

/// Draw number `counter` of the family `key` (drawKey): SplitMix64's output at state
/// key + counter·γ, a pure function of its arguments.
inline std::uint64_t drawU64(std::uint64_t key, std::uint64_t counter) {
    return mix64(key + 0x9e3779b97f4a7c15ULL * counter);
}

/// Draws per point of uniformInUnitDisc: kDiscDraws − 1 tries, then its polar fallback.
inline constexpr int kDiscDraws = 8;

/// The polar form used by uniformInUnitDisc's fallback: radius √(hi·2⁻³²) and angle
/// 2π·lo·2⁻³² from the two 32-bit halves of u (radius < 1): uniform in the unit disc when u is.
inline Vec2 polarInUnitDisc(std::uint64_t u) {
    const double r = std::sqrt(static_cast<double>(u >> 32) * 0x1.0p-32);
    const double angle = 2 * kPi * static_cast<double>(u & 0xffffffffULL) * 0x1.0p-32;
    return Vec2(r * std::cos(angle), r * std::sin(angle));
}

/// A point uniform in the open unit disc from the draws drawU64(key, kDiscDraws·counter + t):
/// each draw t = 0, 1, … gives two signed 32-bit integers a, b, i.e. the point (a, b)·2⁻³¹ of a
/// lattice in [−1, 1)², kept when a² + b² < 2⁶² (an exact integer test; probability π/4). After
/// kDiscDraws − 1 misses (probability (1 − π/4)⁷ ≈ 2e-5) a fresh draw is read in polar form
/// (polarInUnitDisc) — never a rejected one, whose halves are not uniform. No square root or
/// sine on the usual path; the result depends on (key, counter) only.
inline Vec2 uniformInUnitDisc(std::uint64_t key, std::uint64_t counter) {
    constexpr double kScale = 0x1.0p-31;  // a signed 32-bit integer → [−1, 1)
    const std::uint64_t first = static_cast<std::uint64_t>(kDiscDraws) * counter;
    for (std::uint64_t t = 0; t + 1 < static_cast<std::uint64_t>(kDiscDraws); ++t) {
        const std::uint64_t u = drawU64(key, first + t);
        const auto a = static_cast<std::int32_t>(static_cast<std::uint32_t>(u >> 32));
        const auto b = static_cast<std::int32_t>(static_cast<std::uint32_t>(u));
        const auto a2 = static_cast<std::uint64_t>(static_cast<std::int64_t>(a) * a);
        const auto b2 = static_cast<std::uint64_t>(static_cast<std::int64_t>(b) * b);
        if (a2 + b2 < (std::uint64_t{1} << 62)) return Vec2(static_cast<double>(a) * kScale, static_cast<double>(b) * kScale);
    }
    return polarInUnitDisc(drawU64(key, first + static_cast<std::uint64_t>(kDiscDraws) - 1));
}

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
