// CrowdHealth — VanToll: distance to collision plus deviations from preferred and current motion.
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// The local navigation cost used by W. van Toll and J. Pettré, "Connecting global and local agent
/// navigation via topology", ACM SIGGRAPH Conference on Motion, Interaction and Games (MIG) 2019,
/// 33:1–33:10 (extended: "Synchronizing navigation algorithms for crowd simulation via topological
/// strategies", Computers & Graphics 89, 2020) — UMANS' `VanToll`, parameter `max_distance`. It already
/// contains its goal-reaching part; UMANS pairs it with regular sampling in a 180° cone around the
/// preferred velocity (policies/VanToll.xml). For a candidate velocity v with speed s:
///
///   cost(v) = (d_max − min(d_c(v), d_max))          [m]   how soon the agent would hit something
///           + ∠(v, v_pref)                          [rad] deviation from the preferred direction
///           + |s − |v_pref|| / |v_pref|             [-]   relative deviation from the preferred speed
///           + ∠(v, v_current)                       [rad] change of direction (smoothness)
///
/// where d_c(v) = s·t_c(v) is the distance walked before the first collision with a neighbour in
/// range (which keeps its current velocity) or a wall in range, and d_max = `max_distance`.
/// The terms have unit weights and mixed units, as in the original. An angle with a zero vector
/// is 0, so at rest the smoothness term vanishes.
///
/// Difference from UMANS: a neighbour or wall the agent already overlaps counts as a collision at
/// t = 0 only for velocities that bring the two closer; UMANS counts it for every velocity, which
/// makes the collision term constant (no way out) as long as the overlap lasts.
class VanToll : public Component {
public:
    explicit VanToll(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// Time (s) until the agent moving at v first touches a neighbour or wall in range (kInf if never).
    double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;

private:
    double maxDistance_ = 8.0;  ///< m, distances to collision beyond this cost nothing
};

}  // namespace ch
