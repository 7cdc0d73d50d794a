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

/// 144 agents on a jittered 0.25 m lattice (3 m across: every one within 5 m of every other, so
/// ~143 entries per list), radii 0.15–0.35 m; runs two steps and checks the second step's contact
/// (computed from the positions after the first) against the definition. Returns how many agents
/// had a non-zero contact.
int checkPackedCluster(int threads) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> jitter(-0.05, 0.05), radius(0.15, 0.35);
    std::vector<AgentSpec> agents;
    for (int r = 0; r < 12; ++r)
        for (int c = 0; c < 12; ++c) {
            const Vec2 p(10 + 0.25 * c + jitter(rng), 10 + 0.25 * r + jitter(rng));
            agents.push_back(test::agent(static_cast<AgentId>(agents.size()), p, Vec2(p.x() + (r % 2 ? 20 : -20), p.y()),
                                         radius(rng)));
        }
    agents[37].radius = 0.6;  // one large body: the bound comes from the largest radius
    const double scale = 62.5, range = 5.0;
    ScenarioSpec spec = test::scenario(
        agents, {test::policy(0, OptimisationMethod::Gradient,
                              {test::component("SocialForcesAvoidance", {{"range", range}}), test::component("GoalReachingForce")},
                              0.5, {}, StepTiming::Coarse, scale)},
        0.1, 10.0);
    Simulation sim(spec);
    sim.setThreads(threads);
    sim.stepCoarse();
    std::map<AgentId, Body> bodies;
    {
        const AgentStore& A = sim.agents();
        BOOST_TEST_REQUIRE(A.size() == 144u);
        for (std::size_t i = 0; i < A.size(); ++i) bodies[A.id[i]] = Body{A.pos[i], A.radius[i], A.mass[i]};
    }
    sim.stepCoarse();
    const AgentStore& A = sim.agents();
    int touching = 0;
    for (std::size_t i = 0; i < A.size(); ++i) {
        const Vec2 want = definition(bodies, A.id[i], scale, range);
        const Vec2 got = A.contactAccel[i];
        // Summed in another order than the list's: equal to rounding (|acc| ~ 10-100 m/s²).
        BOOST_TEST_REQUIRE((got - want).norm() <= 1e-9 * (1 + want.norm()),
                           "agent " << A.id[i] << ": " << got.transpose() << " vs " << want.transpose());
        if (want.squaredNorm() > 0) ++touching;
    }
    return touching;
}

/// 400 agents on a jittered 1 m lattice (no two touch), radii 0.15–0.35 m, among 0.6 m pillars
/// every 3 m and a long wall; the second step's contact must be the spring of every wall each
/// agent overlaps (the definition, over every segment of the world). Returns how many touched.
int checkWalls(int threads) {
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> jitter(-0.3, 0.3), radius(0.15, 0.35);
    std::vector<AgentSpec> agents;
    for (int r = 0; r < 20; ++r)
        for (int c = 0; c < 20; ++c) {
            const Vec2 p(c + jitter(rng), r + jitter(rng));
            agents.push_back(test::agent(static_cast<AgentId>(agents.size()), p, Vec2(p.x() + (r % 2 ? 30 : -30), p.y()),
                                         radius(rng)));
        }
    const double scale = 62.5, range = 5.0;
    ScenarioSpec spec = test::scenario(
        agents, {test::policy(0, OptimisationMethod::Gradient,
                              {test::component("SocialForcesAvoidance", {{"range", range}}), test::component("GoalReachingForce")},
                              0.5, {}, StepTiming::Coarse, scale)},
        0.1, 10.0);
    for (int i = 0; i < 7; ++i)
        for (int j = 0; j < 7; ++j) {
            ObstacleSpec o;
            const Vec2 c(3.0 * i + 0.7, 3.0 * j + 0.7);
            o.points = {c, c + Vec2(0.6, 0), c + Vec2(0.6, 0.6), c + Vec2(0, 0.6)};
            spec.obstacles.push_back(o);
        }
    ObstacleSpec wall;
    wall.points = {{-1, 10.2}, {21, 10.2}};
    spec.obstacles.push_back(wall);
    Simulation sim(spec);
    sim.setThreads(threads);
    sim.stepCoarse();
    std::map<AgentId, Body> bodies;
    {
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) bodies[A.id[i]] = Body{A.pos[i], A.radius[i], A.mass[i]};
    }
    sim.stepCoarse();
    const AgentStore& A = sim.agents();
    BOOST_TEST_REQUIRE(A.size() == 400u);
    int touching = 0;
    for (std::size_t i = 0; i < A.size(); ++i) {
        const Body& me = bodies.at(A.id[i]);
        Vec2 want = definition(bodies, A.id[i], scale, range);
        BOOST_TEST_REQUIRE(want.squaredNorm() == 0.0);  // no two agents touch
        for (const Segment& seg : sim.world().segments()) {
            const Vec2 diff = me.pos - closestPointOnSegment(me.pos, seg.a, seg.b);
            const double d = diff.norm(), overlap = me.radius - d;
            if (overlap > 0 && d > 1e-12) want += diff / d * (scale * overlap);
        }
        want /= me.mass;
        const Vec2 got = A.contactAccel[i];
        BOOST_TEST_REQUIRE((got - want).norm() <= 1e-9 * (1 + want.norm()),
                           "agent " << A.id[i] << ": " << got.transpose() << " vs " << want.transpose());
        if (want.squaredNorm() > 0) ++touching;
    }
    return touching;
}

}  // namespace

BOOST_AUTO_TEST_CASE(contact_with_walls_is_the_sum_over_every_wall_overlapped) {
    for (const int threads : {1, 2}) {
        const int touching = checkWalls(threads);
        BOOST_TEST(touching > 20, "threads " << threads << ": " << touching << " touching a wall");
        BOOST_TEST(touching < 300);  // and most agents are clear of every wall
    }
}

BOOST_AUTO_TEST_CASE(contact_of_a_packed_cluster_is_the_sum_over_every_overlap) {
    const int was = nearEntriesPath();
    for (const int path : {0, 1}) {
        if (!setNearEntriesPath(path)) continue;
        for (const int threads : {1, 2}) {
            const int touching = checkPackedCluster(threads);
            BOOST_TEST(touching > 100, "path " << path << " threads " << threads << ": " << touching << " touching");
        }
    }
    setNearEntriesPath(was);
}
