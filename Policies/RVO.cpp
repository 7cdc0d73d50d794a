// CrowdHealth — RVO (van den Berg, Lin & Manocha 2008): the penalty of a candidate velocity.
#include "RVO.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(RVO);

ComponentInfo RVO::Info() {
    ComponentInfo info;
    info.name = "RVO";
    info.kind = ComponentKind::CostFunction;
    info.summary = "reciprocal velocity obstacles: w/time-to-collision + |v_pref - v| (includes goal reaching; "
                   "meant for random sampling)";
    info.reference = "van den Berg, Lin & Manocha 2008, Reciprocal velocity obstacles for real-time multi-agent "
                     "navigation, ICRA 2008, pp. 1928-1935";
    info.params = {ParamSpec::real("w", "m", 1.0, 0.0, 1e6,
                                   "aggressiveness weight of the 1/time-to-collision term of the penalty")};
    info.create = [](const ParamSet& p) { return std::make_unique<RVO>(p); };
    return info;
}

RVO::RVO(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "w", w_);
}

double RVO::timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const AgentStore& A = ctx.agents;
    double tc = kInf;
    // Against agents: the reciprocal velocity 2v' − v_A relative to the neighbour's velocity.
    const Vec2 reciprocal = 2.0 * v - q.velocity;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        const double t = timeToCollision(Vec2(0, 0), reciprocal, q.radius, n.offset, A.vel[n.index], A.radius[n.index]);
        if (t > 0) tc = std::min(tc, t);  // 0: overlapping already, left to contact forces
    }
    // Against walls: the velocity obstacle of v' itself.
    for (int s : q.segments) {
        const Segment& seg = ctx.world.segments()[s];
        if (distanceToSegmentSquared(q.position, seg.a, seg.b) > range_ * range_) continue;
        const double t = timeToCollisionSegment(q.position, v, q.radius, seg.a, seg.b);
        if (t > 0) tc = std::min(tc, t);
    }
    return tc;
}

double RVO::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const double speed = v.norm();
    if (speed > q.maxSpeed) return kOverSpeedCost + (speed - q.maxSpeed);
    const double tc = timeToFirstCollision(v, q, ctx);
    const double collision = std::isfinite(tc) ? w_ / tc : 0.0;
    return collision + (q.prefVelocity - v).norm();
}

double RVO::costLowerBound(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    (void)ctx;
    const double speed = v.norm();
    if (speed > q.maxSpeed) return kOverSpeedCost + (speed - q.maxSpeed);
    return (q.prefVelocity - v).norm();
}

}  // namespace ch
