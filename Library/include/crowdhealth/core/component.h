// CrowdHealth — the component interface: cost functions and forces (DESIGN §2).
//
// STEP CONTRACT — read this before writing a component.
//  * Every call sees the *frozen* state of the previous step through StepContext: positions,
//    velocities and measurements of all agents are those at the start of the step, and no
//    component may modify them. A component returns a value for ONE agent (the `AgentQuery`
//    agent); the simulation writes it into that agent's slot of the next state (double buffer).
//  * `prepare()` runs once per step before any per-agent call, on one thread at a time per
//    component; it may fill the component's own per-agent arrays (e.g. SPH density), and may use
//    OpenMP inside as long as each iteration writes only its own agent's slot.
//  * Per-agent calls run in parallel; they must be `const` and thread-safe, and must draw random
//    numbers only through `ctx.rng(query, stream)`, never from a shared generator.
//  Results therefore depend neither on agent order nor on the number of threads.
#pragma once

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/neighbours.h"
#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/rng.h"
#include "crowdhealth/core/types.h"
#include "crowdhealth/core/world.h"

#include <map>
#include <span>
#include <optional>
#include <string>
#include <vector>

namespace ch {

struct ComponentInfo;

/// The agent being evaluated, with its neighbourhood gathered once per step (within the largest
/// range of its policy's components; see NeighbourLists). Components with a smaller range filter
/// by `distance`. The spans point into the step's neighbour lists (or, in tests, into any array
/// that outlives the call).
struct AgentQuery {
    int i = 0;
    Vec2 position{0, 0}, velocity{0, 0}, prefVelocity{0, 0};
    double radius = 0, prefSpeed = 0, maxSpeed = 0, maxAcceleration = 0, mass = 1;
    std::span<const NeighbourAgent> agents;  ///< other agents (not i), in a fixed (grid) order
    std::span<const int> segments;           ///< indices into World::segments(), ascending
};

/// Agent i's own state from the store into q (index, kinematics, attributes); not its neighbourhood.
inline void setQueryAgent(AgentQuery& q, const AgentStore& agents, std::size_t i) {
    q.i = static_cast<int>(i);
    q.position = agents.pos[i];
    q.velocity = agents.vel[i];
    q.prefVelocity = agents.prefVel[i];
    q.radius = agents.radius[i];
    q.prefSpeed = agents.prefSpeed[i];
    q.maxSpeed = agents.maxSpeed[i];
    q.maxAcceleration = agents.maxAcceleration[i];
    q.mass = agents.mass[i];
}

/// Read-only view of the frozen state handed to every component call.
struct StepContext {
    const AgentStore& agents;
    const World& world;
    const PointGrid& grid;   ///< agent positions of this step
    double dt;               ///< length of this step (coarse or fine), s
    double time;             ///< simulated time at the start of the step, s
    std::uint64_t stepIndex; ///< number of fine steps done so far (for random streams)
    std::uint64_t seed;      ///< the run's seed
    double relaxationTime;   ///< the evaluating policy step's RelaxationTime, s
    /// This step's neighbour lists (null: none, e.g. in tests; the helpers below then query the grid).
    const NeighbourLists* lists = nullptr;
    /// Largest radius of any agent of the scenario (m); 0 when unknown (tests), then components
    /// that need it take it from `agents`.
    double maxRadius = 0;

    /// Calls f(j, offset, distanceSquared) for every other agent j within `radius` of agent i, in
    /// a fixed order that does not depend on the thread count: the order of the step's list (the
    /// visit order of the grid it was gathered from; lists of 2 m and more come from a finer grid
    /// of their own, core/neighbours.h), else the step grid's visit order. Reads the step's neighbour list when it reaches far enough, else
    /// queries the grid: the same agents, offsets and squared distances either way (the same
    /// test, |offset|² <= radius², decides).
    template <class F>
    void forEachNeighbour(std::size_t i, double radius, F&& f) const {
        const double r2 = radius * radius;
        if (listReaches(i, radius)) {
            lists->forEachAgent(i, [&](int j, const Vec2& d) {
                const double d2 = d.squaredNorm();
                if (d2 <= r2) f(j, d, d2);
            });
            return;
        }
        const int self = static_cast<int>(i);
        grid.forEachWithin(agents.pos[i], radius, [&](int j, const Vec2& d, double d2) {
            if (j != self) f(j, d, d2);
        });
    }

    /// Whether the step's stored list of agent i reaches `radius` (it holds every other agent
    /// within it, and maybe some farther, in the order forEachNeighbour visits them).
    bool listReaches(std::size_t i, double radius) const {
        return lists != nullptr && i < lists->size() && radius <= lists->radius(i);
    }

    /// Every other agent within `radius` of agent i as a list in `scratch`, for loops that read the
    /// list themselves (Policies/PairSums.h): the step's stored list with its offsets when it
    /// reaches that far (it may hold farther agents too: filter by distance), else
    /// forEachNeighbour's agents, in the same order. The span is valid until the scratch changes.
    std::span<const NeighbourAgent> neighbourList(std::size_t i, double radius, std::vector<NeighbourAgent>& scratch) const {
        if (listReaches(i, radius)) return lists->agents(i, scratch);
        scratch.clear();
        forEachNeighbour(i, radius, [&](int j, const Vec2& offset, double) { scratch.push_back(NeighbourAgent{offset, j}); });
        return scratch;
    }

    /// Wall segments within `radius` of agent i into `out` (ascending), from the step's lists
    /// when they reach far enough, else from the world's segment grid.
    void segmentsNear(std::size_t i, double radius, std::vector<int>& out) const {
        // Most agents of a crowd: a list that reaches far enough and holds no wall (inline, since
        // SPH and ContactForces ask for every agent at every step).
        if (listReaches(i, radius) && lists->segmentCount(i) == 0) {
            out.clear();
            return;
        }
        segmentsNearScan(i, radius, out);
    }
    /// segmentsNear() where the list holds walls or does not reach: its walls filtered by
    /// distance, or the world's segment grid.
    void segmentsNearScan(std::size_t i, double radius, std::vector<int>& out) const;

    /// A random stream private to (agent, step, stream): same numbers whatever the thread count.
    Rng rng(const AgentQuery& q, std::uint64_t stream) const {
        return Rng(seed, static_cast<std::uint64_t>(agents.id[q.i]), stepIndex, stream);
    }
};

enum class ComponentKind { CostFunction, Force };

/// Time (s) until the query agent, moving at velocity v, first touches a neighbour (moving at its
/// current velocity) or a wall within `range` m; kInf if never. A neighbour or wall already
/// overlapped counts as an immediate collision (0) only for velocities that close the gap, so an
/// agent in contact can always move away. Shared by the time-to-collision models.
double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx, double range);

/// What a time-to-collision model makes of a neighbour or wall the agent already overlaps.
enum class OverlapRule {
    Closing,  ///< an immediate collision (0) for velocities that close the gap (timeToFirstCollision above)
    Ignore,   ///< left out altogether: contact forces separate the pair (UMANS' ignoreCurrentCollisions)
};

/// timeToFirstCollision with the given rule for what is overlapped already.
double timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx, double range, OverlapRule rule);

/// Base of every cost function and force. Subclasses bind their parameters in the constructor
/// with `bind()`, so schedules can change them while running (`setParameter`).
class Component {
public:
    virtual ~Component() = default;

    /// Interaction range (m): neighbours farther than this are ignored. Parameter `range`.
    double range() const { return range_; }

    /// Once per step, before the per-agent calls (see the step contract).
    virtual void prepare(const StepContext& ctx) { (void)ctx; }

    /// Whether the component reads the step's neighbour lists through its StepContext (`lists`,
    /// forEachNeighbour, segmentsNear: in prepare(), or for agents other than the query's), and
    /// not only the query agent's own lists (AgentQuery::agents, segments) in its per-agent
    /// calls. When no component of the scenario does, the simulation gathers each agent's lists
    /// just before that agent's calls, into a buffer that stays in cache, instead of storing
    /// every list of the step (the same lists, entry by entry; issue 20). True unless a component
    /// says otherwise, so a plugin written before this keeps the stored lists.
    virtual bool readsStepLists() const { return true; }

    /// Whether the component's per-agent calls read AgentQuery::agents (the query agent's
    /// neighbours with their offsets). When no component of a policy does and the policy has no
    /// UMANS contact (ContactForceScale), the simulation leaves q.agents empty for that policy's
    /// agents instead of computing an offset for every entry of every list (issue 20: 4 % of a
    /// dense SPH step, whose components read the stored lists by index). q.segments is filled
    /// either way. True unless a component says otherwise, so a plugin written before this gets
    /// its neighbours.
    virtual bool readsQueryAgents() const { return true; }

    /// Cost of candidate velocity v (m/s) for the query agent; lower is better.
    virtual double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const = 0;
    /// A value cost(v, q, ctx) is never below, computed in floating point so that it really is
    /// (default −∞: no bound). Sampling skips a candidate whose bound already reaches the best
    /// cost so far, which changes no result (the first strictly better candidate still wins) and
    /// spares the expensive part of models like RVO.
    virtual double costLowerBound(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
        (void)v; (void)q; (void)ctx;
        return -kInf;
    }
    /// Gradient of cost with respect to v. Default: central differences with δ = 0.1 m/s (UMANS).
    virtual Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;
    /// The velocity of minimum cost in closed form, where the model has one.
    virtual std::optional<Vec2> globalMinimum(const AgentQuery& q, const StepContext& ctx) const {
        (void)q; (void)ctx;
        return std::nullopt;
    }

    /// Changes a bound parameter while running. Returns false if the name is not bound.
    bool setParameter(const std::string& name, double value);
    /// Current value of a bound parameter (NaN if not bound).
    double parameter(const std::string& name) const;

    /// Called after agents were added or removed, so per-agent state kept across steps can
    /// follow its agents: `previous[i]` is the index agent i had before the change, or -1 for an
    /// agent that has just appeared. Runs on one thread.
    virtual void remapAgents(const std::vector<int>& previous) { (void)previous; }

    /// Per-agent scalar this component wants recorded (e.g. "rest_density"); empty if none.
    virtual const std::vector<double>* field(const std::string& name) const { (void)name; return nullptr; }

    /// Per-agent contact acceleration (m/s², index = AgentStore index) this component produced in
    /// its last prepare()/step, or nullptr if it models no body contact. The simulation adds
    /// coeff × this into AgentStore::contactAccel for every agent whose policy step evaluated the
    /// component, so recorders see contact from components as well as UMANS' post-clamp contact.
    /// It must stay aligned with the agents (follow them in remapAgents()).
    virtual const std::vector<Vec2>* contactField() const { return nullptr; }

protected:
    /// Reads `name` from params into `member` and remembers it for setParameter().
    void bind(const ParamSet& params, const std::string& name, double& member);
    double range_ = 5.0;

private:
    std::map<std::string, double*> bound_;
};

/// A force: an acceleration contribution. Usable wherever a cost function is (UMANS' force-based
/// cost): target velocity v_t = v + a·dt, cost(v') = |v' - v_t|²/(2·dt), whose gradient at the
/// current velocity is -a, and whose global minimum is v_t.
class ForceComponent : public Component {
public:
    /// Acceleration (m/s²) on the query agent from the frozen state.
    virtual Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const = 0;

    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    std::optional<Vec2> globalMinimum(const AgentQuery& q, const StepContext& ctx) const override;
};

}  // namespace ch
