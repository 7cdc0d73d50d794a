// CrowdHealth — PLEdestrians: least-effort velocity selection of Guy et al. (2010).
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// The biomechanical-effort cost of S. J. Guy, J. Chhugani, S. Curtis, P. Dubey, M. Lin and
/// D. Manocha, "PLEdestrians: a least-effort approach to crowd simulation", Proc. ACM
/// SIGGRAPH/Eurographics Symposium on Computer Animation (SCA), pp. 119–128, 2010 (UMANS'
/// `PLEdestrians`; goal reaching included).
///
/// Walking costs the metabolic power e_s + e_w·|v|² per unit mass (w_a = e_s = 2.23 J/(kg·s),
/// w_b = e_w = 1.26 J·s/(kg·m²)), so the cheapest steady speed is u* = √(w_a/w_b) ≈ 1.33 m/s and
/// walking a distance L at it costs 2·√(w_a·w_b)·L. A candidate velocity v is followed for the
/// horizon t = t_max, after which the agent walks straight to its goal g at u*:
///     E(v) = t_max·(w_a + w_b·|v|²) + 2·√(w_a·w_b)·|g − x − t_max·v|     (J/kg),
/// and v is inadmissible (+∞) when it collides within t_min (neighbours at their current
/// velocities, walls static). Analytic gradient
///     ∇E = 2·t_max·w_b·v − 2·√(w_a·w_b)·t_max·(g − x − t_max·v)/|g − x − t_max·v|,
/// and a closed-form unconstrained minimum: u*·ĝ when the goal is farther than u*·t_max, else
/// (g − x)/t_max (arrive exactly at the horizon); it is the global minimum when admissible,
/// otherwise the step falls back to dense sampling. Near the goal agents therefore slow down
/// over the last u*·t_max metres (an exponential approach with time constant t_max), as in the
/// paper's formulation.
///
/// Differences from UMANS: same formula and defaults (UMANS follows the velocity for exactly
/// t_max, as here); UMANS has no gradient or closed form (it samples). A neighbour or wall the
/// agent already overlaps is ignored, as in UMANS (`overlap="ignore"`, the default: contact forces
/// separate the pair); `overlap="closing"` makes every velocity that closes the gap inadmissible
/// instead — two agents that touch head-on or at a right angle then block each other for ever.
/// A goal-less agent uses g = x (it prefers to stand still).
/// Tie-break (ours): the cost carries 1e-5·(v · left of v_pref), a preference for the right-hand
/// side far below any real difference of effort. UMANS' PLEdestrians.xml samples directions in
/// world axes, so two mirror-image candidates of equal effort are decided by the world
/// orientation; in an exact head-on encounter both agents then step to the same world side and
/// block each other for ever. With the tie-break each agent decides in its own frame. Its weight
/// (1e-5 J·s/(kg·m), a millionth of the effort of a step) must outweigh the symmetry breaking
/// (Simulation@symmetry_breaking, 1e-6 m per step while held up): at 1e-9 the perturbation
/// chose the side at random and UMANS' exact head-on (1to1-180Degrees) stalled for 6 s.
/// The closed-form minimum ignores this term (it moves the optimum by ~1e-6 m/s).
class PLEdestrians : public Component {
public:
    explicit PLEdestrians(const ParamSet& params);
    static ComponentInfo Info();

    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    /// Analytic gradient of the effort; zero where v is inadmissible (the cost is +∞ there).
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    std::optional<Vec2> globalMinimum(const AgentQuery& q, const StepContext& ctx) const override;

    /// Time (s) to the first collision at velocity v (kInf if none). Exposed for tests.
    double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;

private:
    double wa_ = 2.23;   ///< J/(kg·s) = m²/s³, e_s: power spent standing
    double wb_ = 1.26;   ///< J·s/(kg·m²) = 1/s, e_w: extra power per (m/s)²
    double tMin_ = 0.5;  ///< s, velocities colliding sooner are not allowed
    double tMax_ = 3.0;  ///< s, planning horizon of a candidate velocity
    double overlap_ = 0; ///< 0 = ignore overlapped neighbours (UMANS), 1 = closing velocities inadmissible

    Vec2 goalOffset(const AgentQuery& q, const StepContext& ctx) const;
};

}  // namespace ch
