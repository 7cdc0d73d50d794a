// CrowdHealth — WallArea (see WallArea.h).
#include "WallArea.h"

#include <algorithm>
#include <cmath>

namespace ch::wallarea {

namespace {

constexpr double kTwoPi = 2.0 * kPi;

double normAngle(double a) {
    a = std::fmod(a, kTwoPi);
    return a < 0 ? a + kTwoPi : a;
}

/// One segment as seen from the centre: the line's distance d and foot direction φ, and the
/// angular interval [start, start + width] (absolute, start in [0, 2π)) of the part of the
/// segment that lies inside the disc.
struct View {
    int segment;
    double d, phi, start, width;
    Vec2 nearest;
    double distance;
};

bool contains(const View& v, double theta) {
    return normAngle(theta - v.start) <= v.width;
}

}  // namespace

void occludedAreas(const Vec2& p, double h, const std::vector<Segment>& segments, const std::vector<int>& near,
                   std::vector<WallPiece>& out) {
    out.clear();
    if (near.empty()) return;  // most agents of a crowd: no wall within h (before the thread_local lookups)
    // Per-thread scratch, reused from call to call (no allocation inside a step).
    thread_local std::vector<View> views;
    thread_local std::vector<double> cuts, area;
    views.clear();
    for (int s : near) {
        const Segment& seg = segments[s];
        const Vec2 ab = seg.b - seg.a;
        const double len = ab.norm();
        if (len < 1e-12) continue;
        const Vec2 t = ab / len;
        const Vec2 ap = seg.a - p;
        // Foot of the perpendicular from p on the infinite line.
        const Vec2 foot = seg.a - t * ap.dot(t);
        const Vec2 n = foot - p;
        const double d = n.norm();
        if (d >= h || d < 1e-9) continue;  // line outside the disc, or seen edge-on (no area)
        const Vec2 nh = n / d;
        // Angles of the endpoints relative to the foot direction: in (−π/2, π/2) on this line.
        auto rel = [&](const Vec2& q) {
            const Vec2 r = q - p;
            return std::atan2(nh.x() * r.y() - nh.y() * r.x(), nh.dot(r));
        };
        double u1 = rel(seg.a), u2 = rel(seg.b);
        if (u1 > u2) std::swap(u1, u2);
        const double beta = std::acos(d / h);  // the line is inside the disc for |u| < β
        u1 = std::max(u1, -beta);
        u2 = std::min(u2, beta);
        if (u2 - u1 <= 1e-12) continue;
        const double phi = std::atan2(nh.y(), nh.x());
        const Vec2 nearest = closestPointOnSegment(p, seg.a, seg.b);
        views.push_back(View{s, d, phi, normAngle(phi + u1), u2 - u1, nearest, (nearest - p).norm()});
    }
    if (views.empty()) return;

    // Elementary arcs between consecutive interval ends: on each, the first segment hit is fixed.
    cuts.clear();
    for (const View& v : views) {
        cuts.push_back(v.start);
        cuts.push_back(normAngle(v.start + v.width));
    }
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end(), [](double a, double b) { return b - a < 1e-13; }), cuts.end());

    area.assign(views.size(), 0.0);
    const std::size_t m = cuts.size();
    for (std::size_t k = 0; k < m; ++k) {
        const double a0 = cuts[k];
        double a1 = k + 1 < m ? cuts[k + 1] : cuts[0] + kTwoPi;
        if (m == 1) a1 = a0 + kTwoPi;
        if (a1 - a0 < 1e-13) continue;
        const double mid = 0.5 * (a0 + a1);
        int best = -1;
        double bestT = kInf;
        for (std::size_t v = 0; v < views.size(); ++v) {
            if (!contains(views[v], mid)) continue;
            const double c = std::cos(mid - views[v].phi);
            if (c <= 0) continue;
            const double tHit = views[v].d / c;
            if (tHit < bestT) {
                bestT = tHit;
                best = static_cast<int>(v);
            }
        }
        if (best < 0 || bestT >= h) continue;
        const View& v = views[best];
        // Angles relative to the foot direction, continuous across the arc.
        const double r0 = std::remainder(a0 - v.phi, kTwoPi);
        const double r1 = r0 + (a1 - a0);
        area[best] += 0.5 * h * h * (r1 - r0) - 0.5 * v.d * v.d * (std::tan(r1) - std::tan(r0));
    }
    for (std::size_t v = 0; v < views.size(); ++v)
        if (area[v] > 0) out.push_back(WallPiece{views[v].segment, area[v], views[v].nearest, views[v].distance});
}

}  // namespace ch::wallarea
