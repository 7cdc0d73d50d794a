// CrowdHealth — basic types shared by every part of the library.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>

namespace ch {

/// 2D vector in metres (positions), m/s (velocities) or m/s² (accelerations).
using Vec2 = Eigen::Vector2d;

/// Stable identifier of an agent as given in the scenario (or assigned in file order).
using AgentId = std::int64_t;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Returns v scaled down to length `maxLength` if it is longer (v unchanged otherwise).
inline Vec2 clampLength(const Vec2& v, double maxLength) {
    const double sq = v.squaredNorm();
    if (sq > maxLength * maxLength && sq > 0.0) return v * (maxLength / std::sqrt(sq));
    return v;
}

/// Unit vector along v, or zero when v is (nearly) zero.
inline Vec2 normalisedOrZero(const Vec2& v) {
    const double n = v.norm();
    return n > 1e-12 ? Vec2(v / n) : Vec2(0.0, 0.0);
}

/// ⌊x⌋ as an int: static_cast<int>(std::floor(x)) for every x whose floor fits an int, in a few
/// instructions without branches. (With the generic x86-64 target, which has no rounding
/// instruction, GCC expands std::floor into a branchy sequence; the grids look cells up this way
/// for every agent at every step.)
inline int floorToInt(double x) {
    const double t = static_cast<double>(static_cast<long long>(x));  // towards zero, exact below 2^63
    return static_cast<int>(x < t ? t - 1.0 : t);
}

/// Rotates v counter-clockwise by `angle` radians.
inline Vec2 rotated(const Vec2& v, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

}  // namespace ch
