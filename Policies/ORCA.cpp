// CrowdHealth — ORCA (van den Berg, Guy, Lin & Manocha 2011): half-planes and linear programs.
#include "ORCA.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ch {

CH_REGISTER_COMPONENT(ORCA);

namespace orca {

namespace {

constexpr double kEps = 1e-9;

double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }
/// a turned a quarter counter-clockwise / clockwise.
Vec2 leftOf(const Vec2& a) { return {-a.y(), a.x()}; }
Vec2 rightOf(const Vec2& a) { return {a.y(), -a.x()}; }
/// Signed angle (rad, in (−π, π]) that turns unit vector `from` onto `to`.
double angleBetween(const Vec2& from, const Vec2& to) { return std::atan2(cross(from, to), from.dot(to)); }

/// The 1D program on the boundary line of planes[k]: the best point of that line inside the disc
/// and inside planes[0..k). The line is parametrised as base + t·dir with base its point nearest
/// to the origin.
bool solveOnLine(const std::vector<HalfPlane>& planes, std::size_t k, double maxSpeed, const Vec2& target,
                 bool directionMode, Vec2& out) {
    const HalfPlane& h = planes[k];
    const Vec2 base = h.offset * h.normal;
    const Vec2 dir = leftOf(h.normal);
    const double halfChord2 = maxSpeed * maxSpeed - h.offset * h.offset;
    if (halfChord2 < 0) return false;  // the line misses the speed disc
    double lo = -std::sqrt(halfChord2), hi = -lo;
    for (std::size_t j = 0; j < k; ++j) {
        // planes[j] on the line: t·(n_j·dir) ≤ offset_j − n_j·base
        const double slope = planes[j].normal.dot(dir);
        const double room = planes[j].offset - planes[j].normal.dot(base);
        if (std::abs(slope) <= kEps) {
            if (room < -kEps) return false;  // parallel and entirely outside
            continue;
        }
        const double t = room / slope;
        if (slope > 0) hi = std::min(hi, t);
        else lo = std::max(lo, t);
        if (lo > hi + kEps) return false;
    }
    if (lo > hi) lo = hi = 0.5 * (lo + hi);  // an interval shrunk to a point by rounding
    double t;
    if (directionMode) t = target.dot(dir) >= 0 ? hi : lo;
    else t = std::clamp(dir.dot(target - base), lo, hi);
    out = base + t * dir;
    return true;
}

}  // namespace

std::size_t solve2D(const std::vector<HalfPlane>& planes, double maxSpeed, const Vec2& target, bool directionMode,
                    Vec2& result) {
    // Unconstrained optimum inside the disc.
    if (directionMode) result = target * maxSpeed;
    else result = clampLength(target, maxSpeed);
    for (std::size_t k = 0; k < planes.size(); ++k) {
        if (planes[k].violation(result) <= kEps) continue;
        // The old optimum breaks plane k: the new optimum lies on its boundary line.
        const Vec2 previous = result;
        if (!solveOnLine(planes, k, maxSpeed, target, directionMode, result)) {
            result = previous;
            return k;
        }
    }
    return planes.size();
}

void solve3D(const std::vector<HalfPlane>& planes, std::size_t numHard, std::size_t begin, double maxSpeed,
             Vec2& result) {
    double delta = 0;  // the largest violation of the soft planes seen so far
    std::vector<HalfPlane> projected;
    for (std::size_t i = std::max(begin, numHard); i < planes.size(); ++i) {
        if (planes[i].violation(result) <= delta + kEps) continue;
        // Restricted to "violation_i = δ", the soft planes j < i become violation_j ≤ violation_i,
        // i.e. (n_j − n_i)·v ≤ offset_j − offset_i; the hard planes stay as they are.
        projected.assign(planes.begin(), planes.begin() + static_cast<std::ptrdiff_t>(numHard));
        for (std::size_t j = numHard; j < i; ++j) {
            const Vec2 dn = planes[j].normal - planes[i].normal;
            const double len = dn.norm();
            // Same direction: plane j moves with plane i, lowering i lowers j too.
            if (len <= kEps) continue;
            projected.push_back(HalfPlane{dn / len, (planes[j].offset - planes[i].offset) / len});
        }
        const Vec2 previous = result;
        // Minimise violation_i: go as far as possible along −n_i.
        if (solve2D(projected, maxSpeed, -planes[i].normal, true, result) < projected.size()) {
            // Cannot happen in exact arithmetic (the previous result is feasible); keep it.
            result = previous;
        }
        delta = planes[i].violation(result);
    }
}

Solution solve(const std::vector<HalfPlane>& planes, std::size_t numHard, double maxSpeed, const Vec2& prefVelocity) {
    Solution s;
    const std::size_t failed = solve2D(planes, maxSpeed, prefVelocity, false, s.velocity);
    if (failed == planes.size()) return s;
    s.feasible = false;
    // When the hard planes alone (walls within the speed disc) conflict, every plane becomes soft.
    solve3D(planes, failed < numHard ? 0 : numHard, failed, maxSpeed, s.velocity);
    return s;
}

HalfPlane agentHalfPlane(const Vec2& relPos, const Vec2& relVel, double R, double tau, double dt, const Vec2& velocity,
                         double share) {
    const double dist2 = relPos.squaredNorm();
    Vec2 n, u;  // outward normal of ∂VO at its point nearest to relVel, and relVel → that point
    if (dist2 > R * R) {
        const Vec2 w = relVel - relPos / tau;  // from the centre of the truncation disc
        const double wp = w.dot(relPos);
        const double w2 = w.squaredNorm();
        if (wp < 0 && wp * wp > R * R * w2) {
            // Nearest to the truncation arc: the angle between w and −relPos is below the one of
            // the tangent points (whose cosine is R/|relPos|).
            const double wl = std::sqrt(w2);
            n = w / wl;
            u = (R / tau - wl) * n;
        } else {
            // Nearest to a leg of the cone: the tangent from 0 to D(relPos, R) on w's side.
            const double leg = std::sqrt(dist2 - R * R);
            Vec2 d;
            if (cross(relPos, w) > 0) {
                d = Vec2(relPos.x() * leg - relPos.y() * R, relPos.x() * R + relPos.y() * leg) / dist2;  // +asin(R/|p|)
                n = leftOf(d);
            } else {
                d = Vec2(relPos.x() * leg + relPos.y() * R, -relPos.x() * R + relPos.y() * leg) / dist2;  // −asin(R/|p|)
                n = rightOf(d);
            }
            u = relVel.dot(d) * d - relVel;
        }
    } else {
        // Overlapping now: the truncation disc of one step, so the pair separates within dt.
        const Vec2 w = relVel - relPos / dt;
        const double wl = w.norm();
        if (wl > kEps) n = w / wl;
        else if (dist2 > 0) n = -relPos / std::sqrt(dist2);
        else n = Vec2(1, 0);  // coincident centres: any fixed direction
        u = (R / dt - wl) * n;
    }
    // Allowed: (v − (velocity + share·u))·n ≥ 0  ⇔  (−n)·v ≤ −n·(velocity + share·u).
    return HalfPlane{-n, -n.dot(velocity + share * u)};
}

std::optional<HalfPlane> obstacleHalfPlane(const Vec2& a, const Vec2& b, double r, double tau, const Vec2& v) {
    const Vec2 nearest = closestPointOnSegment(Vec2(0, 0), a, b);
    const double d = nearest.norm();
    if (d <= kEps) return std::nullopt;
    if (d <= r) return HalfPlane{nearest / d, 0.0};  // touching: no velocity component towards it

    // VO = ∪_{s ≥ 1} s·C' with C' = C/τ the scaled capsule. Its boundary: two legs (rays tangent to
    // the end discs, from the scaled tangent points outwards) and the part of ∂C' seen from 0
    // (end arcs and the straight side facing 0). The boundary point nearest to v is the nearest of
    // the nearest points of these pieces; each piece carries its outward normal.
    const double inv = 1.0 / tau;
    const double rho = r * inv;
    double best = kInf;
    Vec2 bestPoint(0, 0), bestNormal(0, 0);
    auto consider = [&](const Vec2& p, const Vec2& n) {
        const double dd = (v - p).squaredNorm();
        if (dd < best) {
            best = dd;
            bestPoint = p;
            bestNormal = n;
        }
    };

    // Tangents from 0 to an end disc D(e, r): unit directions turned ±asin(r/|e|) from e, and the
    // distance from 0 to the tangent points.
    struct Tangents { Vec2 left, right; double length; };
    auto tangents = [&](const Vec2& e) {
        const double e2 = e.squaredNorm();
        const double leg = std::sqrt(std::max(0.0, e2 - r * r));
        Tangents t;
        t.left = Vec2(e.x() * leg - e.y() * r, e.x() * r + e.y() * leg) / e2;
        t.right = Vec2(e.x() * leg + e.y() * r, -e.x() * r + e.y() * leg) / e2;
        t.length = leg;
        return t;
    };
    const Tangents ta = tangents(a), tb = tangents(b);
    // The capsule subtends less than π from outside, so "more counter-clockwise" is a cross product.
    const bool leftFromB = cross(ta.left, tb.left) > 0;
    const Vec2 left = leftFromB ? tb.left : ta.left;
    const Vec2 leftStart = left * ((leftFromB ? tb.length : ta.length) * inv);
    const bool rightFromB = cross(ta.right, tb.right) < 0;
    const Vec2 right = rightFromB ? tb.right : ta.right;
    const Vec2 rightStart = right * ((rightFromB ? tb.length : ta.length) * inv);
    consider(leftStart + std::max(0.0, (v - leftStart).dot(left)) * left, leftOf(left));
    consider(rightStart + std::max(0.0, (v - rightStart).dot(right)) * right, rightOf(right));

    const Vec2 ab = b - a;
    const double len = ab.norm();
    if (len > kEps) {
        // The straight side on 0's side of the supporting line is seen from 0 iff 0 is farther
        // than r from that line.
        Vec2 m = leftOf(ab / len);
        if (m.dot(a) > 0) m = -m;
        if (-m.dot(a) > r) consider(closestPointOnSegment(v, a * inv + rho * m, b * inv + rho * m), m);
    }
    // End arcs: normals n with n·(−ê) > r/|e| are seen from 0; the cap of e has n·(e − other) ≥ 0.
    auto arc = [&](const Vec2& e, const Vec2& other) {
        const double el = e.norm();
        const Vec2 centre = -e / el;
        double lo = -std::acos(std::min(1.0, r / el)), hi = -lo;
        if (len > kEps) {
            // The seen arc has half-width < π/2 and the cap is a half circle: they meet in one
            // interval at most, without wrapping around.
            const double delta = angleBetween(centre, (e - other) / len);
            lo = std::max(lo, delta - kPi / 2);
            hi = std::min(hi, delta + kPi / 2);
            if (lo > hi) return;
        }
        const Vec2 es = e * inv;
        const Vec2 w = v - es;
        double theta = w.squaredNorm() > kEps * kEps ? angleBetween(centre, w) : 0.5 * (lo + hi);
        if (theta < lo || theta > hi) {
            // Distance along the circle grows with the angular gap: take the nearer end.
            const double gapLo = std::abs(std::remainder(theta - lo, 2 * kPi));
            const double gapHi = std::abs(std::remainder(theta - hi, 2 * kPi));
            theta = gapLo <= gapHi ? lo : hi;
        }
        const Vec2 n = rotated(centre, theta);
        consider(es + rho * n, n);
    };
    arc(a, b);
    arc(b, a);

    // Allowed: n·v' ≥ n·P with P the nearest boundary point and n its outward normal. 0 is always
    // allowed: on a leg n·P = 0 (the leg passes through 0); on the seen part of ∂C' the normal faces
    // 0, i.e. n·(0 − P) > 0. Hence any set of walls leaves 0 feasible.
    return HalfPlane{-bestNormal, -bestNormal.dot(bestPoint)};
}

}  // namespace orca

ComponentInfo ORCA::Info() {
    ComponentInfo info;
    info.name = "ORCA";
    info.kind = ComponentKind::CostFunction;
    info.summary = "optimal reciprocal collision avoidance: closest velocity to v_pref inside the ORCA half-planes "
                   "of neighbours and walls (includes goal reaching)";
    info.reference = "van den Berg, Guy, Lin & Manocha 2011, Reciprocal n-body collision avoidance, "
                     "Robotics Research (ISRR), STAR 70:3-19";
    ParamSpec tau = ParamSpec::real("timeHorizon", "s", 5.0, 0.0, 1e3,
                                    "time horizon tau of the velocity obstacles of other agents");
    tau.minExclusive = true;
    ParamSpec tauObst = ParamSpec::real("timeHorizonObst", "s", 5.0, 0.0, 1e3,
                                        "time horizon of the velocity obstacles of walls (CrowdHealth addition)");
    tauObst.minExclusive = true;
    info.params = {tau, tauObst};
    info.create = [](const ParamSet& p) { return std::make_unique<ORCA>(p); };
    return info;
}

ORCA::ORCA(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "timeHorizon", timeHorizon_);
    bind(params, "timeHorizonObst", timeHorizonObst_);
}

template <class F>
void ORCA::forEachHalfPlane(const AgentQuery& q, const StepContext& ctx, F&& f) const {
    const double tau = std::max(timeHorizon_, 1e-6);
    const double tauObst = std::max(timeHorizonObst_, 1e-6);
    const double dt = std::max(ctx.dt, 1e-6);
    for (int s : q.segments) {
        const Segment& seg = ctx.world.segments()[s];
        const Vec2 a = seg.a - q.position, b = seg.b - q.position;
        if (distanceToSegmentSquared(Vec2(0, 0), a, b) > range_ * range_) continue;
        if (auto h = orca::obstacleHalfPlane(a, b, q.radius, tauObst, q.velocity)) f(*h, true);
    }
    const AgentStore& A = ctx.agents;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        f(orca::agentHalfPlane(n.offset, q.velocity - A.vel[n.index], q.radius + A.radius[n.index], tau, dt,
                               q.velocity),
          false);
    }
}

std::size_t ORCA::halfPlanes(const AgentQuery& q, const StepContext& ctx, std::vector<orca::HalfPlane>& out) const {
    out.clear();
    std::vector<orca::HalfPlane> agents;
    forEachHalfPlane(q, ctx, [&](const orca::HalfPlane& h, bool wall) { (wall ? out : agents).push_back(h); });
    const std::size_t walls = out.size();
    out.insert(out.end(), agents.begin(), agents.end());
    return walls;
}

std::optional<Vec2> ORCA::globalMinimum(const AgentQuery& q, const StepContext& ctx) const {
    std::vector<orca::HalfPlane> planes;
    const std::size_t walls = halfPlanes(q, ctx, planes);
    return orca::solve(planes, walls, q.maxSpeed, q.prefVelocity).velocity;
}

double ORCA::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    double worst = v.norm() - q.maxSpeed;
    forEachHalfPlane(q, ctx, [&](const orca::HalfPlane& h, bool) { worst = std::max(worst, h.violation(v)); });
    if (worst <= 0) return (v - q.prefVelocity).norm();
    // Larger than any feasible cost |v − v_pref| ≤ max_speed + |v_pref|.
    return worst + q.maxSpeed + std::max(q.maxSpeed, q.prefVelocity.norm());
}

Vec2 ORCA::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    // The gradient of the active piece: the largest violation's outward normal outside the
    // feasible region, the unit vector from v_pref inside it.
    double worst = v.norm() - q.maxSpeed;
    Vec2 normal = normalisedOrZero(v);
    forEachHalfPlane(q, ctx, [&](const orca::HalfPlane& h, bool) {
        const double x = h.violation(v);
        if (x > worst) {
            worst = x;
            normal = h.normal;
        }
    });
    if (worst <= 0) return normalisedOrZero(v - q.prefVelocity);
    return normal;
}

}  // namespace ch
