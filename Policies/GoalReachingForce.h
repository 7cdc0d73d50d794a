// CrowdHealth — GoalReachingForce: relaxation of the velocity towards the preferred velocity.
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// a_goal = strength · (v_pref − v) / max(τ, Δt), with τ the evaluating step's RelaxationTime.
/// Helbing & Molnár (1995), "Social force model for pedestrian dynamics", Phys. Rev. E 51(5),
/// eq. 2 (the driving term); UMANS' GoalReachingForce; `strength` is K_goal of van Toll et al.
/// (2021). Independent of the agent's mass: it is a desire, not a body force.
class GoalReachingForce : public ForceComponent {
public:
    explicit GoalReachingForce(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only the query
    bool readsQueryAgents() const override { return false; }
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;

private:
    double strength_ = 1.0;  ///< K_goal, dimensionless
};

}  // namespace ch
