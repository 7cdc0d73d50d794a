// CrowdHealth — ContactForces: body contact between agents and with walls (paper eq. 1 term).
#pragma once

#include "crowdhealth/core/registry.h"

#include <vector>

namespace ch {

/// Linear springs on overlapping bodies, inside the acceleration clamp (van Toll et al. 2021,
/// "SPH crowds", Computers & Graphics 98, contact forces; the CrowdHealth paper, eq. 1):
///   agents: a_i += K_ag · max(0, D_i + D_j − |x_i − x_j|) · x̂_ji / m_i   (x̂_ji: unit, from j to i)
///   walls:  a_i += K_obs · max(0, D_i − d) · n̂ / m_i   (d, n̂: distance to and direction from the wall)
/// with D the body radius and m the mass factor. `wallRule` picks which walls act:
///   * vantoll (default): every wall segment within D_i, each along the direction from its nearest
///     point (van Toll's implementation);
///   * prototype (the CrowdHealth paper's prototype): at most one wall per obstacle — the directly
///     adjacent wall (the agent's foot point lies inside the segment) is taken before a corner,
///     among those the largest penetration; and an agent whose centre is inside the obstacle is
///     pushed out towards the nearest boundary point with penetration D_i + d.
/// Everything is computed in prepare() from the frozen state; acceleration() returns the agent's
/// slot, and contactField() reports it to the simulation (AgentStore::contactAccel).
class ContactForces : public ForceComponent {
public:
    explicit ContactForces(const ParamSet& params);
    static ComponentInfo Info();

    void prepare(const StepContext& ctx) override;
    bool readsQueryAgents() const override { return false; }  ///< its sums run in prepare()
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;
    void remapAgents(const std::vector<int>& previous) override;
    const std::vector<Vec2>* contactField() const override { return &accel_; }

    bool prototypeWalls() const { return wallRule_ != 0.0; }

private:
    double agentStiffness_ = 50;     ///< K_ag, 1/s² (per unit mass factor)
    double obstacleStiffness_ = 200; ///< K_obs, 1/s²
    double wallRule_ = 0;            ///< Choice: 0 = vantoll, 1 = prototype
    std::vector<Vec2> accel_;        ///< per agent, m/s²

    Vec2 wallsVanToll(std::size_t i, const StepContext& ctx, std::vector<int>& near) const;
    Vec2 wallsPrototype(std::size_t i, const StepContext& ctx, std::vector<int>& near) const;
};

}  // namespace ch
