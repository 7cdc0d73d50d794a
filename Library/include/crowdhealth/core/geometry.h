// CrowdHealth — small 2D geometry helpers on Eigen vectors.
#pragma once

#include "crowdhealth/core/types.h"

#include <vector>

namespace ch {

/// A wall segment from `a` to `b` belonging to obstacle `obstacle`.
struct Segment {
    Vec2 a, b;
    int obstacle = -1;
};

/// Closest point to p on segment [a, b].
Vec2 closestPointOnSegment(const Vec2& p, const Vec2& a, const Vec2& b);
/// Squared distance from p to segment [a, b].
double distanceToSegmentSquared(const Vec2& p, const Vec2& a, const Vec2& b);
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
