// CrowdHealth tests — building scenarios by hand and running them (no XML involved).
#pragma once

#include "crowdhealth/core/registry.h"
#include "crowdhealth/core/scenario.h"
#include "crowdhealth/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace ch::test {

/// An AgentQuery that owns the neighbour arrays its spans show (tests fill them by hand). Fill
/// `agentStore`/`segmentStore`, then call bind(). Copies re-point their spans at their own arrays;
/// never slice one into a plain AgentQuery that outlives it.
struct OwnedQuery : AgentQuery {
    std::vector<NeighbourAgent> agentStore;
    std::vector<int> segmentStore;

    OwnedQuery() = default;
    OwnedQuery(const OwnedQuery& o) : AgentQuery(o), agentStore(o.agentStore), segmentStore(o.segmentStore) { bind(); }
    OwnedQuery& operator=(const OwnedQuery& o) {
        AgentQuery::operator=(o);
        agentStore = o.agentStore;
        segmentStore = o.segmentStore;
        bind();
        return *this;
    }
    /// Points the spans at the owned arrays (after filling or changing them).
    void bind() {
        agents = agentStore;
        segments = segmentStore;
    }
};

/// A component spec with every default of its table and the given overrides.
inline ComponentSpec component(const std::string& name, const std::map<std::string, double>& values = {},
                               double coeff = 1.0) {
    const ComponentInfo* info = Registry::instance().find(name);
    if (info == nullptr) throw RegistryError("test asks for unregistered component " + name);
    ComponentSpec c;
    c.name = name;
    c.coeff = coeff;
    c.params = ParamSet(Registry::fullTable(*info));
    for (const auto& [k, v] : values) c.params.set(k, v);
    return c;
}

/// A component built from the registry with every default of its table and the given overrides.
inline std::unique_ptr<Component> make(const std::string& name, const std::map<std::string, double>& values = {}) {
    const ComponentSpec c = component(name, values);
    return createComponent(c.name, c.params);
}

/// A policy with one step.
inline PolicySpec policy(int id, OptimisationMethod method, std::vector<ComponentSpec> components,
                         double relaxationTime = 0.0, SamplingSpec sampling = {},
                         StepTiming timing = StepTiming::Coarse, double contactForceScale = 62.5) {
    PolicySpec p;
    p.id = id;
    StepSpec s;
    s.method = method;
    s.relaxationTime = relaxationTime;
    s.sampling = sampling;
    s.timing = timing;
    s.components = std::move(components);
    p.steps.push_back(std::move(s));
    p.contactForceScale = contactForceScale;
    return p;
}

inline AgentSpec agent(AgentId id, Vec2 pos, Vec2 goal, double radius = 0.3, double prefSpeed = 1.3,
                       double maxSpeed = 1.6, int policyId = 0) {
    AgentSpec a;
    a.id = id;
    a.position = pos;
    a.goal = goal;
    a.radius = radius;
    a.prefSpeed = prefSpeed;
    a.maxSpeed = maxSpeed;
    a.policyId = policyId;
    return a;
}

/// A hand-built frozen state for unit tests of one component call: agents added one by one, a
/// context over them, and a query for agent i with every other agent and every wall segment as
/// neighbours. World holds pointers into itself: build a Frame in place, never copy it.
struct Frame {
    AgentStore agents;
    World world;
    PointGrid grid;

    explicit Frame(const std::vector<ObstacleSpec>& obstacles = {}) : world(WorldSpec{}, obstacles) {}

    int add(Vec2 pos, Vec2 goal, Vec2 vel, double radius = 0.3) {
        const std::size_t i = agents.add(agent(static_cast<AgentId>(agents.size()), pos, goal, radius), 0);
        agents.vel[i] = vel;
        agents.prefVel[i] = normalisedOrZero(goal - pos) * agents.prefSpeed[i];
        return static_cast<int>(i);
    }
    StepContext context(double dt = 0.1, double relaxation = 0.5) {
        grid.build(agents.pos, 5.0);
        return StepContext{agents, world, grid, dt, 0.0, 0, 1, relaxation};
    }
    OwnedQuery query(int i) const {
        OwnedQuery q;
        setQueryAgent(q, agents, static_cast<std::size_t>(i));
        for (std::size_t j = 0; j < agents.size(); ++j)
            if (static_cast<int>(j) != i) q.agentStore.push_back(NeighbourAgent{agents.pos[j] - agents.pos[i], static_cast<int>(j)});
        for (std::size_t k = 0; k < world.segments().size(); ++k) q.segmentStore.push_back(static_cast<int>(k));
        q.bind();
        return q;
    }
};

inline ScenarioSpec scenario(std::vector<AgentSpec> agents, std::vector<PolicySpec> policies, double dt = 0.1,
                             double endTime = 60.0) {
    ScenarioSpec s;
    s.sourceFile = "<test>";
    s.deltaTime = dt;
    s.endTime = endTime;
    s.agents = std::move(agents);
    s.policies = std::move(policies);
    return s;
}

/// What happened in a run.
struct RunResult {
    double maxOverlapRatio = 0;               ///< max over time and pairs of overlap / min radius
    std::map<AgentId, double> arrival;        ///< first time each agent was within its goal radius
    std::map<AgentId, Vec2> finalPosition;
    bool finite = true;                       ///< no NaN/inf position ever
};

/// Runs to the end time, watching overlaps and arrivals after every coarse step.
inline RunResult run(const ScenarioSpec& spec, int threads = 1) {
    Simulation sim(spec);
    sim.setThreads(threads);
    RunResult r;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (!std::isfinite(A.pos[i].x()) || !std::isfinite(A.pos[i].y())) r.finite = false;
            if (A.atGoal(i) && !r.arrival.count(A.id[i])) r.arrival[A.id[i]] = sim.time();
            for (std::size_t j = i + 1; j < A.size(); ++j) {
                const double d = sim.world().offset(A.pos[i], A.pos[j]).norm();
                const double overlap = A.radius[i] + A.radius[j] - d;
                if (overlap > 0)
                    r.maxOverlapRatio = std::max(r.maxOverlapRatio, overlap / std::min(A.radius[i], A.radius[j]));
            }
        }
        for (const Evacuation& e : sim.evacuations())
            if (!r.arrival.count(e.id)) r.arrival[e.id] = e.time;
    }
    for (std::size_t i = 0; i < sim.agents().size(); ++i) r.finalPosition[sim.agents().id[i]] = sim.agents().pos[i];
    return r;
}

}  // namespace ch::test
