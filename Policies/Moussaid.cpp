// CrowdHealth — Moussaid (Moussaïd, Helbing & Theraulaz 2011), see Moussaid.h.
#include "Moussaid.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(Moussaid);

ComponentInfo Moussaid::Info() {
    ComponentInfo info;
    info.name = "Moussaid";
    info.kind = ComponentKind::CostFunction;
    info.summary = "vision-based heuristics: direction closest to the goal within the free distance, speed from it";
    info.reference =
        "Moussaid, Helbing & Theraulaz 2011, How simple rules determine pedestrian behavior and crowd disasters, "
        "PNAS 108(17):6884-6888";
    ParamSpec dMax = ParamSpec::real("d_max", "m", 8.0, 0.0, 1e3,
                                     "horizon distance: free distances are capped at it (paper: 10 m)");
    dMax.minExclusive = true;
    info.params = {
        dMax,
        ParamSpec::choice("overlap", {"stop", "closing"}, 0,
                          "a neighbour the agent's body already overlaps: stop = blocks every direction, the agent "
                          "brakes and contact forces separate the pair (UMANS 1.x); closing = blocks only the "
                          "directions that close the gap"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<Moussaid>(p); };
    return info;
}

Moussaid::Moussaid(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "d_max", dMax_);
    bind(params, "overlap", overlap_);
}

bool Moussaid::overlapsNeighbour(const AgentQuery& q, const StepContext& ctx) const {
    for (const NeighbourAgent& n : q.agents) {
        const double d2 = n.distanceSquared();
        const double reach = q.radius + ctx.agents.radius[n.index];
        if (d2 <= range_ * range_ && d2 <= reach * reach) return true;
    }
    return false;
}

double Moussaid::distanceToCollision(const Vec2& dir, double speed, const AgentQuery& q,
                                     const StepContext& ctx) const {
    const Vec2 v = dir * speed;
    const double first = timeToFirstCollision(v, q, ctx, range_);
    if (!(first < kInf)) return dMax_;
    return std::min(dMax_, first * speed);
}

double Moussaid::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const double v0 = q.prefSpeed;
    const double prefNorm = q.prefVelocity.norm();
    const double speed = v.norm();
    // At the goal (or no wish to walk): prefer standing still.
    if (prefNorm <= 1e-12 || v0 <= 0) return speed * speed;

    // UMANS: an overlapped neighbour is a collision at distance 0 in every direction, so every
    // velocity costs 0/0 or ∞ there and the sampler keeps its base (zero velocity): the agent brakes.
    if (overlap_ == kOverlapStop && overlapsNeighbour(q, ctx)) return kInf;

    const Vec2 goalDir = q.prefVelocity / prefNorm;
    const Vec2 dir = speed > 1e-12 ? Vec2(v / speed) : goalDir;
    const double f = distanceToCollision(dir, v0, q, ctx);

    // Heuristic 1: squared distance between the reachable point and the goal-ward horizon point.
    const double cosDev = std::clamp(dir.dot(goalDir), -1.0, 1.0);
    const double d2 = std::max(0.0, dMax_ * dMax_ + f * f - 2.0 * dMax_ * f * cosDev);

    // Heuristic 2: the speed that allows stopping within the free distance in time τ.
    const double tau = std::max(ctx.relaxationTime, ctx.dt);
    const double vDes = std::min(v0, f / tau);
    const double rel = (vDes - speed) / std::max(vDes, 1e-3);
    return (1.0 + d2) * (1.0 + rel * rel);
}

}  // namespace ch
