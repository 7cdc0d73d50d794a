// CrowdHealth — RVO: reciprocal velocity obstacles (van den Berg, Lin & Manocha 2008).
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// RVO — J. van den Berg, M. Lin and D. Manocha, "Reciprocal velocity obstacles for real-time
/// multi-agent navigation", IEEE International Conference on Robotics and Automation (ICRA 2008),
/// pp. 1928–1935.
///
/// The paper's penalty of a candidate velocity v' (its velocity-selection step):
///     penalty(v') = w / tc(v') + |v_pref − v'|,
/// where tc(v') is the time to the first collision when moving at v' within the reciprocal velocity
/// obstacles: v' ∈ RVO_B(v_B, v_A) ⇔ 2v' − v_A ∈ VO_B(v_B), so against an agent B the time to
/// collision is that of the relative velocity (2v' − v_A) − v_B of the discs of radius r_A + r_B;
/// against a static wall segment (which does not reciprocate) it is that of v' itself (plain VO).
/// w (parameter `w`, m) is the aggressiveness: how much deviation from v_pref is worth one unit of
/// 1/tc. tc = ∞ (no collision ahead) gives 0. The paper, like UMANS' RVO.xml, minimises it over
/// random samples of admissible velocities (SamplingType="random", around the current velocity,
/// radius = max_acceleration·Δt, 250 samples); it has no closed-form minimum and no gradient (the
/// penalty jumps where a velocity enters a velocity obstacle), so gradient() is the default
/// finite difference.
///
/// As in UMANS, pairs that already overlap are left out of tc (contact forces separate them), and
/// only neighbours and walls within `range` count.
/// Differences from UMANS' RVO:
///  * walls use the velocity obstacle of v' (UMANS applies the reciprocal 2v' − v_A to walls too);
///  * a velocity faster than max_speed costs 1e9 + (|v'| − max_speed) rather than the largest float,
///    so it is never preferred to an admissible one but the least excessive one still wins when no
///    admissible sample exists (UMANS then falls back to the zero velocity).
class RVO : public Component {
public:
    explicit RVO(const ParamSet& params);
    static ComponentInfo Info();
    /// |v_pref − v'| for an admissible speed (the collision term is ≥ 0), the cost itself above max_speed.
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double costLowerBound(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// The time to the first collision tc(v') of the paper (s; kInf if none ahead).
    double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;

    static constexpr double kOverSpeedCost = 1e9;

private:
    double w_ = 1.0;  ///< m, weight of the collision-time term
};

}  // namespace ch
