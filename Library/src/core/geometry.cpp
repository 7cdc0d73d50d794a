// CrowdHealth — 2D geometry helpers.
#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

bool pointInPolygon(const Vec2& p, const std::vector<Vec2>& poly) {
    bool inside = false;
    const std::size_t n = poly.size();
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
        const Vec2& a = poly[i];
        const Vec2& b = poly[j];
        if ((a.y() > p.y()) != (b.y() > p.y())) {
            const double x = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
            if (p.x() < x) inside = !inside;
        }
    }
    return inside;
}

double polygonArea(const std::vector<Vec2>& poly) {
    double s = 0;
    const std::size_t n = poly.size();
    for (std::size_t i = 0; i < n; ++i) {
        const Vec2& a = poly[i];
        const Vec2& b = poly[(i + 1) % n];
        s += a.x() * b.y() - b.x() * a.y();
    }
    return 0.5 * s;
}

double timeToCollisionPoint(const Vec2& p, const Vec2& v, double r, const Vec2& q) {
    return timeToCollision(p, v, r, q, Vec2(0, 0), 0.0);
}

double timeToCollisionSegment(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b) {
    if (distanceToSegmentSquared(p, a, b) <= r * r) return 0.0;
    // The earliest contact is with an endpoint or with the segment's interior.
    double t = std::min(timeToCollisionPoint(p, v, r, a), timeToCollisionPoint(p, v, r, b));
    const Vec2 ab = b - a;
    const double len = ab.norm();
    if (len <= 0) return t;
    const Vec2 n(-ab.y() / len, ab.x() / len);
    double dist = (p - a).dot(n);  // signed distance to the supporting line
    const double vn = v.dot(n);
    if (dist < 0) { dist = -dist; }
    const double approach = ((p - a).dot(n) < 0) ? vn : -vn;  // speed towards the line
    if (approach > 0) {
        const double ti = (dist - r) / approach;
        if (ti >= 0) {
            const Vec2 hit = p + v * ti;
            const double s = (hit - a).dot(ab) / (len * len);
            if (s >= 0 && s <= 1) t = std::min(t, ti);
        }
    }
    return t;
}

}  // namespace ch
