// CrowdHealth tests — neighbour lists gathered agent by agent (issue 20). When no component of a
// scenario reads the neighbour lists through its StepContext (Component::readsStepLists), the
// simulation gathers each agent's lists just before its policy's calls instead of storing every
// list of the step. That must change nothing: the same positions and velocities, to the bit, as
// with the lists stored, for policies of different ranges, walls, UMANS' contact, 1 and 2
// threads; and a scenario with a component that does read stored lists (SPH, ContactForces, a
// plugin that does not say) must keep them stored.
#define BOOST_TEST_MODULE core_list_streaming
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include <atomic>
#include <cstring>
#include <random>
#include <string>
#include <tuple>

using namespace ch;

namespace {

/// 600 agents in two counter-flowing groups through a corridor with a pillar: policy 0 social
/// forces (range 5 m) + goal reaching, policy 1 the time-to-collision cost TtcaDca (range 3 m,
/// sampling), both with UMANS' contact; `extra` is added to policy 0 when given.
ScenarioSpec corridor(const ComponentSpec* extra = nullptr) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> jitter(-0.1, 0.1), radius(0.2, 0.3);
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 600; ++k) {
        const int row = k / 30, col = k % 30;
        const bool right = row % 2 == 0;
        const Vec2 p(0.7 * col + jitter(rng) + (right ? 0.0 : 4.0), -6.0 + 0.6 * row + jitter(rng));
        agents.push_back(test::agent(static_cast<AgentId>(k), p, Vec2(right ? 60.0 : -40.0, p.y()), radius(rng), 1.3,
                                     1.6, k % 3 == 0 ? 1 : 0));
    }
    std::vector<ComponentSpec> sf = {test::component("SocialForcesAvoidance", {{"range", 5.0}}),
                                     test::component("GoalReachingForce")};
    if (extra != nullptr) sf.push_back(*extra);
    SamplingSpec sampling;
    ScenarioSpec spec = test::scenario(
        agents,
        {test::policy(0, OptimisationMethod::Gradient, sf, 0.5),
         test::policy(1, OptimisationMethod::Sampling, {test::component("TtcaDca", {{"range", 3.0}})}, 0.0, sampling)},
        0.1, 60.0);
    ObstacleSpec pillar;
    pillar.points = {{10, -1}, {11, -1}, {11, 1}, {10, 1}};
    ObstacleSpec north, south;
    north.points = {{-5, 6.5}, {40, 6.5}, {40, 7}, {-5, 7}};
    south.points = {{-5, -7}, {40, -7}, {40, -6.5}, {-5, -6.5}};
    spec.obstacles = {pillar, north, south};
    return spec;
}

bool sameBits(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec2)) == 0;
}

/// Steps both simulations `steps` coarse steps, requiring the same positions, velocities and
/// contact accelerations, bit for bit, after each; returns the largest contact acceleration seen.
double stepAlike(Simulation& a, Simulation& b, int steps, int threads) {
    double contact = 0;
    for (int step = 0; step < steps; ++step) {
        a.stepCoarse();
        b.stepCoarse();
        const AgentStore &x = a.agents(), &y = b.agents();
        BOOST_TEST_REQUIRE(x.size() == y.size());
        BOOST_TEST_REQUIRE(sameBits(x.pos, y.pos), "positions differ at step " << step << ", " << threads << " threads");
        BOOST_TEST_REQUIRE(sameBits(x.vel, y.vel), "velocities differ at step " << step << ", " << threads << " threads");
        BOOST_TEST_REQUIRE(sameBits(x.contactAccel, y.contactAccel), "contacts differ at step " << step);
        for (const Vec2& c : x.contactAccel) contact = std::max(contact, c.norm());
    }
    return contact;
}

}  // namespace

BOOST_AUTO_TEST_CASE(gathered_lists_give_the_bits_of_stored_ones) {
    for (const int threads : {1, 2}) {
        Simulation gathered(corridor()), stored(corridor());
        BOOST_TEST(!gathered.storesNeighbourLists());  // every component reads only its query's lists
        stored.setStoreNeighbourLists(true);
        BOOST_TEST(stored.storesNeighbourLists());
        gathered.setThreads(threads);
        stored.setThreads(threads);
        const double contact = stepAlike(gathered, stored, 40, threads);
        // The crowd does interact: agents moved, and some touched (UMANS' contact read the lists).
        BOOST_TEST(contact > 0.0);
        BOOST_TEST(gathered.agents().pos[0].x() > 1.0);
    }
}

BOOST_AUTO_TEST_CASE(a_component_reading_stored_lists_keeps_them) {
    // ContactForces reads other agents' neighbourhoods in prepare(), through its StepContext.
    const ComponentSpec contact = test::component("ContactForces");
    Simulation sim(corridor(&contact));
    BOOST_TEST(sim.storesNeighbourLists());
    sim.setStoreNeighbourLists(false);  // ignored: the component needs them
    BOOST_TEST(sim.storesNeighbourLists());
    sim.stepCoarse();
    BOOST_TEST(sim.agents().size() == 600u);
}

namespace {

/// A component that does not say how it reads the lists (as a plugin written before
/// readsStepLists): the simulation must assume it reads them stored.
class Silent : public ForceComponent {
public:
    Vec2 acceleration(const AgentQuery&, const StepContext&) const override { return Vec2(0, 0); }
};

}  // namespace

BOOST_AUTO_TEST_CASE(a_component_that_does_not_say_is_taken_to_read_stored_lists) {
    BOOST_TEST(Silent().readsStepLists());
    for (const char* name : {"SPH", "ContactForces"}) BOOST_TEST(test::make(name)->readsStepLists(), name);
    for (const char* name : {"SocialForcesAvoidance", "GoalReachingForce", "TtcaDca", "ORCA", "RVO", "PowerLaw"})
        BOOST_TEST(!test::make(name)->readsStepLists(), name);
}

BOOST_AUTO_TEST_CASE(step_context_helpers_read_the_stored_index_lists_as_the_grid_would) {
    // A 7 × 7 lattice of 1 m spacing: with a query radius of 1 m, the four nearest neighbours are
    // exactly on the circle, and the test that keeps them (|offset|² <= r²) must be the same
    // whether StepContext reads the stored lists (indices, offsets computed on reading) or the grid.
    test::Frame f;
    for (int y = 0; y < 7; ++y)
        for (int x = 0; x < 7; ++x) f.add(Vec2(x, y), Vec2(10, y), Vec2(0, 0));
    StepContext withLists = f.context();
    const std::vector<int> group(f.agents.size(), 0);
    NeighbourLists lists;
    lists.build(f.agents.pos, f.grid, f.world, group, {1.5});
    withLists.lists = &lists;
    const StepContext onGrid = f.context();
    using Found = std::vector<std::tuple<int, double, double, double>>;
    const auto found = [](const StepContext& ctx, std::size_t i, double r) {
        Found out;
        ctx.forEachNeighbour(i, r, [&](int j, const Vec2& d, double d2) { out.emplace_back(j, d.x(), d.y(), d2); });
        std::sort(out.begin(), out.end());
        return out;
    };
    std::vector<NeighbourAgent> scratch, fromGrid;
    for (std::size_t i = 0; i < f.agents.size(); ++i) {
        BOOST_TEST_REQUIRE(withLists.listReaches(i, 1.0));
        const Found a = found(withLists, i, 1.0), b = found(onGrid, i, 1.0);
        BOOST_TEST(a.size() == b.size());
        BOOST_TEST((a == b), "agent " << i);
        const bool inner = i % 7 != 0 && i % 7 != 6 && i / 7 != 0 && i / 7 != 6;
        if (inner) BOOST_TEST(a.size() == 4u);  // the four at exactly 1 m
        // neighbourList: the stored list (with its offsets) when it reaches, every entry exact.
        const std::span<const NeighbourAgent> list = withLists.neighbourList(i, 1.0, scratch);
        BOOST_TEST(list.size() == lists.indices(i).size());
        for (const NeighbourAgent& nb : list)
            BOOST_TEST((Vec2(nb.offset) == f.agents.pos[static_cast<std::size_t>(nb.index)] - f.agents.pos[i]));
        BOOST_TEST(!onGrid.listReaches(i, 1.0));
        BOOST_TEST(onGrid.neighbourList(i, 1.0, fromGrid).size() == b.size());
    }
}

namespace {

/// Reads AgentQuery::agents and adds nothing: with it in a policy, the simulation must gather
/// each agent's neighbours (Component::readsQueryAgents, true by default). It counts what it saw.
std::atomic<long> gProbeSeen{0};
class QueryProbe : public ForceComponent {
public:
    explicit QueryProbe(const ParamSet& params) { bind(params, "range", range_); }
    bool readsStepLists() const override { return false; }
    bool readsQueryAgents() const override { return true; }
    Vec2 acceleration(const AgentQuery& q, const StepContext&) const override {
        gProbeSeen += static_cast<long>(q.agents.size());
        return Vec2(0, 0);
    }
};

void registerProbe() {
    static const bool once = [] {
        ComponentInfo info;
        info.name = "QueryAgentsProbeForTests";
        info.kind = ComponentKind::Force;
        info.summary = "test only";
        info.defaultRange = 0;
        info.create = [](const ParamSet& p) -> std::unique_ptr<Component> { return std::make_unique<QueryProbe>(p); };
        return Registry::instance().add(info);
    }();
    (void)once;
}

/// A dense SPH crowd (about 4 P/m²) pressed against a wall with a pillar: GoalReachingForce, SPH,
/// SocialGroups and ContactForces (the built-in components that say they read no
/// AgentQuery::agents), or UMANS' contact instead of ContactForces when `umans`, with the probe
/// first when `probe`. `world` plane or torus.
ScenarioSpec pressed(bool probe, WorldType world, bool umans) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> jitter(-0.05, 0.05), radius(0.22, 0.26);
    std::vector<AgentSpec> agents;
    std::vector<std::string> groups;
    for (int k = 0; k < 400; ++k) {
        const Vec2 p(-6.0 + 0.5 * (k % 20) + jitter(rng), -5.0 + 0.5 * (k / 20) + jitter(rng));
        AgentSpec a = test::agent(static_cast<AgentId>(k), p, Vec2(30.0, p.y() * 0.2), radius(rng), 1.3, 1.6);
        if (k % 7 < 3) {  // groups of three, numbered by their first member
            if (k % 7 == 0) groups.push_back("g" + std::to_string(k / 7));
            a.group = groups.back();
            a.groupIndex = static_cast<int>(groups.size()) - 1;
        }
        agents.push_back(a);
    }
    std::vector<ComponentSpec> c;
    if (probe) c.push_back(test::component("QueryAgentsProbeForTests"));
    c.push_back(test::component("GoalReachingForce", {{"range", 0}}));
    c.push_back(test::component("SPH", {{"range", 1}}));
    if (!umans) c.push_back(test::component("ContactForces", {{"range", 1}}));
    c.push_back(test::component("SocialGroups"));
    ScenarioSpec spec = test::scenario(agents, {test::policy(0, OptimisationMethod::Gradient, c, 0.0, {},
                                                             StepTiming::Coarse, umans ? 62.5 : 0.0)},
                                       0.05, 60.0);
    spec.groups = groups;
    if (world == WorldType::Toric) {
        spec.world.type = WorldType::Toric;
        spec.world.width = 24;
        spec.world.height = 16;
    }
    ObstacleSpec wall, pillar;
    wall.points = {{5, -7.5}, {5.5, -7.5}, {5.5, 7.5}, {5, 7.5}};
    pillar.points = {{1, -0.5}, {2, -0.5}, {2, 0.5}, {1, 0.5}};
    spec.obstacles = {wall, pillar};
    return spec;
}

}  // namespace

BOOST_AUTO_TEST_CASE(neighbours_withheld_from_components_that_do_not_read_them_change_nothing) {
    // SPH, ContactForces, GoalReachingForce and SocialGroups say their per-agent calls read no
    // AgentQuery::agents, so a policy of only those gets none (the simulation skips computing
    // every list entry's offset). A component that does read them, added to the policy and
    // adding nothing, makes the simulation gather them again: the run must be the same, bit for
    // bit. A component that said so but read q.agents would see empty lists in one run only.
    registerProbe();
    for (const char* name : {"SPH", "ContactForces", "GoalReachingForce", "SocialGroups", "RandomFunction"})
        BOOST_TEST(!test::make(name)->readsQueryAgents(), name);
    for (const char* name : {"SocialForcesAvoidance", "TtcaDca", "ORCA", "VanToll"}) BOOST_TEST(test::make(name)->readsQueryAgents(), name);
    BOOST_TEST(Silent().readsQueryAgents());  // a plugin that does not say gets its neighbours
    for (const bool umans : {false, true})
        for (const WorldType world : {WorldType::Infinite, WorldType::Toric})
            for (const int threads : {1, 2}) {
                Simulation without(pressed(false, world, umans)), with(pressed(true, world, umans));
                without.setThreads(threads);
                with.setThreads(threads);
                gProbeSeen = 0;
                const double contact = stepAlike(without, with, 30, threads);
                // The probe saw the neighbours (so they were gathered for it), and the crowd is
                // dense enough that bodies touch (ContactForces' or UMANS' contact acts).
                BOOST_TEST(gProbeSeen.load() > 400L * 30 * 8);
                BOOST_TEST(contact > 0.0);
            }
}
