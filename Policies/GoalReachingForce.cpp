// CrowdHealth — GoalReachingForce.
#include "GoalReachingForce.h"

#include <algorithm>

namespace ch {

CH_REGISTER_COMPONENT(GoalReachingForce);

ComponentInfo GoalReachingForce::Info() {
    ComponentInfo info;
    info.name = "GoalReachingForce";
    info.kind = ComponentKind::Force;
    info.defaultRange = 0.0;
    info.summary = "drives the velocity towards the preferred velocity with relaxation time RelaxationTime";
    info.reference = "Helbing & Molnar 1995, Phys. Rev. E 51(5):4282, eq. 2; van Toll et al. 2021 (K_goal)";
    info.params = {ParamSpec::real("strength", "-", 1.0, 0.0, 1e3,
                                   "K_goal: multiplies the goal acceleration (van Toll et al. 2021)")};
    info.create = [](const ParamSet& p) { return std::make_unique<GoalReachingForce>(p); };
    return info;
}

GoalReachingForce::GoalReachingForce(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "strength", strength_);
}

Vec2 GoalReachingForce::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    // The relaxation time is at least one step so the velocity never overshoots v_pref.
    return strength_ * (q.prefVelocity - q.velocity) / std::max(ctx.relaxationTime, ctx.dt);
}

}  // namespace ch
