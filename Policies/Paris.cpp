// CrowdHealth — Paris (Paris, Pettré & Donikian 2007).
#include "Paris.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(Paris);

ComponentInfo Paris::Info() {
    ComponentInfo info;
    info.name = "Paris";
    info.kind = ComponentKind::CostFunction;
    info.summary = "predictive avoidance: per direction, the speeds that pass before or after each neighbour "
                   "(includes goal reaching; use with sampling)";
    info.reference = "Paris, Pettre & Donikian 2007, Pedestrian reactive navigation for crowd simulation: a "
                     "predictive approach, Computer Graphics Forum 26(3):665";
    info.params = {
        ParamSpec::real("w_a", "-", 0.5, 0.0, 1.0,
                        "weight of collision avoidance against the angle to the goal in the direction cost"),
        ParamSpec::real("w_b", "s", 0.0, 0.0, 1e3,
                        "softening of the time weight 1 - t1/(t_max + w_b) of a predicted conflict"),
        ParamSpec::real("t_max", "s", 8.0, 0.0, 1e3, "prediction horizon: conflicts later than this are ignored"),
        ParamSpec::real("side_preference", "-", 0.05, 0.0, 1.0,
                        "CrowdHealth extension: preference for detours to the right when the preferred direction "
                        "is in conflict (0 = none)"),
        ParamSpec::choice("variant", {"exact", "umans"}, 1,
                          "exact = forbidden speed intervals solved exactly, sums over neighbours, walls, "
                          "side_preference; umans = what UMANS 1.x computes (its version is marked work in "
                          "progress): conflict point where the two paths cross, means over neighbours, no walls"),
    };
    info.params[2].minExclusive = true;
    info.create = [](const ParamSet& p) { return std::make_unique<Paris>(p); };
    return info;
}

Paris::Paris(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "w_a", wA_);
    bind(params, "w_b", wB_);
    bind(params, "t_max", tMax_);
    bind(params, "side_preference", sideBias_);
    bind(params, "variant", variant_);
}

Paris::UmansConflict Paris::umansConflict(const Vec2& d, const AgentQuery& q, const StepContext& ctx,
                                          const NeighbourAgent& n) const {
    // The neighbour's path (at its current velocity) and the agent's line along d cross at X; the
    // neighbour covers X (within the radius sum R) from t1 to t2 = t1 + R/|u|, each capped at the
    // horizon (t2 past it counts as 0); the agent reaches X before the neighbour at speeds above
    // s1 = |X|/t1 and after it below s2 = |X|/t2. No crossing point (parallel paths, a standing
    // neighbour): a conflict for the whole horizon if walking along d at 1 m/s collides within it.
    const AgentStore& A = ctx.agents;
    const Vec2 p = n.offset;  // neighbour relative to the agent
    const Vec2 u = A.vel[n.index];
    const double R = q.radius + A.radius[n.index];
    const double det = d.x() * u.y() - d.y() * u.x();
    const UmansConflict free{tMax_, 0.0, 0.0, kInf};  // C_pred = 0, every speed allowed
    if (std::abs(det) < 1e-5) {
        if (timeToCollision(Vec2(0, 0), d, q.radius, p, u, A.radius[n.index]) > tMax_) return free;
        return UmansConflict{0.0, tMax_, kInf, 0.0};
    }
    const double along = (p.x() * u.y() - p.y() * u.x()) / det;  // X = along·d
    const Vec2 X = along * d;
    // A crossing the agent, at its current velocity, does not reach within the horizon is ignored
    // (also one behind it).
    if (std::min(tMax_, timeToCollisionPoint(Vec2(0, 0), q.velocity, R, X)) >= tMax_) return free;
    const double t1 = std::min(tMax_, timeToCollisionPoint(p, u, R, X));
    double t2 = t1 + R / u.norm();
    if (t2 > tMax_) t2 = 0;
    const double dist = X.norm();
    return UmansConflict{t1, t2, dist / t1, dist / t2};
}

double Paris::umansCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const double s = v.norm();
    const Vec2 d = s > 0 ? Vec2(v / s) : Vec2(0, 0);
    const double ps = q.prefVelocity.norm();
    double speedPred = 0, deviation = 0;
    int count = 0;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        const UmansConflict c = umansConflict(d, q, ctx, n);
        ++count;
        // C_speed (the preferred speed outside [s1, s2]) times C_pred (nearer conflicts count more).
        const double cSpeed = std::min(std::max(0.0, 1.0 - c.s1 / ps), std::max(0.0, (c.s2 - ps) / ps));
        speedPred += cSpeed * (1.0 - c.t1 / (tMax_ + wB_));
        deviation += std::max(0.0, std::max((c.s1 - s) / ps, (s - c.s2) / ps));
    }
    if (count > 0) speedPred /= count;
    const double cosAngle = (s > 0 && ps > 0) ? d.dot(q.prefVelocity) / ps : 0.0;
    const double direction = wA_ * speedPred + (1 - wA_) * (1 - cosAngle) / 2;
    return 1000 * direction + deviation + 0.001 * (v - q.prefVelocity).norm();
}

namespace {

/// Smallest interval holding both (either may be empty).
Paris::SpeedInterval hull(const Paris::SpeedInterval& a, const Paris::SpeedInterval& b) {
    if (a.empty()) return b;
    if (b.empty()) return a;
    return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
}

Paris::SpeedInterval intersect(const Paris::SpeedInterval& a, const Paris::SpeedInterval& b) {
    if (a.empty() || b.empty()) return {};
    return {std::max(a.lo, b.lo), std::min(a.hi, b.hi)};
}

constexpr Paris::SpeedInterval kAll{-kInf, kInf};
constexpr Paris::SpeedInterval kNone{};

/// {s : k·s + m ≥ 0} as an interval.
Paris::SpeedInterval linearAtLeastZero(double k, double m) {
    if (k > 0) return {-m / k, kInf};
    if (k < 0) return {-kInf, -m / k};
    return m >= 0 ? kAll : kNone;
}

}  // namespace

Paris::SpeedInterval Paris::forbiddenSpeeds(const Vec2& d, const Vec2& rel, const Vec2& u, double R,
                                            double horizon) {
    // Work with w(s) = s·d − u, the agent's velocity relative to the neighbour. With the
    // neighbour at `rel`, a collision within the horizon happens iff w lies in the truncated
    // velocity obstacle: the cone of directions that hit the disc D(rel, R), cut off before the
    // disc D(rel/T, R/T). That set is convex: (cap disc) ∪ (cone beyond the chord through the two
    // tangent points), so the line s ↦ w(s) meets it in one interval, found piece by piece.
    const double a = d.dot(rel);  // d.rel
    const double b = u.dot(rel);  // u.rel: w.rel = a s − b
    const double dist2 = rel.squaredNorm();
    const SpeedInterval nonNegative{0.0, kInf};

    if (dist2 <= R * R) {
        // Already overlapping: every motion that brings the centres closer continues the collision.
        return intersect(linearAtLeastZero(a, -b), nonNegative);
    }
    const double T = horizon;

    // 1) cap disc |w − rel/T| ≤ R/T ⇔ |s·d − c|² ≤ ρ² with c = u + rel/T.
    SpeedInterval capPart;
    {
        const Vec2 c = u + rel / T;
        const double B = d.dot(c);
        const double disc = B * B - (c.squaredNorm() - (R / T) * (R / T));
        if (disc >= 0) capPart = {B - std::sqrt(disc), B + std::sqrt(disc)};
    }

    // 2) cone (w.rel)² ≥ |w|²·K with K = |rel|² − R², beyond the chord: w.rel ≥ K/T (which also
    //    selects the forward nappe, where w.rel > 0).
    SpeedInterval conePart;
    {
        const double K = dist2 - R * R;
        const double du = d.dot(u), uu = u.squaredNorm();
        // f(s) = (a s − b)² − K (s² − 2 s du + uu) = A s² + 2 Bh s + C
        const double A = a * a - K;
        const double Bh = -a * b + K * du;
        const double C = b * b - K * uu;
        const SpeedInterval beyond = linearAtLeastZero(a, -b - K / T);
        SpeedInterval pieces[2];
        if (std::abs(A) <= 1e-12 * dist2) {
            pieces[0] = linearAtLeastZero(2 * Bh, C);
        } else {
            const double disc = Bh * Bh - A * C;
            if (A > 0) {
                if (disc < 0) {
                    pieces[0] = kAll;
                } else {
                    const double r1 = (-Bh - std::sqrt(disc)) / A, r2 = (-Bh + std::sqrt(disc)) / A;
                    pieces[0] = {-kInf, std::min(r1, r2)};
                    pieces[1] = {std::max(r1, r2), kInf};
                }
            } else if (disc >= 0) {
                const double r1 = (-Bh - std::sqrt(disc)) / A, r2 = (-Bh + std::sqrt(disc)) / A;
                pieces[0] = {std::min(r1, r2), std::max(r1, r2)};
            }
        }
        conePart = hull(intersect(pieces[0], beyond), intersect(pieces[1], beyond));
    }

    return intersect(hull(capPart, conePart), nonNegative);
}

Paris::SpeedInterval Paris::forbiddenSpeedsWall(const Vec2& d, const Vec2& p, double r, const Vec2& a,
                                                const Vec2& b, double horizon) {
    const Vec2 nearest = closestPointOnSegment(p, a, b);
    if ((nearest - p).squaredNorm() <= r * r) {
        // Touching: walking into the wall is forbidden, walking away is free.
        return d.dot(nearest - p) > 0 ? SpeedInterval{0.0, kInf} : SpeedInterval{};
    }
    // With a unit velocity the time to collision is the distance walked before contact.
    const double D = timeToCollisionSegment(p, d, r, a, b);
    if (!std::isfinite(D)) return {};
    return {D / horizon, kInf};
}

double Paris::conflictAlong(const Vec2& d, double ps, double s, const AgentQuery& q, const StepContext& ctx,
                            double* deviation) const {
    const AgentStore& A = ctx.agents;
    double conflict = 0;  // Σ C_speed·C_pred
    auto account = [&](const SpeedInterval& iv, auto&& timeAtPreferredSpeed) {
        if (iv.empty()) return;
        if (ps > iv.lo && ps < iv.hi) {
            const double cSpeed = std::min(1.0, std::min(ps - iv.lo, iv.hi - ps) / ps);
            const double t1 = std::clamp(timeAtPreferredSpeed(), 0.0, tMax_);
            conflict += cSpeed * (1.0 - t1 / (tMax_ + wB_));
        }
        if (deviation != nullptr && s > iv.lo && s < iv.hi) *deviation += std::min(s - iv.lo, iv.hi - s) / ps;
    };
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        const Vec2& u = A.vel[n.index];
        const double rj = A.radius[n.index];
        account(forbiddenSpeeds(d, n.offset, u, q.radius + rj, tMax_),
                [&] { return timeToCollision(Vec2(0, 0), ps * d, q.radius, n.offset, u, rj); });
    }
    for (int k : q.segments) {
        const Segment& seg = ctx.world.segments()[k];
        if (distanceToSegmentSquared(q.position, seg.a, seg.b) > range_ * range_) continue;
        account(forbiddenSpeedsWall(d, q.position, q.radius, seg.a, seg.b, tMax_),
                [&] { return timeToCollisionSegment(q.position, ps * d, q.radius, seg.a, seg.b); });
    }
    return conflict;
}

double Paris::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    if (variant_ == kVariantUmans) return umansCost(v, q, ctx);
    const AgentStore& A = ctx.agents;
    const double s = v.norm();
    const double prefNorm = q.prefVelocity.norm();
    // The speed scale of the relative terms: the preferred speed (at the goal, the nominal one).
    const double ps = prefNorm > 1e-9 ? prefNorm : (q.prefSpeed > 1e-9 ? q.prefSpeed : 1.0);
    const double towardsPreferred = 0.001 * (v - q.prefVelocity).norm();

    if (s < 1e-9) {
        // Standing still has no walking direction: the angle term is neutral, and every neighbour
        // that would walk into the agent within the horizon costs one unit of speed deviation.
        double penalty = 0;
        for (const NeighbourAgent& n : q.agents) {
            if (n.distanceSquared() > range_ * range_) continue;
            const double ttc = timeToCollision(Vec2(0, 0), Vec2(0, 0), q.radius, n.offset, A.vel[n.index],
                                               A.radius[n.index]);
            if (ttc <= tMax_) penalty += 1.0;
        }
        return 1000.0 * (1.0 - wA_) * 0.5 + penalty + towardsPreferred;
    }

    const Vec2 d = v / s;
    double deviation = 0;  // Σ depth of s inside the forbidden intervals
    const double conflict = conflictAlong(d, ps, s, q, ctx, &deviation);

    const Vec2 prefDir = prefNorm > 1e-9 ? Vec2(q.prefVelocity / prefNorm) : Vec2(0, 0);
    const double cosAngle = d.dot(prefDir);
    const double sinAngle = prefDir.x() * d.y() - prefDir.y() * d.x();  // > 0: d left of v_pref
    // Keep right: when the preferred direction itself is in conflict, detours to the right are
    // cheaper (see the class comment); a 1e-6 remainder breaks exact ties in the agent's frame.
    double blocked = 0;
    if (sideBias_ > 0 && prefNorm > 1e-9) blocked = std::min(1.0, conflictAlong(prefDir, ps, ps, q, ctx, nullptr));
    const double angleCost = (1.0 - cosAngle) / 2.0 + (sideBias_ * blocked + 1e-6) * sinAngle;
    const double directionCost = wA_ * conflict + (1.0 - wA_) * angleCost;
    return 1000.0 * directionCost + deviation + towardsPreferred;
}

}  // namespace ch
