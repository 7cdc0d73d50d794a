// CrowdHealth — Karamouzas: velocity-based collision avoidance with a time-to-collision-dependent
// admissible velocity set (Karamouzas & Overmars 2010).
#pragma once

#include "crowdhealth/core/registry.h"

#include <utility>

namespace ch {

/// The velocity-selection model of I. Karamouzas and M. Overmars, "A velocity-based approach for
/// simulating human collision avoidance", Proc. Intelligent Virtual Agents (IVA 2010), LNCS 6356,
/// pp. 180–186, Springer 2010 (extended in "Simulating and evaluating the local behavior of small
/// pedestrian groups", IEEE TVCG 18(3):394–406, 2012). It continues the predictive,
/// time-to-collision based avoidance of Karamouzas, Heil, van Beek & Overmars, "A predictive
/// collision avoidance model for pedestrian simulation", MIG 2009, LNCS 5884, pp. 41–52. This is
/// what UMANS calls `Karamouzas`; it already contains goal reaching.
///
/// Let t_c⁰ be the time to the first collision when walking at the preferred velocity v_pref.
/// It decides which candidate velocities v are admissible (the others rank last, see below):
///  * deviation φ = ∠(v, v_pref) ≤ φ_max(t_c⁰) with φ_max = d_max… d_min:
///      t_c⁰ <  tc_min:          d_mid + ((tc_min − t_c⁰)/tc_min)²·(d_max − d_mid)  (quadratic)
///      tc_min ≤ t_c⁰ < tc_mid:  d_mid
///      tc_mid ≤ t_c⁰ < t_max:   linear from d_mid (at tc_mid) down to d_min (at t_max)
///      t_c⁰ ≥ t_max (or none):  d_min
///    with d_min = 0.05 rad (≈ 0, kept positive for round-off), d_mid = π/6, d_max = π/2;
///  * speed |v| ∈ [u_pref − ε, u_pref + ε] when t_c⁰ ≥ t_max, [0, u_max + ε] when t_c⁰ < tc_min,
///    [u_pref − Δ − ε, u_pref + Δ + ε] in between, Δ = |u_max − u_pref|, ε = 0.05 m/s.
/// Among admissible velocities the cost is
///   C(v) = α·(1 − cos φ)/2 + β·| |v| − |v_cur| |/u_max + γ·|v − v_pref|/(2u_max)
///          + δ·max(0, t_max − t_c(v))/t_max,
/// t_c(v) being the time to the first collision (agents moving at their current velocities,
/// walls static) at candidate velocity v. It is meant for regular sampling (UMANS' Karamouzas.xml);
/// velocities outside the admissible set cost 10⁶ and more (see below).
///
/// Differences from UMANS:
///  * UMANS' linear branch of φ_max is d_min + d_mid − (t_max − t_c⁰)/(t_max − tc_mid), which is
///    negative for t_c⁰ ∈ [6, ≈6.85) s (every velocity is rejected and the agent brakes to a stop)
///    and ends at d_min + d_mid instead of d_min at t_max. We use the linear interpolation the
///    model describes.
///  * UMANS writes the first term as α(1 − cos φ / 2) = α/2 + α(1 − cos φ)/2: a constant offset,
///    the same minimiser.
///  * UMANS keeps tc_max = 8 s even when `t_max` is changed; here the last threshold is `t_max`.
///    `tc_min` and `tc_mid` are parameters (UMANS constants 2.5 s and 6 s).
///  * A neighbour (or wall) the agent already overlaps is ignored, as in UMANS (`overlap="ignore"`,
///    the default; contact forces separate the pair). `overlap="closing"` counts it as a collision
///    at t = 0 for velocities that close the gap (ignored for velocities that open it), so the agent
///    is never rewarded for pushing deeper into someone — but two agents that touch at a right
///    angle then hold each other up (UMANS' 1to1-90Degrees example: 54 s instead of 12 s).
///  * UMANS gives inadmissible velocities the cost +∞ (FLT_MAX). On a fixed sample grid the
///    admissible set is often empty: with nothing ahead it is a 0.1 m/s-wide ring segment of
///    ±3°, and UMANS' Karamouzas.xml puts speed rings every u_max/14 (0.114 m/s for 1.6 m/s), so
///    an agent whose preferred speed falls between rings (e.g. 1.2 m/s) has no admissible sample,
///    falls back to the zero velocity and stands still for ever (with that rule, agents of
///    UMANS' OneWayFlow100 example stood still from the start).
///    Here an inadmissible velocity costs 10⁶·(1 + e) + C(v), e = excess angle/90° + excess
///    speed/u_max: every admissible velocity still beats every inadmissible one, and when none
///    was sampled the nearest to the admissible set is taken.
///  * The zero velocity (reachable with IncludeBaseAsSample) has no direction: here only the speed
///    interval decides whether it is admissible (so when t_c⁰ < tc_min) and its deviation term
///    counts as φ = 90° (α/2). In UMANS its cost is NaN, so it is never picked; counting it as
///    φ = 0 instead makes two crossing agents wait for each other for ever.
class Karamouzas : public Component {
public:
    explicit Karamouzas(const ParamSet& params);
    static ComponentInfo Info();

    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;

    /// Largest admissible deviation from v_pref (rad) when the first collision at v_pref is ttc s away.
    double maxDeviation(double ttc) const;
    /// Admissible speed interval (m/s) when the first collision at v_pref is ttc s away.
    std::pair<double, double> speedInterval(double ttc, double prefSpeed, double maxSpeed) const;
    /// Time (s) to the first collision of the query agent at velocity v with agents and walls within
    /// `range` (kInf if none). Exposed for tests.
    double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;

private:
    double alpha_ = 5.0;   ///< weight of the deviation from the preferred direction
    double beta_ = 0.5;    ///< weight of the change of speed
    double gamma_ = 1.0;   ///< weight of the distance to the preferred velocity
    double delta_ = 1.0;   ///< weight of the imminence of a collision
    double tMax_ = 8.0;    ///< s, collisions farther away are ignored (also tc_max)
    double tcMin_ = 2.5;   ///< s, below: imminent collision, every speed allowed
    double tcMid_ = 6.0;   ///< s, start of the narrowing of the admissible cone
    double overlap_ = 0;   ///< 0 = ignore overlapped neighbours (UMANS), 1 = closing velocities collide now

    static constexpr double kDMin = 0.05;                ///< rad
    static constexpr double kDMid = kPi / 6.0;           ///< rad
    static constexpr double kDMax = kPi / 2.0;           ///< rad
    static constexpr double kSpeedTolerance = 0.05;      ///< m/s (ε)
    static constexpr double kOutsidePenalty = 1e6;       ///< cost floor of inadmissible velocities
};

}  // namespace ch
