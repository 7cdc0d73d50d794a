// CrowdHealth — Moussaid: the vision-based heuristics of Moussaïd, Helbing & Theraulaz (2011).
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// The two behavioural heuristics of M. Moussaïd, D. Helbing and G. Theraulaz, "How simple rules
/// determine pedestrian behavior and crowd disasters", PNAS 108(17):6884–6888, 2011, as a cost
/// over candidate velocities (UMANS' `Moussaid`; goal reaching included).
///
/// For a walking direction α, f(α) ∈ [0, d_max] is the distance the pedestrian can walk along α at
/// its preferred speed v0 before the first collision, the others keeping their current velocities
/// (walls static), capped at the horizon d_max.
///  * Heuristic 1 (direction): minimise the distance from the point reached, f(α) along α, to the
///    point d_max ahead in the goal direction α0:  d(α)² = d_max² + f(α)² − 2·d_max·f(α)·cos(α0 − α).
///  * Heuristic 2 (speed): walk at v_des(α) = min(v0, f(α)/τ), τ the relaxation time (paper:
///    0.5 s; here the policy step's RelaxationTime, at least one step).
/// Cost of a candidate v with direction α and speed s:
///    C(v) = (1 m² + d(α)²) · (1 + ((v_des(α) − s)/v_des(α))²),
/// minimal — over the sampled set — at the direction of heuristic 1 walked at the speed of
/// heuristic 2 (the product keeps the direction choice independent of the speed samples). The
/// +1 m² keeps the speed term active when d(α) = 0. The vision field of the paper (±75° around the
/// line of sight) is the policy's sampling cone (UMANS' Moussaid.xml samples ±90° around v_pref).
///
/// Differences from UMANS (same formula otherwise):
///  * a direction blocked now (f = 0, so v_des = 0) gives in UMANS a 0/0 cost (NaN); here the
///    relative speed error uses max(v_des, 1 mm/s), so only standing still is cheap there;
///  * a neighbour the agent already overlaps: UMANS counts it as a collision at distance 0 in every
///    direction, so no candidate has a finite cost and the agent brakes towards standing still
///    until contact forces separate the pair; `overlap="stop"` (default) does the same,
///    `overlap="closing"` blocks only the directions that close the gap;
///  * RelaxationTime 0 would divide by zero in UMANS; here τ is at least the step's Δt;
///  * the zero velocity takes the preferred direction (UMANS: undefined direction, NaN cost).
class Moussaid : public Component {
public:
    explicit Moussaid(const ParamSet& params);
    static ComponentInfo Info();

    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// f(α): distance (m) to the first collision walking along unit direction `dir` at `speed`,
    /// capped at d_max. Exposed for tests.
    double distanceToCollision(const Vec2& dir, double speed, const AgentQuery& q, const StepContext& ctx) const;

private:
    static constexpr double kOverlapStop = 0;  ///< `overlap` choice index of "stop"
    bool overlapsNeighbour(const AgentQuery& q, const StepContext& ctx) const;
    double dMax_ = 8.0;  ///< m, horizon distance (paper: 10 m; UMANS default 8 m)
    double overlap_ = kOverlapStop;  ///< 0 = stop (UMANS), 1 = closing
};

}  // namespace ch
