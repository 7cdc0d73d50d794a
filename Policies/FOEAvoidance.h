// CrowdHealth — FOEAvoidance: collision avoidance from each neighbour's focus of expansion.
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// Optical-flow based avoidance after A. López, F. Chaumette, E. Marchand and J. Pettré,
/// "Character navigation in dynamic environments based on optical flow", Computer Graphics Forum
/// 38(2):181–192, 2019 (Eurographics) — UMANS' `FOEAvoidance`, used with GoalReachingForce and the
/// gradient method (policies/FOEAvoidance.xml). Avoidance only: it has no goal term.
///
/// The agent looks along its candidate velocity v (a 1D pinhole camera: depth axis f = v/|v|,
/// image axis e = f rotated by −90°). A neighbour j at relative position P with relative velocity
/// V = v_j − v has image position x_g = (P·e)/(P·f) and focus of expansion x_f = (V·e)/(V·f): its
/// image flow radiates from x_f, so |x_g − x_f| small means a collision course. Only neighbours
/// ahead (P·f > 0.1 m) and closing in depth (V·f < −0.01 m/s) count:
///
///   cost(v) = Σ_j I(t_j)·exp(−|x_g − x_f| / σ_j),  σ_j = ((r_i + r_j)/(P·f)) / ln 10,
///   t_j = −(P·f)/(V·f)  (time until j reaches the agent's lateral line),
///   I(t) = clamp(I0 − (I0/t0)·t, I_min, I0) for 0 ≤ t ≤ t_max, 0 otherwise
///
/// (σ_j makes the cost fall to a tenth at the edge of j's image). Since
/// |x_g − x_f|·(P·f) = |P×V|/|V·f| is the lateral miss distance m_j at t_j, the term is
/// I(t_j)·10^(−m_j/(r_i+r_j)); we implement that form and its exact gradient with respect to v
/// (`gradient()` matches central differences of `cost()`), with sign(0) := +1 so that an exact
/// collision course (m_j = 0) is left towards the agent's right. At v = 0 there is no camera:
/// cost and gradient are 0.
///
/// Differences from UMANS: UMANS returns a heuristic "gradient" built from its own derivatives
/// with respect to heading and speed (heading part clamped to ±0.1 rad, sign(0) = 0 so a perfect
/// head-on stays head-on); ours is the true gradient of the cost. UMANS hard-codes I0 = 10,
/// t0 = 5 s, I_min = 0.1 and t_max = 10 s; they are parameters here with those defaults. Walls
/// are ignored, as in UMANS.
class FOEAvoidance : public Component {
public:
    explicit FOEAvoidance(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// One neighbour's term at candidate v: P = x_j − x_i, u = v_j, R = r_i + r_j. Adds its
    /// gradient with respect to v to *grad when given.
    double pairCost(const Vec2& v, const Vec2& P, const Vec2& u, double R, Vec2* grad) const;

private:
    double importance(double ttc, double* slope) const;

    double importanceMax_ = 10.0;  ///< I0, importance of an imminent collision
    double importanceTime_ = 5.0;  ///< s, t0: the linear importance reaches 0 at this time
    double importanceMin_ = 0.1;   ///< I_min, floor of the importance up to max_ttc
    double maxTtc_ = 10.0;         ///< s, later crossings are ignored
};

}  // namespace ch
