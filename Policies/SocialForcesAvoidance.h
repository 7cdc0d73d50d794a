// CrowdHealth — SocialForcesAvoidance: Helbing & Molnár's repulsive social forces.
#pragma once

#include "crowdhealth/core/registry.h"

#include <vector>

namespace ch {

/// Repulsion from other pedestrians and walls after D. Helbing and P. Molnár, "Social force model
/// for pedestrian dynamics", Phys. Rev. E 51(5):4282–4286, 1995 (eqs. 3–5, 8, 13), with UMANS'
/// parameters:
///  * pedestrians: V(b) = V0·exp(−b/σ) with the elliptic b(R) of eq. 4,
///    2b = sqrt((|R| + |R − v_β Δt e_β|)² − (v_β Δt)²); f = −∇_R V(b), the exact gradient;
///  * walls: U(R) = U0·exp(−|R|/R_wall), f = −∇U along the normal from the nearest point of each
///    obstacle (one force per obstacle), or with `walls="umans"` as UMANS 1.x: from every wall
///    segment whose outer side faces the agent, a shared corner once, weighted by the field of view;
///  * weight 1 inside the field of view (±100° around the walking direction), 0.5 behind (eq. 8);
///  * agents already in contact exert no social force (contact forces take over, as UMANS' first
///    release), unless `contactCutoff="false"` (UMANS 1.x: the force acts at every distance);
///  * the other's motion in b(R) is v_β Δt e_β (1995, `otherVelocity="preferred"`) or the
///    relative velocity (v_β − v_α)Δt (UMANS 1.x, `otherVelocity="relative"`).
/// The result is divided by the agent's mass factor. The three switches (defaults: this model as
/// first written here) and what UMANS does are in docs/policies.md.
class SocialForcesAvoidance : public ForceComponent {
public:
    explicit SocialForcesAvoidance(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    void prepare(const StepContext& ctx) override;
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;

    /// Force (per unit mass) on an agent at relative position R = x_α − x_β from a neighbour
    /// moving at speed vb in unit direction eb; no field-of-view weighting. Exposed for tests.
    Vec2 pairForce(const Vec2& R, double vb, const Vec2& eb) const;
    /// Force from a wall whose nearest point is at `diff` = x_α − nearest.
    Vec2 wallForce(const Vec2& diff) const;

    /// The pair loop's builds (issue 20), which give the same bits: 0 generic (two pairs at a time
    /// in SSE2 registers on x86-64; the only one elsewhere), 1 AVX2 (four), 2 AVX-512 (eight).
    /// The best this CPU runs is used, for every instance.
    static int pairLoopPath();
    /// Uses build `path` from now on, for every instance (tests compare the builds); returns false
    /// and changes nothing when this CPU cannot run it.
    static bool setPairLoopPath(int path);

    /// What the pair loop reads of a neighbour β (set in prepare()): its step s = v_β Δt e_β
    /// (with relative velocities v_β Δt), |s|² (0 with relative velocities: taken per pair) and
    /// its radius. 32 bytes: one cache line, not three arrays.
    struct alignas(32) Other {
        double sx, sy, stepSq, radius;
    };

private:
    /// Walls as UMANS 1.x: every segment in range whose outer side (the right of a→b: UMANS assumes
    /// counter-clockwise polygons and so do we, taking them as listed) faces the agent, skipping a
    /// segment whose nearest point is its end b, so a shared corner acts once; each weighted by the
    /// field of view like a pedestrian.
    Vec2 wallsUmans(const AgentQuery& q, const StepContext& ctx, const Vec2& heading, double cosFov) const;
    /// pairForce with the neighbour's step s = v_β Δt e_β, |s|² and |R| already known (the hot loop).
    [[gnu::always_inline]] inline Vec2 pairForce(const Vec2& R, double magR, const Vec2& step, double stepSq) const;

    std::vector<Vec2> step_;      ///< per agent, set in prepare(): v Δt e (e: preferred direction);
                                  ///< with relative velocities: v Δt (the pair's step is step_[j] − step_[i])
    std::vector<Other> other_;    ///< per agent, set in prepare(): what the pair loop reads
    double cosFov_ = 0;           ///< cos(fov), set in prepare()
    double dt_ = 2.0;       ///< s, the step Δt in b(R): how far ahead the other's motion counts
    double V0_ = 2.1;       ///< m²/s², strength of the pedestrian potential
    double sigma_ = 0.3;    ///< m, decay length of the pedestrian potential
    double U0_ = 10.0;      ///< m²/s², strength of the wall potential
    double R_ = 0.2;        ///< m, decay length of the wall potential
    double fovDeg_ = 100.0; ///< degrees, half-angle of the field of view
    double behind_ = 0.5;   ///< weight of interactions outside the field of view
    double otherVelocity_ = 0;  ///< choice: 0 preferred (v_β Δt e_β), 1 relative ((v_β − v_α)Δt)
    double contactCutoff_ = 1;  ///< bool: pairs whose bodies overlap exert no social force
    double walls_ = 0;          ///< choice: 0 nearest (one per obstacle), 1 umans (per facing segment)
};

}  // namespace ch
