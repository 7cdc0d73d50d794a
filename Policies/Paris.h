// CrowdHealth — Paris: predictive avoidance by admissible speeds per walking direction.
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// Predictive collision avoidance after S. Paris, J. Pettré and S. Donikian, "Pedestrian reactive
/// navigation for crowd simulation: a predictive approach", Computer Graphics Forum 26(3):665–674,
/// 2007 (Eurographics), written as a cost over candidate velocities (UMANS' name `Paris`, with its
/// parameters `w_a`, `w_b`, `t_max`). It already contains its goal-reaching part; UMANS pairs it
/// with regular sampling (policies/Paris.xml).
///
/// For a candidate velocity v = s·d (speed s, unit direction d) and each neighbour j in range, the
/// paper predicts the interaction along direction d: the agent may pass *before* j (fast enough)
/// or *after* j (slow enough); the speeds in between collide. We compute that interval of
/// forbidden speeds [s_lo, s_hi] exactly: it is the intersection of the ray {s·d, s ≥ 0} with j's
/// velocity obstacle truncated at the horizon t_max (disc of radius r_i + r_j, j keeping its
/// current velocity) — a convex set, so the intersection is one interval. Then
///  * C_speed,j = min(1, min(ps − s_lo, s_hi − ps)/ps) when the preferred speed ps is forbidden
///    (the relative speed change needed to avoid j in this direction), else 0;
///  * C_pred,j  = 1 − t1/(t_max + w_b), t1 the time to collision at speed ps (near conflicts
///    weigh more; w_b softens the decay);
///  * C_angle   = (1 − cos∠(d, v_pref))/2 + (κ·b + 10⁻⁶)·sin∠(v_pref, d), with b = min(1, Σ_j
///    C_speed,j·C_pred,j along v_pref itself) and κ = `side_preference` (CrowdHealth extension,
///    default 0.05): when the way to the goal is blocked, detours to the right are cheaper ("keep
///    right"); when it is free, nothing changes. Without it, two agents in a mirror-symmetric
///    encounter (head-on, or a 90° crossing with equal distances) make mirror-image choices: they
///    dodge to the same side of the world, or both pass in front, and end up side by side pushing
///    each other forever. The 10⁻⁶ part breaks exact ties in the agent's own frame (the sampling
///    order would break them in the world frame);
///  * direction cost C_dir(d) = w_a·Σ_j C_speed,j·C_pred,j + (1 − w_a)·C_angle;
///  * speed cost C_s(v) = Σ_j min(s − s_lo, s_hi − s)/ps for every j whose forbidden interval
///    contains s (how deep the speed lies inside it);
///  * cost(v) = 1000·C_dir + C_s + 0.001·|v − v_pref|: the direction is chosen first, then a
///    collision-free speed, then the one closest to the preferred velocity (UMANS' weights).
/// Static walls give the forbidden interval [D/t_max, ∞), D the distance the agent can walk along
/// d before touching the wall.
///
/// Two variants (parameter `variant`):
///  * `umans` (default): what UMANS 1.x computes, re-implemented (umansCost): per neighbour in
///    range, the crossing point X of the agent's line along the candidate direction and the
///    neighbour's path at its current velocity; the neighbour covers X from t1 (time to come within
///    the radius sum R of X, capped at t_max) to t2 = t1 + R/|u| (0 past t_max); s1 = |X|/t1,
///    s2 = |X|/t2; a crossing the agent would not reach within t_max at its *current* velocity is
///    ignored, parallel paths count as a conflict over the whole horizon if walking along d at
///    1 m/s collides within t_max. Direction cost w_a·mean_j C_speed,j·C_pred,j + (1 − w_a)·
///    (1 − cos φ)/2 with C_speed = min(max(0, 1 − s1/v_p), max(0, (s2 − v_p)/v_p)),
///    C_pred = 1 − t1/(t_max + w_b); speed cost Σ_j max(0, (s1 − s)/v_p, (s − s2)/v_p); total
///    1000·direction + speed + 0.001·|v − v_pref|. No walls. UMANS' Paris examples then behave as
///    in UMANS (Circle25: 38.6 s against 39.7 s, Circle50: 86.1 against 87.4); bodies overlap
///    (up to 0.2 m there, as in UMANS).
///  * `exact`: the interval model described above, ours. Its differences from UMANS:
///  * UMANS derives t1, t2 from the crossing point of the two paths, measuring the agent's own
///    arrival with its *current* velocity (so an agent at rest avoids nobody) and swapping the
///    roles of s1 and s2, which makes its C_speed identically zero and its speed cost penalise
///    every speed. We use the exact interval above, also valid for parallel paths (head-on).
///  * Σ_j instead of UMANS' mean over every neighbour in range, which dilutes one conflict by the
///    number of uninvolved neighbours around.
///  * Walls are avoided (UMANS ignores obstacles in this cost function).
///  * Neighbours overlapping the agent forbid the speeds that bring the centres closer.
///  * The right-hand preference (`side_preference`; 0 turns it off).
/// Cost per candidate: two passes over the neighbours (the direction and the preferred direction).
class Paris : public Component {
public:
    explicit Paris(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// A closed interval of speeds (m/s); empty when hi < lo. hi may be +∞.
    struct SpeedInterval {
        double lo = 1.0, hi = 0.0;
        bool empty() const { return !(hi >= lo); }
        bool contains(double s) const { return !empty() && s >= lo && s <= hi; }
    };
    /// Speeds s ≥ 0 for which the agent moving at s·d (d a unit vector) touches, within `horizon`
    /// seconds, a disc of radius R whose centre is at `rel` from the agent and moves at `u`.
    static SpeedInterval forbiddenSpeeds(const Vec2& d, const Vec2& rel, const Vec2& u, double R, double horizon);
    /// The same for a disc of radius r at p and the static segment [a, b].
    static SpeedInterval forbiddenSpeedsWall(const Vec2& d, const Vec2& p, double r, const Vec2& a, const Vec2& b,
                                             double horizon);

private:
    /// Σ_j C_speed,j·C_pred,j along unit direction d; adds the speed cost of speed s to *deviation.
    double conflictAlong(const Vec2& d, double ps, double s, const AgentQuery& q, const StepContext& ctx,
                         double* deviation) const;

    double wA_ = 0.5;   ///< weight of the avoidance part of the direction cost
    double wB_ = 0.0;   ///< s, softens how fast a conflict's weight decays with its time
    double tMax_ = 8.0; ///< s, prediction horizon
    double sideBias_ = 0.05;  ///< preference for right-hand detours when the preferred direction is blocked
    double variant_ = 1;      ///< 0 = exact, 1 = umans (UMANS 1.x; default)
    static constexpr double kVariantUmans = 1;

    /// One neighbour's conflict in the `umans` variant: the neighbour covers the crossing point
    /// from t1 to t2 (s); the agent passes in front above speed s1, behind below s2 (m/s).
    struct UmansConflict {
        double t1, t2, s1, s2;
    };
    UmansConflict umansConflict(const Vec2& d, const AgentQuery& q, const StepContext& ctx,
                                const NeighbourAgent& n) const;
    double umansCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;
};

}  // namespace ch
