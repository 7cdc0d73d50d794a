// CrowdHealth — default behaviour of components (numerical gradient, force-based cost).
#include "crowdhealth/component.h"

#include <cmath>
#include <limits>

namespace ch {

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
