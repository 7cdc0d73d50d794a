// CrowdHealth — the simulation: world + agents + policies, advanced in fixed steps.
//
// One coarse step (delta_time) = N fine steps (delta_time_fine). Per fine step:
//   1. agents whose start_time has come are activated; the neighbour grid is rebuilt;
//   2. preferred velocities are set (towards the goal at preferred speed, zero at the goal), then
//      changed by the CrowdHealth layer (herding, erratic motion, falls and helpers);
//   3. at the first fine step of a coarse step every *coarse* policy step is evaluated and its
//      acceleration held for the whole coarse step; every *fine* policy step is evaluated now;
//      a step with a blend (StepSpec::blend) counts with its per-agent weight (PolicyStep::weight);
//   4. integration (forward Euler; a fallen agent of the CrowdHealth layer does not move): a = clamp(a_coarse + a_fine, a_max); v ← clamp(v + a·dt, s_max);
//      then UMANS' post-clamp contact: v ← v + dt·F_contact/m; x ← x + v·dt; toric wrap;
//      AgentStore::contactAccel = UMANS' contact + Σ coeff·contactField() of the components the
//      agent's policy evaluated (e.g. ContactForces, which acts inside the clamp);
//   5. time advances; agents within their goal radius with remove_at_goal are removed (recorded
//      as evacuations); in a planar world agents outside the bounds are removed.
// Every per-agent phase reads the frozen state and writes only that agent's slot of the next
// state, so the result is independent of thread count.
#pragma once

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/policy.h"
#include "crowdhealth/core/scenario.h"
#include "crowdhealth/health/health.h"
#include "crowdhealth/core/world.h"
#include "crowdhealth/navigation/navigation.h"

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace ch {

/// SPH density (Poly6 kernel, smoothing length h in m) at each of `positions`: Σ_j m_j W(r_ij)
/// over the given agents (j = i included) plus the world's static boundary particles (mass 1
/// each), minimum image on a torus. `masses` has one entry per position. Returns one value per
/// position (1/m² × mass). Simulation::measureDensity uses it; renderers use it to recompute the
/// density of recorded trajectories.
std::vector<double> measureDensity(const std::vector<Vec2>& positions, const std::vector<double>& masses,
                                   const World& world, double h = 1.0);
/// The same, written into `density` (re-sized to one value per position, its buffer kept):
/// Simulation::measureDensity fills the store's column so, with no second vector per record.
void measureDensity(const std::vector<Vec2>& positions, const std::vector<double>& masses, const World& world,
                    double h, std::vector<double>& density);

struct Evacuation {
    AgentId id;
    double time;    ///< s, the time at which the agent was removed at its goal
    int exit = -1;  ///< the <Exit> it left by (index into VenueSpec::targets); -1: its goal
};

class Simulation {
public:
    /// The named phases of a fine step, in order (see the list above), for profiling.
    enum class Phase { Activation, Neighbours, Preferred, Prepare, Forces, Integration, Removal, Count };
    static constexpr std::size_t kPhases = static_cast<std::size_t>(Phase::Count);
    static const char* phaseName(Phase p);

    /// Builds everything from a validated spec. Throws std::runtime_error (e.g. RegistryError)
    /// when the spec names something that does not exist.
    /// Takes the spec by value: pass a temporary or std::move it to avoid a copy (it holds every
    /// agent's spec, which counts at a million agents).
    explicit Simulation(ScenarioSpec spec);
    ~Simulation();
    /// Parts (the navigation) refer to the simulation's own spec and world: neither copied nor moved.
    Simulation(const Simulation&) = delete;
    Simulation& operator=(const Simulation&) = delete;

    /// OpenMP threads for the parallel phases (results do not depend on it).
    void setThreads(int n);
    /// Every `fineSteps` fine steps (0: never) the agents are re-ordered in grid-cell order so that
    /// neighbours sit close together in memory (default kReorderInterval). Results stay
    /// deterministic and thread-count independent; sums over neighbours run in another order, so
    /// they differ in the last bits from an unordered run.
    void setReorderInterval(int fineSteps) { reorderInterval_ = std::max(0, fineSteps); }
    static constexpr int kReorderInterval = 50;
    /// Whether each step stores every agent's neighbour lists (true) or gathers each agent's lists
    /// just before its policy's calls (false: the default when no component of the scenario reads
    /// the lists through its StepContext, Component::readsStepLists). Both give the same lists and
    /// the same bits; gathering on the way saves the stored lists' memory and their traffic
    /// (~3 MB of indices per step for 10k agents at 5 m, issue 20, and the entries' copies). store = true keeps them stored (tests
    /// compare the two; the benchmark shows the difference); false is ignored where a component
    /// needs them.
    void setStoreNeighbourLists(bool store) { storeLists_ = store || needStoredLists_; }
    bool storesNeighbourLists() const { return storeLists_; }

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

    /// The scenario it was built from; its agents are gone after releaseAgentSpecs().
    const ScenarioSpec& spec() const { return spec_; }
    const World& world() const { return world_; }
    const AgentStore& agents() const { return agents_; }
    std::vector<Policy>& policies() { return policies_; }
    const std::vector<Policy>& policies() const { return policies_; }
    /// Agents removed at their goal, in time order (ties: in agent order).
    const std::vector<Evacuation>& evacuations() const { return evacuations_; }
    /// Agents removed because they left a planar world.
    std::size_t leftWorld() const { return leftWorld_; }
    /// Every agent removed so far (at its goal or exit, or out of a planar world), in removal order,
    /// with its last position: what measurement lines need to count the last move of someone who
    /// left between two records.
    struct Removal {
        AgentId id;
        double time;    ///< s
        Vec2 position;  ///< m, where it was when removed
    };
    const std::vector<Removal>& removed() const { return removed_; }
    /// Agents not yet activated (start_time in the future, or a source's arrival waiting for room).
    std::size_t pending() const { return pending_.size() - nextPending_ + deferred_.size(); }
    /// Every agent of the scenario: active, waiting, or removed (spec().agents.size() until
    /// releaseAgentSpecs()).
    std::size_t totalAgents() const { return totalAgents_; }
    /// Frees the agent specs (spec().agents, 240 bytes per agent: 229 MiB for a million) once every
    /// agent is in the world, for a program that no longer reads them; spec().agents is empty
    /// afterwards, the rest of spec() stays. False (and nothing freed) while some agent is still to
    /// come (pending() > 0): call it again later. Nothing the simulation computes depends on it.
    bool releaseAgentSpecs();
    /// True once releaseAgentSpecs() has freed the agent specs.
    bool agentSpecsReleased() const { return specsReleased_; }

    /// Fills agents().density with the SPH density measured with the Poly6 kernel (h in m),
    /// counting other agents, the agent itself and static boundary particles (mass 1 each).
    /// A measurement for metrics; it does not change the dynamics.
    void measureDensity(double h = 1.0);
    /// Sets the preferred speed (m/s) of every active agent and of every agent still to come
    /// (interactive tools; schedules use their own path). Takes effect at the next step.
    void setPrefSpeed(double speed);
    /// Largest depth (m) by which any agent's disc overlaps a wall (0 if none).
    double maxWallPenetration() const;

    /// Wall-clock seconds spent in each phase since construction or the last reset (steady_clock,
    /// read around whole phases only; profiling, never part of the physics).
    const std::array<double, kPhases>& phaseSeconds() const { return phaseSeconds_; }
    void resetPhaseTimes() { phaseSeconds_.fill(0.0); }

    /// Global navigation (crowdhealth/navigation/navigation.h); nullptr when the scenario has no
    /// venue (no <Navigation>, targets, journeys, sources or premovement times: UMANS' straight goals).
    const Navigation* navigation() const { return navigation_.get(); }
    /// Arrivals of sources that found no free place yet (they retry every fine step).
    std::size_t waitingArrivals() const { return deferred_.size(); }

    /// The CrowdHealth layer: per-agent crush and panic records (crowdhealth/health/health.h).
    const HealthLayer& health() const { return health_; }
    /// The same, to change a policy's layer parameters while running (the Python module's
    /// set_parameter, addressed as <Ramp> does).
    HealthLayer& health() { return health_; }
    /// Names of the metrics.csv columns of the ramped parameters (RampSpec::column), one per
    /// distinct target, in order of first appearance in the schedule.
    const std::vector<std::string>& scheduleColumns() const { return scheduleColumns_; }
    /// Current value of each scheduleColumns() parameter (agents: mean over the active agents,
    /// or the last value while nobody is in the world).
    std::vector<double> scheduleValues() const;

private:
    void stepFine();
    /// Runs f() and adds its wall time to phase p.
    template <class F>
    void timed(Phase p, F&& f);
    StepContext contextFor(const PolicyStep& s) const;
    void setPreferredVelocities();
    /// The tiny seeded displacement added to agent i's new position when it is held up
    /// (ScenarioSpec::symmetryBreaking).
    Vec2 symmetryJitter(std::size_t i) const;
    /// Symmetry breaking acts on agents slower than this fraction of their preferred speed.
    static constexpr double kHeldUpFraction = 0.5;
    /// Phase 3: every agent's policy steps on its neighbourhood (fills fineAccel_, stopped_,
    /// umansContact_ when a policy has UMANS' contact, nextContact_ and, at a coarse boundary,
    /// heldAccel_ when a policy has a coarse step).
    void evaluateAgents(bool coarseBoundary);
    /// Phase 4: forward Euler from the accelerations of phase 3, in place (positions, velocities,
    /// viewing directions: every acceleration is known, and each agent reads only its own state).
    void integrate();
    void activatePending();
    /// Agent i's state and its neighbour lists of this step into q: views of the stored lists, or
    /// (lists not stored) the lists gathered now into `scratch` (the calling thread's own). With
    /// `agents` false and the lists stored, q.agents is left empty (no component of i's policy
    /// reads it, Component::readsQueryAgents); q.segments is set either way.
    void gatherQuery(std::size_t i, AgentQuery& q, NeighbourLists::Scratch& scratch, bool agents) const;
    void removeFinished();
    /// grid_'s cell size for a largest neighbourhood radius `range`: half of it for short ranges
    /// (< NeighbourLists::kFineGridFrom: SPH, contact), the range itself for long ones (whose
    /// lists come from a finer grid of their own). The list build writes every candidate of the
    /// cells the query disc's bounding box touches: with cells of r that box holds (3r)² of area
    /// for a disc of πr² (2.9 candidates per neighbour), with cells of r/2 (2.5r)² (2.0).
    static double stepGridCell(double range);
    /// Re-orders the agents in the order of grid_ (cells row by row) and rebuilds grid_.
    void reorderAgents();
    /// After agents were added, removed or re-ordered (previous[i] = agent i's former index, -1
    /// for a newcomer): moves the held coarse accelerations and tells every component
    /// (Component::remapAgents). The one place per-agent state follows the store.
    void followAgents(const std::vector<int>& previous);
    /// UMANS' post-clamp contact of q's agent; maxRadius ≥ every agent's radius (a bound for
    /// the reach, which skips the neighbours that cannot touch).
    Vec2 umansContactAcceleration(const AgentQuery& q, double scale, double maxRadius) const;

    ScenarioSpec spec_;
    World world_;
    std::vector<Policy> policies_;
    AgentStore agents_;
    PointGrid grid_;
    NeighbourLists lists_;  ///< this step's neighbourhoods (within policyRange_ of each agent)
    bool needStoredLists_ = true;  ///< some component reads lists through its StepContext
    bool storeLists_ = true;       ///< lists_ is built (else bound, and gathered agent by agent)
    std::vector<NeighbourLists::Scratch> listScratch_;  ///< per thread, when lists are not stored
    double dtCoarse_, dtFine_;
    int finePerCoarse_;
    double endTime_;
    std::uint64_t fineSteps_ = 0;
    std::vector<std::size_t> pending_;  ///< indices into spec_.agents, by start time then file order
    std::size_t nextPending_ = 0;
    std::size_t totalAgents_ = 0;
    bool specsReleased_ = false;
    std::unique_ptr<Navigation> navigation_;
    std::vector<std::size_t> deferred_;  ///< source arrivals that found no free place, in order
    std::vector<Evacuation> evacuations_;
    std::vector<Removal> removed_;
    std::size_t leftWorld_ = 0;
    int reorderInterval_ = kReorderInterval;
    double maxRange_ = 1.0;                ///< the largest neighbourhood radius (m)
    double gridCell_ = 1.0;                ///< grid_'s cell size (m): see stepGridCell()
    double maxRadius_ = 0;                 ///< largest agent radius (m)
    std::vector<double> policyRange_;      ///< neighbourhood radius per policy (m)
    std::vector<unsigned char> queryAgents_;  ///< per policy: some component or its UMANS contact reads AgentQuery::agents
    std::vector<int> agentPolicy_;         ///< policy index per spec agent

    // per-step buffers (index = agent)
    std::vector<Vec2> heldAccel_;  ///< coarse-step acceleration, held over the coarse step
    std::vector<Vec2> fineAccel_;     ///< Σ fine policy steps of this step (m/s²)
    std::vector<Vec2> umansContact_;  ///< UMANS' post-clamp contact acceleration (m/s²)
    std::vector<unsigned char> stopped_;  ///< 1: at its goal with a stopAtGoal step (stands still)
    std::vector<unsigned char> remove_;   ///< removal marks (reused): 1 exit or goal, 2 out of the world
    std::vector<int> exitOf_;             ///< the exit each agent leaves by this step, or -1 (reused)
    std::vector<Vec2> nextContact_;       ///< contactAccel of the step being computed (swapped in after it)
    bool anyCoarseStep_ = false;          ///< some policy has a coarse step (heldAccel_ is kept)
    bool anyUmansContact_ = false;        ///< some policy has UMANS' contact (umansContact_ is kept)
    std::array<double, kPhases> phaseSeconds_{};

    // CrowdHealth layer and schedule (<Schedule><Ramp>)
    HealthLayer health_;
    struct Ramp {
        RampSpec spec;
        std::vector<Component*> components;  ///< Component target: every matching instance
        std::vector<int> policies;           ///< CrowdHealth target: policy indices
        int column = 0;                      ///< index into scheduleColumns_
        bool first = false;                  ///< the first ramp of its target: holds `from` before its start
        double applied = std::numeric_limits<double>::quiet_NaN();  ///< last value written
    };
    std::vector<Ramp> ramps_;
    std::vector<std::string> scheduleColumns_;
    std::vector<int> columnRamp_;            ///< per column: a ramp that targets it
    mutable std::vector<double> lastAgentValue_;  ///< per column (agents targets)
    /// Sets every ramped parameter to its value at time() (RampSpec: the first ramp of a target
    /// holds `from` before its start, later ones wait for theirs).
    void applySchedule();
    void resolveRamps();
};

}  // namespace ch
