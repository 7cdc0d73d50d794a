// CrowdHealth tests — UMANS' post-clamp contact (Simulation::umansContactAcceleration) in a packed
// cluster (issue 20): the contact pass now reads only the candidates nearEntries keeps from each
// neighbour list (64 entries at a time), so a crowd with more than 64 neighbours per agent, many
// of them overlapping, and radii that differ, must give every agent the spring sum over *all*
// its overlapping neighbours, as the definition computed here by brute force. Walls likewise:
// the pass skips the walls whose bounds lie beyond the agent's radius, and an agent by a wall
// must still get the spring of every wall it overlaps.
#define BOOST_TEST_MODULE core_umans_contact
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/core/near_filter.h"

#include <cmath>
#include <map>
#include <random>

using namespace ch;

namespace {

struct Body {
    Vec2 pos;
    double radius, mass;
};

/// Σ over the others within `range` of −offset/d · scale·(r_a + r_b − d), over the mass: UMANS'
/// spring for every overlap (no walls here).
Vec2 definition(const std::map<AgentId, Body>& bodies, AgentId a, double scale, double range) {
    const Body& me = bodies.at(a);
    Vec2 acc(0, 0);
    for (const auto& [id, other] : bodies) {
        if (id == a) continue;
        const Vec2 offset = other.pos - me.pos;
        const double d = offset.norm();
        if (d > range) continue;
        const double overlap = me.radius + other.radius - d;
        if (overlap > 0 && d > 1e-12) acc -= offset / d * (scale * overlap);
    }
    return acc / me.mass;
}

/// side × side agents on a jittered lattice of `spacing` from (origin, origin), radii 0.15–0.35 m,
/// odd rows walking +x and even rows −x towards goals `goal` metres away.
std::vector<AgentSpec> jitteredLattice(int side, double spacing, double origin, double jitter, double goal,
                                       std::mt19937_64& rng) {
    std::uniform_real_distribution<double> shift(-jitter, jitter), radius(0.15, 0.35);
    std::vector<AgentSpec> agents;
    for (int r = 0; r < side; ++r)
        for (int c = 0; c < side; ++c) {
            const Vec2 p(origin + spacing * c + shift(rng), origin + spacing * r + shift(rng));
            agents.push_back(test::agent(static_cast<AgentId>(agents.size()), p, Vec2(p.x() + (r % 2 ? goal : -goal), p.y()),
                                         radius(rng)));
        }
    return agents;
}

/// How many agents had a spring from another agent, and how many from a wall.
struct Touching {
    int agents = 0, walls = 0;
};

/// Runs two SocialForces steps (range 5 m, UMANS' contact scale 62.5) and checks every agent's
/// contact in the second step, computed from the positions after the first, against the
/// definition: the springs of every other agent it overlaps and of every wall of the world it
/// overlaps.
Touching checkContact(int threads, const std::vector<AgentSpec>& agents, const std::vector<ObstacleSpec>& obstacles) {
    const double scale = 62.5, range = 5.0;
    ScenarioSpec spec = test::scenario(
        agents, {test::policy(0, OptimisationMethod::Gradient,
                              {test::component("SocialForcesAvoidance", {{"range", range}}), test::component("GoalReachingForce")},
                              0.5, {}, StepTiming::Coarse, scale)},
        0.1, 10.0);
    spec.obstacles = obstacles;
    Simulation sim(spec);
    sim.setThreads(threads);
    sim.stepCoarse();
    std::map<AgentId, Body> bodies;
    {
        const AgentStore& A = sim.agents();
        BOOST_TEST_REQUIRE(A.size() == agents.size());
        for (std::size_t i = 0; i < A.size(); ++i) bodies[A.id[i]] = Body{A.pos[i], A.radius[i], A.mass[i]};
    }
    sim.stepCoarse();
    const AgentStore& A = sim.agents();
    Touching touching;
    for (std::size_t i = 0; i < A.size(); ++i) {
        const Body& me = bodies.at(A.id[i]);
        const Vec2 fromAgents = definition(bodies, A.id[i], scale, range);
        Vec2 fromWalls(0, 0);
        for (const Segment& seg : sim.world().segments()) {
            const Vec2 diff = me.pos - closestPointOnSegment(me.pos, seg.a, seg.b);
            const double d = diff.norm(), overlap = me.radius - d;
            if (overlap > 0 && d > 1e-12) fromWalls += diff / d * (scale * overlap);
        }
        const Vec2 want = fromAgents + fromWalls / me.mass;
        const Vec2 got = A.contactAccel[i];
        // Summed in another order than the list's: equal to rounding (|acc| ~ 10-100 m/s²).
        BOOST_TEST_REQUIRE((got - want).norm() <= 1e-9 * (1 + want.norm()),
                           "agent " << A.id[i] << ": " << got.transpose() << " vs " << want.transpose());
        touching.agents += fromAgents.squaredNorm() > 0 ? 1 : 0;
        touching.walls += fromWalls.squaredNorm() > 0 ? 1 : 0;
    }
    return touching;
}

/// 144 agents on a jittered 0.25 m lattice (3 m across: every one within 5 m of every other, so
/// ~143 entries per list), one of them large.
Touching checkPackedCluster(int threads) {
    std::mt19937_64 rng(7);
    std::vector<AgentSpec> agents = jitteredLattice(12, 0.25, 10, 0.05, 20, rng);
    agents[37].radius = 0.6;  // one large body: the bound comes from the largest radius
    return checkContact(threads, agents, {});
}

/// 400 agents on a jittered 1 m lattice (no two touch) among 0.6 m pillars every 3 m and a long wall.
Touching checkWalls(int threads) {
    std::mt19937_64 rng(9);
    std::vector<ObstacleSpec> obstacles;
    for (int i = 0; i < 7; ++i)
        for (int j = 0; j < 7; ++j) {
            ObstacleSpec o;
            const Vec2 c(3.0 * i + 0.7, 3.0 * j + 0.7);
            o.points = {c, c + Vec2(0.6, 0), c + Vec2(0.6, 0.6), c + Vec2(0, 0.6)};
            obstacles.push_back(o);
        }
    ObstacleSpec wall;
    wall.points = {{-1, 10.2}, {21, 10.2}};
    obstacles.push_back(wall);
    return checkContact(threads, jitteredLattice(20, 1.0, 0, 0.3, 30, rng), obstacles);
}

}  // namespace

BOOST_AUTO_TEST_CASE(contact_with_walls_is_the_sum_over_every_wall_overlapped) {
    for (const int threads : {1, 2}) {
        const Touching touching = checkWalls(threads);
        BOOST_TEST(touching.agents == 0);  // the lattice keeps them apart: the walls alone
        BOOST_TEST(touching.walls > 20, "threads " << threads << ": " << touching.walls << " touching a wall");
        BOOST_TEST(touching.walls < 300);  // and most agents are clear of every wall
    }
}

BOOST_AUTO_TEST_CASE(contact_of_a_packed_cluster_is_the_sum_over_every_overlap) {
    const int was = nearEntriesPath();
    for (const int path : {0, 1}) {
        if (!setNearEntriesPath(path)) continue;
        for (const int threads : {1, 2}) {
            const int touching = checkPackedCluster(threads).agents;
            BOOST_TEST(touching > 100, "path " << path << " threads " << threads << ": " << touching << " touching");
        }
    }
    setNearEntriesPath(was);
}
