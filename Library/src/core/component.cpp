// CrowdHealth — default behaviour of components (numerical gradient, force-based cost).
#include "crowdhealth/core/component.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ch {

void StepContext::segmentsNearScan(std::size_t i, double radius, std::vector<int>& out) const {
    if (!listReaches(i, radius)) {
        world.segmentsNear(agents.pos[i], radius, out);
        return;
    }
    // The list is a superset; the segment grid's own test picks the same segments, in order.
    out.clear();
    const double r2 = radius * radius;
    const Vec2& p = agents.pos[i];
    for (int s : lists->segments(i)) {
        const Segment& seg = world.segments()[static_cast<std::size_t>(s)];
        if (distanceToSegmentSquared(p, seg.a, seg.b) <= r2) out.push_back(s);
    }
}

double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx, double range) {
    return timeToFirstCollision(v, q, ctx, range, OverlapRule::Closing);
}

double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx, double range, OverlapRule rule) {
    const bool closing = rule == OverlapRule::Closing;
    const AgentStore& A = ctx.agents;
    double first = kInf;
    for (const NeighbourAgent& n : q.agents) {
        const double d2 = n.distanceSquared();
        if (d2 > range * range) continue;
        const Vec2& vj = A.vel[n.index];
        const double rj = A.radius[n.index];
        if (d2 <= (q.radius + rj) * (q.radius + rj)) {
            if (closing && (v - vj).dot(n.offset) > 0) return 0.0;
            continue;
        }
        first = std::min(first, timeToCollision(Vec2(0, 0), v, q.radius, n.offset, vj, rj));
    }
    for (int s : q.segments) {
        const Segment& seg = ctx.world.segments()[s];
        const Vec2 toWall = closestPointOnSegment(q.position, seg.a, seg.b) - q.position;
        const double d2 = toWall.squaredNorm();
        if (d2 > range * range) continue;
        if (d2 <= q.radius * q.radius) {
            if (closing && v.dot(toWall) > 0) return 0.0;
            continue;
        }
        first = std::min(first, timeToCollisionSegment(q.position, v, q.radius, seg.a, seg.b));
    }
    return first;
}

Vec2 Component::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    // Central differences; δ = 0.1 m/s as UMANS, large enough to smooth sampling noise in costs.
    const double d = 0.1;
    const double gx = (cost(v + Vec2(d, 0), q, ctx) - cost(v - Vec2(d, 0), q, ctx)) / (2 * d);
    const double gy = (cost(v + Vec2(0, d), q, ctx) - cost(v - Vec2(0, d), q, ctx)) / (2 * d);
    return {gx, gy};
}

void Component::bind(const ParamSet& params, const std::string& name, double& member) {
    member = params.get(name);
    bound_[name] = &member;
}

bool Component::setParameter(const std::string& name, double value) {
    auto it = bound_.find(name);
    if (it == bound_.end()) return false;
    *it->second = value;
    return true;
}

double Component::parameter(const std::string& name) const {
    auto it = bound_.find(name);
    return it == bound_.end() ? std::numeric_limits<double>::quiet_NaN() : *it->second;
}

double ForceComponent::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const Vec2 target = q.velocity + acceleration(q, ctx) * ctx.dt;
    return (v - target).squaredNorm() / (2.0 * ctx.dt);
}

Vec2 ForceComponent::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const Vec2 target = q.velocity + acceleration(q, ctx) * ctx.dt;
    return (v - target) / ctx.dt;  // equals -acceleration at the current velocity
}

std::optional<Vec2> ForceComponent::globalMinimum(const AgentQuery& q, const StepContext& ctx) const {
    return Vec2(q.velocity + acceleration(q, ctx) * ctx.dt);
}

}  // namespace ch
