// CrowdHealth — ORCA: optimal reciprocal collision avoidance (van den Berg et al. 2011).
#pragma once

#include "crowdhealth/core/registry.h"

#include <cstddef>
#include <optional>
#include <vector>

namespace ch {

namespace orca {

/// A closed half-plane of velocities {v : normal·v ≤ offset}. `normal` is a unit vector that points
/// out of the allowed side, so normal·v − offset is the signed distance by which v violates it.
struct HalfPlane {
    Vec2 normal{1, 0};
    double offset = 0;
    double violation(const Vec2& v) const { return normal.dot(v) - offset; }
};

/// The 2D linear program of the paper (its "linear programming" step): the point of the
/// disc |v| ≤ maxSpeed inside every half-plane that is closest to `target` (or, with
/// `directionMode`, farthest along the unit vector `target`). Incremental: the planes are added in
/// the given order (deterministic, O(n²) worst case, n is small); when the running optimum breaks a
/// new plane, the new optimum lies on that plane's boundary line and is found by a 1D program on it.
/// Returns planes.size() on success, or the index of the first plane that made it infeasible, with
/// `result` the optimum of the planes before it.
std::size_t solve2D(const std::vector<HalfPlane>& planes, double maxSpeed, const Vec2& target, bool directionMode,
                    Vec2& result);

/// The 3D fallback of the paper (its "dense situations" step): when the planes have no common point,
/// the velocity that minimises the largest violation δ of the *soft* planes, keeping the first
/// `numHard` planes (static obstacles) and the speed disc as hard constraints. Solved as in the
/// paper by adding the soft planes one by one from `begin`; each time the running optimum violates
/// plane i by more than δ, the optimum lies on the plane "violation_i = δ" of (v, δ)-space, whose
/// constraints project to the 2D bisector half-planes violation_j ≤ violation_i (j < i), and a 2D
/// program in direction mode pushes v as far as possible against plane i's normal.
/// `result` holds the starting point (the partial 2D optimum) and receives the answer.
void solve3D(const std::vector<HalfPlane>& planes, std::size_t numHard, std::size_t begin, double maxSpeed,
             Vec2& result);

/// Both programs together: the 2D optimum closest to prefVelocity, or the 3D fallback.
struct Solution {
    Vec2 velocity{0, 0};
    bool feasible = true;  ///< false when the 3D fallback was used
};
Solution solve(const std::vector<HalfPlane>& planes, std::size_t numHard, double maxSpeed, const Vec2& prefVelocity);

/// ORCA^τ_{A|B} of agent A against a moving disc B (the paper's definition): VO^τ is the cone of
/// the disc D(relPos, R) truncated at the disc D(relPos/τ, R/τ); u goes from the relative velocity
/// to the nearest point of the VO boundary, n is the outward normal there, and A takes the share
/// `share` of u: ORCA = {v : (v − (velocity + share·u))·n ≥ 0}.
/// relPos = x_B − x_A, relVel = v_A − v_B, R = r_A + r_B. When the discs already overlap, the
/// truncation disc of time `dt` (one step) is used so that the pair separates within the step.
HalfPlane agentHalfPlane(const Vec2& relPos, const Vec2& relVel, double R, double tau, double dt,
                         const Vec2& velocity, double share = 0.5);

/// The obstacle half-plane of agent A (radius r, velocity v) against a static wall segment [a, b]
/// given relative to A's position. The velocity obstacle of the segment is the cone of the capsule
/// C = [a, b] ⊕ D(r), truncated at C/τ; it is convex, and the half-plane is the supporting line of
/// the VO at the boundary point nearest to v, with the whole u (walls do not reciprocate).
/// Every such line passes through or in front of the zero velocity, so the obstacle half-planes of
/// any set of walls always have 0 in common. When A already touches the segment, the half-plane
/// forbids any velocity component towards its nearest point. Empty when A's centre lies on it.
std::optional<HalfPlane> obstacleHalfPlane(const Vec2& a, const Vec2& b, double r, double tau, const Vec2& v);

}  // namespace orca

/// ORCA — J. van den Berg, S. J. Guy, M. Lin and D. Manocha, "Reciprocal n-body collision
/// avoidance", Robotics Research (ISRR 2009), Springer Tracts in Advanced Robotics 70, pp. 3–19,
/// 2011.
///
/// Every neighbour B within `range` contributes the half-plane ORCA^τ_{A|B} (τ = `timeHorizon`, the
/// current velocities as optimisation velocities, half of the avoidance effort each); every wall
/// segment within `range` contributes an obstacle half-plane with τ = `timeHorizonObst` and the
/// full effort. The new velocity is the point of ORCA^τ_A ∩ D(0, max_speed) closest to the preferred
/// velocity (globalMinimum(): our own incremental 2D linear program), or, when the half-planes
/// have no common point, the velocity that least violates the agents' half-planes while respecting
/// the walls' (the paper's 3D linear program).
///
/// For the `sampling` and `gradient` methods the cost is UMANS' (it includes goal reaching):
/// |v − v_pref| inside the feasible region; outside it, the largest violation (signed distance
/// outside a half-plane, or |v| − max_speed) plus max_speed + max(max_speed, |v_pref|) (= 2·max_speed,
/// UMANS' constant, whenever pref_speed ≤ max_speed), so every feasible velocity is cheaper than
/// every infeasible one. The analytic gradient is that of the active piece.
///
/// Known behaviour (the model's, not a defect of this code): with the current velocity as
/// optimisation velocity, agents that converge from rest in a symmetric layout (UMANS' CircleN)
/// deadlock. Each adjacent pair settles with its relative velocity on the truncation disc (a
/// collision exactly τ ahead), so gaps shrink like e^{−t/τ}; the ring closes onto the touching
/// radius and stops, without any overlap. Perturbing v_pref (the RVO2 examples' remedy) does not
/// help, since the optimum sits at the vertex of two neighbours' half-planes; starts that differ by
/// a few centimetres do. In crowds too dense for the half-planes to intersect, the 3D program's
/// least-violating velocity can let agents overlap (the paper's caveat for dense situations).
///
/// Differences from UMANS' ORCA (which wraps the authors' RVO2 code):
///  * static obstacles are taken into account (UMANS ignores them). The wall VO is computed exactly
///    for a segment (capsule cone), with the current velocity as optimisation velocity as for agents.
///  * when two agents already overlap, u is built from |w| (UMANS' adapted code uses |w|², which
///    mis-sizes the push-out when agents overlap);
///  * the speed disc counts as a constraint of the sampling cost (UMANS' cost ignores max_speed);
///  * a parameter `timeHorizonObst` (s) is added; `timeHorizon` keeps UMANS' name and default (5 s).
class ORCA : public Component {
public:
    explicit ORCA(const ParamSet& params);
    static ComponentInfo Info();

    bool readsStepLists() const override { return false; }  ///< only q.agents, q.segments
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    std::optional<Vec2> globalMinimum(const AgentQuery& q, const StepContext& ctx) const override;

    /// The half-planes of the query agent: walls first (hard constraints of the 3D program), then
    /// agents in neighbour order. Returns the number of wall half-planes.
    std::size_t halfPlanes(const AgentQuery& q, const StepContext& ctx, std::vector<orca::HalfPlane>& out) const;

private:
    template <class F>
    void forEachHalfPlane(const AgentQuery& q, const StepContext& ctx, F&& f) const;

    double timeHorizon_ = 5.0;      ///< τ for agents, s
    double timeHorizonObst_ = 5.0;  ///< τ for walls, s
};

}  // namespace ch
