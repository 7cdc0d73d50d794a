// CrowdHealth — the simulation: world + agents + policies, advanced in fixed steps.
//
// One coarse step (delta_time) = N fine steps (delta_time_fine). Per fine step:
//   1. agents whose start_time has come are activated; the neighbour grid is rebuilt;
//   2. preferred velocities are set (towards the goal at preferred speed, zero at the goal);
//   3. at the first fine step of a coarse step every *coarse* policy step is evaluated and its
//      acceleration held for the whole coarse step; every *fine* policy step is evaluated now;
//   4. integration (forward Euler): a = clamp(a_coarse + a_fine, a_max); v ← clamp(v + a·dt, s_max);
//      then UMANS' post-clamp contact: v ← v + dt·F_contact/m; x ← x + v·dt; toric wrap;
//      AgentStore::contactAccel = UMANS' contact + Σ coeff·contactField() of the components the
//      agent's policy evaluated (e.g. ContactForces, which acts inside the clamp);
//   5. time advances; agents within their goal radius with remove_at_goal are removed (recorded
//      as evacuations); in a planar world agents outside the bounds are removed.
// Every per-agent phase reads the frozen state and writes only that agent's slot of the next
// state, so the result is independent of thread count.
#pragma once

#include "crowdhealth/agents.h"
#include "crowdhealth/grid.h"
#include "crowdhealth/policy.h"
#include "crowdhealth/scenario.h"
#include "crowdhealth/world.h"

#include <cstdint>
#include <string>
#include <vector>

namespace ch {

struct Evacuation {
    AgentId id;
    double time;  ///< s, the time at which the agent was removed at its goal
};

class Simulation {
public:
    /// Builds everything from a validated spec. Throws std::runtime_error (e.g. RegistryError)
    /// when the spec names something that does not exist.
    explicit Simulation(const ScenarioSpec& spec);

    /// OpenMP threads for the parallel phases (results do not depend on it).
    void setThreads(int n);

    /// Advances one coarse step (delta_time): fineStepsPerCoarse() fine steps.
    void stepCoarse();

    /// Simulated time (s), exactly fineSteps()·delta_time_fine.
    double time() const { return static_cast<double>(fineSteps_) * dtFine_; }
    std::uint64_t fineSteps() const { return fineSteps_; }
    std::uint64_t coarseSteps() const { return fineSteps_ / static_cast<std::uint64_t>(finePerCoarse_); }
    double deltaTime() const { return dtCoarse_; }
    double deltaTimeFine() const { return dtFine_; }
    /// End time (s); < 0 means "until no agent is left".
    double endTime() const { return endTime_; }
    void setEndTime(double t) { endTime_ = t; }
    /// True once time ≥ end time, or when no agent is active or waiting any more.
    bool finished() const;

    const ScenarioSpec& spec() const { return spec_; }
    const World& world() const { return world_; }
    const AgentStore& agents() const { return agents_; }
    std::vector<Policy>& policies() { return policies_; }
    const std::vector<Policy>& policies() const { return policies_; }
    /// Agents removed at their goal, in time order (ties: in agent order).
    const std::vector<Evacuation>& evacuations() const { return evacuations_; }
    /// Agents removed because they left a planar world.
    std::size_t leftWorld() const { return leftWorld_; }
    /// Agents not yet activated (start_time in the future).
    std::size_t pending() const { return pending_.size() - nextPending_; }
    std::size_t totalAgents() const { return spec_.agents.size(); }

    /// Fills agents().density with the SPH density measured with the Poly6 kernel (h in m),
    /// counting other agents, the agent itself and static boundary particles (mass 1 each).
    /// A measurement for metrics; it does not change the dynamics.
    void measureDensity(double h = 1.0);
    /// Largest depth (m) by which any agent's disc overlaps a wall (0 if none).
    double maxWallPenetration() const;

private:
    void stepFine();
    void activatePending();
    void gatherQuery(std::size_t i, double range, AgentQuery& q) const;
    void removeFinished();
    /// Tells every component how agent indices moved (see Component::remapAgents).
    void remapComponents(const std::vector<int>& previous);
    Vec2 umansContactAcceleration(const AgentQuery& q, double scale) const;

    ScenarioSpec spec_;
    World world_;
    std::vector<Policy> policies_;
    AgentStore agents_;
    PointGrid grid_;
    double dtCoarse_, dtFine_;
    int finePerCoarse_;
    double endTime_;
    std::uint64_t fineSteps_ = 0;
    std::vector<std::size_t> pending_;  ///< indices into spec_.agents, by start time then file order
    std::size_t nextPending_ = 0;
    std::vector<Evacuation> evacuations_;
    std::size_t leftWorld_ = 0;
    double maxRange_ = 1.0;                ///< grid cell size: the largest neighbourhood radius
    double maxRadius_ = 0;                 ///< largest agent radius (m)
    std::vector<double> policyRange_;      ///< neighbourhood radius per policy (m)
    std::vector<int> agentPolicy_;         ///< policy index per spec agent

    // per-step buffers (index = agent)
    std::vector<Vec2> heldAccel_;  ///< coarse-step acceleration, held over the coarse step
    std::vector<Vec2> nextPos_, nextVel_, nextView_, nextContact_;
};

}  // namespace ch
