// CrowdHealth — small 2D geometry helpers on Eigen vectors.
#pragma once

#include "crowdhealth/core/types.h"

#include <algorithm>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <cmath>
#include <vector>

namespace ch {

/// A wall segment from `a` to `b` belonging to obstacle `obstacle`.
struct Segment {
    Vec2 a, b;
    int obstacle = -1;
};

/// An axis-aligned box [lo, hi] (closed), empty until a point is added: the bounds of a shape,
/// tested before the shape's exact test (a point outside a polygon's box is outside the polygon).
struct Box {
    Vec2 lo{kInf, kInf}, hi{-kInf, -kInf};

    Box() = default;
    /// The box spanned by two corners, in any order.
    Box(const Vec2& a, const Vec2& b) : lo(a.cwiseMin(b)), hi(a.cwiseMax(b)) {}
    /// The smallest box holding every point (empty for none).
    static Box around(const std::vector<Vec2>& points) {
        Box b;
        for (const Vec2& p : points) b.add(p);
        return b;
    }
    void add(const Vec2& p) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    bool empty() const { return !(lo.x() <= hi.x() && lo.y() <= hi.y()); }
    /// The box widened by m on every side.
    Box grown(double m) const {
        Box b;
        b.lo = lo - Vec2(m, m);
        b.hi = hi + Vec2(m, m);
        return b;
    }
    /// The box widened by m and by a margin for rounding (1e-6 m plus 1e-9 of its largest
    /// coordinate), so a point that an interpolating test puts inside, or a distance test puts
    /// within m, is never a few ulps outside.
    Box grownPastRounding(double m) const {
        const double scale = std::max({std::abs(lo.x()), std::abs(hi.x()), std::abs(lo.y()), std::abs(hi.y())});
        return grown(m + roundingMargin(scale));
    }
    /// What a distance or inside test among coordinates of size `scale` (m) may be off by,
    /// with room to spare: 1 µm plus 1e-9 of the scale.
    static double roundingMargin(double scale) { return 1e-6 + 1e-9 * scale; }
    bool contains(const Vec2& p) const { return p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y(); }
    /// True when the two boxes share a point (touching counts).
    bool overlaps(const Box& o) const {
        return o.hi.x() >= lo.x() && o.lo.x() <= hi.x() && o.hi.y() >= lo.y() && o.lo.y() <= hi.y();
    }
};

/// std::clamp(v, 0.0, 1.0), bit for bit (NaN and −0 pass through), without a branch: GCC turns
/// the clamp's first test into a jump, which the random sides of walls near a crowd mispredict
/// (issue 20; SegmentGrid::near tests ~40 walls per agent among many obstacles).
inline double clampUnit(double v) {
#if defined(__SSE2__)
    // maxsd a, b = a > b ? a : b and minsd a, b = a < b ? a : b: the clamp's two tests.
    const __m128d t = _mm_max_sd(_mm_setzero_pd(), _mm_set_sd(v));
    return _mm_cvtsd_f64(_mm_min_sd(_mm_set_sd(1.0), t));
#else
    return std::clamp(v, 0.0, 1.0);
#endif
}
/// Closest point to p on segment [a, b]. (Inline: the wall queries call it for every candidate
/// wall of every agent, and a call kept each one's division from overlapping the next.)
inline Vec2 closestPointOnSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
    const Vec2 ab = b - a;
    const double len2 = ab.squaredNorm();
    if (len2 <= 0.0) return a;
    const double t = clampUnit((p - a).dot(ab) / len2);
    return a + t * ab;
}
/// Squared distance from p to segment [a, b].
inline double distanceToSegmentSquared(const Vec2& p, const Vec2& a, const Vec2& b) {
    return (p - closestPointOnSegment(p, a, b)).squaredNorm();
}
/// True when p lies inside the closed polygon (even-odd rule).
bool pointInPolygon(const Vec2& p, const std::vector<Vec2>& polygon);
/// Signed area of a polygon (positive when counter-clockwise).
double polygonArea(const std::vector<Vec2>& polygon);
/// Time until a disk at p moving at v with radius r first touches the static point q (kInf if never,
/// 0 if touching now).
double timeToCollisionPoint(const Vec2& p, const Vec2& v, double r, const Vec2& q);
/// Time until two moving disks first touch (kInf if never, 0 if overlapping now). Inline: sampling
/// methods call it for every candidate velocity and neighbour.
inline double timeToCollision(const Vec2& p1, const Vec2& v1, double r1, const Vec2& p2, const Vec2& v2, double r2) {
    // Solve |dp + dv t| = r for the smallest t ≥ 0.
    const Vec2 dp = p1 - p2;
    const Vec2 dv = v1 - v2;
    const double r = r1 + r2;
    const double c = dp.squaredNorm() - r * r;
    if (c <= 0) return 0.0;
    const double a = dv.squaredNorm();
    const double b = dp.dot(dv);  // half of the usual b
    if (a <= 0 || b >= 0) return kInf;  // not approaching
    const double disc = b * b - a * c;
    if (disc < 0) return kInf;
    const double t = (-b - std::sqrt(disc)) / a;
    return t >= 0 ? t : kInf;
}

/// Time until a moving disk first touches a static segment (kInf if never, 0 if touching now).
double timeToCollisionSegment(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b);

}  // namespace ch
