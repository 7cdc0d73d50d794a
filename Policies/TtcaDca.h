// CrowdHealth — TtcaDca: Dutra et al.'s vision-based cost on time and distance to closest approach.
#pragma once

#include "crowdhealth/core/registry.h"

#include <vector>

namespace ch {

/// The navigation cost of T. B. Dutra, R. Marques, J. B. Cavalcante-Neto, C. A. Vidal and
/// J. Pettré, "Gradient-based steering for vision-based crowd simulation algorithms", Computer
/// Graphics Forum 36(2):337–348, 2017 (Eurographics) — UMANS' `TtcaDca` with its parameters
/// `sigmaTtca`, `sigmaDca`, `sigmaAngle_goal`, `sigmaSpeed_goal`; used with the gradient method
/// (policies/Dutra.xml, coeff 20). It already contains its goal-reaching part.
///
/// Perception, as in the paper, is a synthetic camera: `pixels` rays spread evenly over a field of
/// view `fov` around the agent's viewing direction (UMANS' view direction: mostly the velocity),
/// each seeing the nearest obstacle it hits within `range` — neighbours as discs grown by the
/// agent's radius r_i (so the agent counts as a point and dca is the clearance between bodies),
/// walls as segments grown by r_i. Occlusion is exact (a depth buffer). A pixel seeing point p
/// (relative to the agent) that moves at u_p (the neighbour's velocity, 0 for walls) gives, for a
/// candidate velocity v, with w = u_p − v:
///   ttca = max(0, −p·w/|w|²)   (0 when w = 0),   dca = |p + ttca·w|,
///   C_o,p = exp(−½[(ttca/σ_ttca)² + (dca/σ_dca)²]);   C_o = mean of C_o,p over the pixels that see
///   something (0 if none).
/// Movement: C_m = 1 − (C_α + C_s)/2 with C_α = exp(−½(α/σ_α)²), α the angle between v and the
/// preferred velocity, and C_s = exp(−½((|v| − |v_pref|)/σ_s)²). cost(v) = C_m + C_o.
///
/// `gradient()` is the exact Euclidean gradient ∇_v cost (the pixel set depends on the position and
/// view direction only, not on v) and matches central differences of `cost()`; where ∇ is not
/// defined (v = 0) the speed part points along the preferred velocity so an agent at rest starts
/// walking. The pixel rays sit a quarter pixel off-centre, so no ray lies exactly on the viewing
/// direction and a perfectly symmetric encounter is not perfectly balanced (both agents then
/// swerve the same way in their own frames and pass each other).
///
/// Two visions (parameter `vision`):
///  * `umans` (default, what UMANS 1.x computes): one term per neighbour within range and within
///    fov/2 of the agent's current velocity, ttca/dca from the centre-to-centre offset shortened
///    by both radii (and UMANS' correction of the relative velocity along the offset's normal),
///    weighted by 1/distance² to mimic pixel counts, no walls; the paper's derivatives in
///    (heading, speed) space (eq. 14–17, 29–37, goal terms with UMANS' 1/(2σ²)), mapped back to
///    velocity space by turning the velocity by the heading derivative (sin h·|v| sideways,
///    (1 − cos h)·|v| backwards) plus the speed derivative along it — not the gradient of
///    `cost()`, which is the per-neighbour cost. UMANS' examples behave as in UMANS with it
///    (Circle5–50, Formation: within 10 % of UMANS' mean arrival times).
///  * `pixels` (ours): rendered pixels as described above, with occlusion and walls, and the plain
///    gradient of the cost in velocity space, whose angular part is divided by |v| with respect to
///    the paper's heading derivative. The target speed is |v_pref| (0 at the goal) instead of the
///    nominal preferred speed. Its agents avoid earlier and wider than UMANS' (Circle10: 12.5 s
///    against 8.3 s) and, going fast past their goal, some circle it for ever (Circle15/25/50).
class TtcaDca : public Component {
public:
    explicit TtcaDca(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// What one pixel sees: a point relative to the agent and that point's velocity.
    struct Pixel {
        Vec2 point;
        Vec2 velocity;
    };
    /// Renders the agent's view (pixels that see nothing are left out).
    void perceive(const AgentQuery& q, const StepContext& ctx, std::vector<Pixel>& out) const;

private:
    /// C_o,p for one pixel; adds its gradient with respect to v to *grad when given.
    double pixelCost(const Vec2& v, const Pixel& px, Vec2* grad) const;
    /// C_m; adds its gradient to *grad when given.
    double movementCost(const Vec2& v, const AgentQuery& q, Vec2* grad) const;

    double sigmaTtca_ = 1.0;   ///< s
    double sigmaDca_ = 0.3;    ///< m
    double sigmaAngle_ = 2.0;  ///< rad
    double sigmaSpeed_ = 2.0;  ///< m/s
    double fovDeg_ = 180.0;    ///< degrees, full horizontal field of view
    double pixels_ = 256;      ///< number of pixel rays across the field of view
    double vision_ = 1;        ///< 0 = pixels, 1 = umans (per neighbour, UMANS 1.x; default)
    static constexpr double kVisionUmans = 1;

    /// One neighbour's term in the `umans` vision: its cost, weight 1/distance², and the
    /// derivatives of its cost with respect to heading (rad⁻¹) and speed (s/m).
    struct NeighbourTerm {
        bool valid = false, derivable = true;
        double cost = 0, weight = 0, heading = 0, speed = 0;
    };
    NeighbourTerm neighbourTerm(const Vec2& v, const AgentQuery& q, const StepContext& ctx,
                                const NeighbourAgent& n) const;
    bool inView(const AgentQuery& q, const NeighbourAgent& n) const;
    double umansCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;
    Vec2 umansGradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;
};

}  // namespace ch
