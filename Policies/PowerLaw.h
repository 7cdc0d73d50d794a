// CrowdHealth — PowerLaw: the time-to-collision interaction energy of Karamouzas, Skinner & Guy (2014).
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// The anticipatory interaction law of I. Karamouzas, B. Skinner and S. J. Guy, "Universal power
/// law governing pedestrian interactions", Phys. Rev. Lett. 113:238701, 2014 (and its supplemental
/// material), as a force (UMANS' `PowerLaw`; combine with GoalReachingForce, gradient method).
///
/// For a neighbour j, with x = x_i − x_j, v = v_i − v_j, R = r_i + r_j, the time to collision τ
/// is the smallest positive root of |x + τv| = R:
///     a = v·v, b = −x·v, c = x·x − R², D = b² − ac,  τ = (b − √D)/a.
/// The interaction energy is E(τ) = k/τ² · e^{−τ/τ0} and the force is its exact negative gradient
/// with respect to x (implicit differentiation of the root gives ∇_x τ = (x + τv)/√D):
///     F = −dE/dτ · ∇_x τ = k·e^{−τ/τ0}/τ² · (2/τ + 1/τ0) · (x + τv)/√D,
/// pointing from the predicted contact point of j towards i. The acceleration is F divided by
/// the agent's mass factor. Pairs that overlap already (c ≤ 0) or are not on a collision course
/// feel nothing (contact forces take over), and, as in UMANS, interactions with τ > τ0 are
/// dropped (where e^{−τ/τ0} ≤ e^{−1}).
///
/// Walls (`walls`, on by default): the same energy with τ the time until the agent's disc, moving
/// at v_i, touches the static segment (an endpoint: the formula above with v_j = 0 and R = r_i;
/// the interior: τ = (s − r_i)/u with s the distance to the supporting line and u the approach
/// speed, ∇τ = n/u). The paper gives no wall law; this is the same energy applied to walls.
///
/// Differences from UMANS: UMANS' comments call the τ derivation "incorrect"; it is in fact the
/// exact root and gradient above (the two expressions are algebraically equal). UMANS ignores
/// walls (set `walls="false"` for its behaviour), divides by a fixed `agentMass` parameter
/// instead of the agent's mass, and drops pairs with τ < 1 ms, where the force is largest; here
/// only τ ≤ 0 is dropped and the acceleration clamp of the step bounds the result.
class PowerLaw : public ForceComponent {
public:
    explicit PowerLaw(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;

    /// E (m²/s² per unit mass) for relative position x, relative velocity v and radius sum R;
    /// 0 when there is no collision within (0, τ0]. Exposed for tests.
    double pairEnergy(const Vec2& x, const Vec2& v, double R) const;
    /// −∇_x E for the same arguments (per unit mass). Exposed for tests.
    Vec2 pairForce(const Vec2& x, const Vec2& v, double R) const;
    /// E and −∇_p E for a disc of radius r at p moving at v towards the static segment [a, b].
    double wallEnergy(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b) const;
    Vec2 wallForce(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b) const;

private:
    double k_ = 1.5;     ///< m² per unit mass (energy scale)
    double tau0_ = 3.0;  ///< s, interaction time horizon
    double walls_ = 1;   ///< apply the law to wall segments too (0/1)

    /// −dE/dτ (> 0), the common factor of every force.
    double forceFactor(double tau) const;
};

}  // namespace ch
