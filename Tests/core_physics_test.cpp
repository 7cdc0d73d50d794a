// Physics of the foundation: a lone agent walks at its preferred speed, social forces are
// pairwise symmetric, and results do not depend on the number of threads.
#define BOOST_TEST_MODULE core_physics
#include <boost/test/unit_test.hpp>

#include "SocialForcesAvoidance.h"
#include "crowdhealth/core/kernels.h"
#include "crowdhealth/core/rng.h"
#include "test_support.h"

#include <cmath>
#include <map>

using namespace ch;

namespace {
PolicySpec socialForcesPolicy(double relaxation = 0.5) {
    return test::policy(0, OptimisationMethod::Gradient,
                        {test::component("SocialForcesAvoidance"), test::component("GoalReachingForce")}, relaxation);
}
}  // namespace

BOOST_AUTO_TEST_CASE(lone_agent_arrives_when_relaxation_predicts) {
    // Relaxation v_{k+1} = v_k + dt (v_p - v_k)/τ from rest gives v_k = v_p (1 - q^k), q = 1 - dt/τ,
    // and x_n = dt Σ_{k=1..n} v_k (position uses the new velocity). The goal is 20 m away; the
    // agent is removed when within its radius, i.e. after 20 - r metres.
    const double dt = 0.1, tau = 0.5, vp = 1.4, r = 0.24, D = 20.0;
    auto a = test::agent(1, {0, 0}, {D, 0}, r, vp, 1.8);
    a.removeAtGoal = true;
    auto spec = test::scenario({a}, {socialForcesPolicy(tau)}, dt, 60);
    spec.endTime = -1;  // until the agent has left
    Simulation sim(spec);
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST_REQUIRE(sim.evacuations().size() == 1u);
    const double measured = sim.evacuations()[0].time;

    double x = 0, v = 0;
    int n = 0;
    const double q = 1 - dt / tau;
    while (x < D - r) {
        ++n;
        v = vp * (1 - std::pow(q, n));
        x += v * dt;
    }
    const double predicted = n * dt;
    BOOST_TEST(std::abs(measured - predicted) / predicted < 0.03,
               "arrival " << measured << " s, relaxation predicts " << predicted << " s");
    // And the continuous-time estimate D/v_p + τ is within the same tolerance.
    BOOST_TEST(std::abs(measured - ((D - r) / vp + tau)) / measured < 0.03);
}

BOOST_AUTO_TEST_CASE(lone_agent_cruises_at_preferred_speed) {
    auto a = test::agent(1, {0, 0}, {100, 0}, 0.3, 1.3, 1.6);
    auto spec = test::scenario({a}, {socialForcesPolicy()}, 0.1, 20);
    Simulation sim(spec);
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(std::abs(sim.agents().vel[0].norm() - 1.3) < 1e-6);
    // Straight along x up to the symmetry breaking (Simulation@symmetry_breaking): while it starts
    // from rest, slower than half its preferred speed, it is moved by up to 1e-6 m per step, and
    // its goal direction turns by ~1e-7 rad (measured: |v_y| 4e-10 m/s; 0 without it).
    BOOST_TEST(std::abs(sim.agents().vel[0].y()) < 1e-8);
}

BOOST_AUTO_TEST_CASE(social_pair_forces_are_equal_and_opposite) {
    test::component("SocialForcesAvoidance");  // make sure it is registered
    SocialForcesAvoidance sf(ParamSet(Registry::fullTable(SocialForcesAvoidance::Info())));
    Rng rng(5);
    for (int k = 0; k < 50; ++k) {
        // Two pedestrians at rest: the potential is isotropic, so f_ab = -f_ba exactly.
        const Vec2 xa(rng.uniform(-2, 2), rng.uniform(-2, 2)), xb(rng.uniform(-2, 2), rng.uniform(-2, 2));
        const Vec2 fab = sf.pairForce(xa - xb, 0.0, Vec2(1, 0));
        const Vec2 fba = sf.pairForce(xb - xa, 0.0, Vec2(0, 1));
        BOOST_TEST((fab + fba).norm() <= 1e-12 * std::max(1.0, fab.norm()));
        // Repulsive: along a → away from b.
        BOOST_TEST(fab.dot(xa - xb) > 0);
    }
    // Two pedestrians walking towards each other symmetrically: mirror-symmetric forces.
    const Vec2 R(2.0, 0.3);
    const Vec2 fab = sf.pairForce(R, 1.2, Vec2(-1, 0));   // b walks towards a (−x)
    const Vec2 fba = sf.pairForce(-R, 1.2, Vec2(1, 0));   // a walks towards b (+x)
    BOOST_TEST((fab + fba).norm() < 1e-12);
}

BOOST_AUTO_TEST_CASE(social_force_is_minus_the_potential_gradient) {
    ParamSet p(Registry::fullTable(SocialForcesAvoidance::Info()));
    SocialForcesAvoidance sf(p);
    const double V0 = 2.1, sigma = 0.3, dt = 2.0;
    auto potential = [&](const Vec2& R, double vb, const Vec2& eb) {
        const Vec2 s = vb * dt * eb;
        const double b = 0.5 * std::sqrt(std::pow(R.norm() + (R - s).norm(), 2) - s.squaredNorm());
        return V0 * std::exp(-b / sigma);
    };
    Rng rng(9);
    for (int k = 0; k < 30; ++k) {
        const Vec2 R(rng.uniform(0.5, 3), rng.uniform(-3, 3));
        const double vb = rng.uniform(0, 1.5);
        const Vec2 eb = rotated(Vec2(1, 0), rng.uniform(-kPi, kPi));
        const double h = 1e-6;
        const Vec2 grad((potential(R + Vec2(h, 0), vb, eb) - potential(R - Vec2(h, 0), vb, eb)) / (2 * h),
                        (potential(R + Vec2(0, h), vb, eb) - potential(R - Vec2(0, h), vb, eb)) / (2 * h));
        const Vec2 f = sf.pairForce(R, vb, eb);
        BOOST_TEST((f + grad).norm() < 1e-6 * std::max(1.0, f.norm()));
    }
}

BOOST_AUTO_TEST_CASE(same_seed_identical_with_one_and_two_threads) {
    // 60 agents in two crossing streams with random sampling: any shared state would show.
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 30; ++k) {
        agents.push_back(test::agent(k, {-8.0 - (k % 5), -3.0 + (k / 5)}, {8, -3.0 + (k / 5)}));
        agents.push_back(test::agent(100 + k, {-3.0 + (k / 5), -8.0 - (k % 5)}, {-3.0 + (k / 5), 8}));
    }
    SamplingSpec s;
    s.type = SamplingSpec::Type::Random;
    s.randomSamples = 40;
    s.radius = SamplingSpec::Radius::MaximumSpeed;
    auto sf = test::scenario(agents, {socialForcesPolicy()}, 0.1, 15);
    auto sampled = test::scenario(
        agents, {test::policy(0, OptimisationMethod::Sampling, {test::component("SocialForcesAvoidance"),
                                                                  test::component("GoalReachingForce")},
                              0.5, s)},
        0.1, 15);
    for (const ScenarioSpec& spec : {sf, sampled}) {
        Simulation one(spec), two(spec);
        one.setThreads(1);
        while (!one.finished()) one.stepCoarse();
        two.setThreads(2);
        while (!two.finished()) two.stepCoarse();
        BOOST_TEST_REQUIRE(one.agents().size() == two.agents().size());
        for (std::size_t i = 0; i < one.agents().size(); ++i) {
            BOOST_TEST(one.agents().pos[i].x() == two.agents().pos[i].x());  // bit-identical
            BOOST_TEST(one.agents().pos[i].y() == two.agents().pos[i].y());
        }
    }
}

BOOST_AUTO_TEST_CASE(start_time_activates_agents_on_time) {
    auto a = test::agent(1, {0, 0}, {10, 0});
    auto b = test::agent(2, {0, 5}, {10, 5});
    b.startTime = 2.0;
    auto spec = test::scenario({a, b}, {socialForcesPolicy()}, 0.1, 3);
    Simulation sim(spec);
    BOOST_TEST(sim.agents().size() == 1u);
    BOOST_TEST(sim.pending() == 1u);
    while (sim.time() < 1.95) sim.stepCoarse();
    BOOST_TEST(sim.agents().size() == 1u);
    sim.stepCoarse();  // the step starting at t = 2 s activates agent 2
    BOOST_TEST(sim.agents().size() == 2u);
}

BOOST_AUTO_TEST_CASE(toric_world_wraps_positions) {
    auto a = test::agent(1, {4.5, 0}, {1000, 0}, 0.3, 1.0, 1.0);
    auto spec = test::scenario({a}, {socialForcesPolicy(0.1)}, 0.1, 3);
    spec.world.type = WorldType::Toric;
    spec.world.width = spec.world.height = 10;
    Simulation sim(spec);
    while (!sim.finished()) sim.stepCoarse();
    const double x = sim.agents().pos[0].x();
    BOOST_TEST(x >= -5.0);
    BOOST_TEST(x < 5.0);
    BOOST_TEST(x < 0.0, "the agent crossed x = 5 and must reappear near x = -5, got " << x);
}

BOOST_AUTO_TEST_CASE(measured_density_of_a_lone_agent_is_m_times_4_over_pi) {
    auto a = test::agent(1, {0, 0}, {0, 0});
    a.mass = 1.3;
    auto spec = test::scenario({a}, {socialForcesPolicy()}, 0.1, 1);
    Simulation sim(spec);
    sim.measureDensity(1.0);
    BOOST_TEST(std::abs(sim.agents().density[0] - 1.3 * 4.0 / kPi) < 1e-12);
}

BOOST_AUTO_TEST_CASE(wall_penetration_is_measured_from_the_shortest_way_out) {
    // A 2 m × 1 m wall; agents of radius 0.25 m at known depths.
    auto spec = test::scenario({test::agent(1, {0.5, -0.1}, {0.5, -5}, 0.25),    // outside, 0.1 m from the face
                                test::agent(2, {1.0, 0.2}, {1.0, 5}, 0.25),      // inside, 0.2 m from the face
                                test::agent(3, {5.0, 5.0}, {6, 6}, 0.25)},       // far away
                               {socialForcesPolicy()}, 0.1, 1);
    ObstacleSpec wall;
    wall.points = {{0, 0}, {2, 0}, {2, 1}, {0, 1}};
    spec.obstacles.push_back(wall);
    Simulation sim(spec);
    // Agent 2: centre 0.2 m inside (nearest edge y = 0) → 0.25 + 0.2; agent 1 would give 0.15.
    BOOST_TEST(std::abs(sim.maxWallPenetration() - 0.45) < 1e-12);
}

BOOST_AUTO_TEST_CASE(wall_penetration_and_obstacles_found_by_index_match_a_scan_of_them_all) {
    // A venue of many obstacles: small pillars (some overlapping, some concave), a hall-sized
    // polygon round part of them and single walls. World::obstacleAt (only the obstacles listed in
    // the point's cell are tested) must name the lowest-numbered polygon holding the point, as a
    // scan of every obstacle does, and maxWallPenetration must equal the scan's depth.
    Rng rng(21);
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 600; ++k) {
        const Vec2 p(rng.uniform(-2, 62), rng.uniform(-2, 62));
        agents.push_back(test::agent(k + 1, p, p + Vec2(1, 0), rng.uniform(0.2, 0.3)));
    }
    auto spec = test::scenario(agents, {socialForcesPolicy()}, 0.1, 1);
    for (int k = 0; k < 300; ++k) {
        const Vec2 c(rng.uniform(0, 60), rng.uniform(0, 60));
        const double s = rng.uniform(0.3, 2.5);
        ObstacleSpec o;
        if (k % 3 == 0)  // an L: concave
            o.points = {c, c + Vec2(s, 0), c + Vec2(s, 0.4 * s), c + Vec2(0.4 * s, 0.4 * s), c + Vec2(0.4 * s, s), c + Vec2(0, s)};
        else
            o.points = {c, c + Vec2(s, 0.2 * s), c + Vec2(0.8 * s, s), c + Vec2(-0.1 * s, 0.9 * s)};
        spec.obstacles.push_back(o);
    }
    ObstacleSpec hall;
    hall.points = {{10, 10}, {50, 12}, {48, 50}, {12, 47}};
    spec.obstacles.push_back(hall);
    for (int k = 0; k < 20; ++k) {
        ObstacleSpec wall;
        const Vec2 a(rng.uniform(0, 60), rng.uniform(0, 60));
        wall.points = {a, a + Vec2(rng.uniform(-6, 6), rng.uniform(-6, 6))};
        spec.obstacles.push_back(wall);
    }
    Simulation sim(spec);
    const World& world = sim.world();
    const auto scanAt = [&](const Vec2& p) {
        for (std::size_t o = 0; o < spec.obstacles.size(); ++o)
            if (spec.obstacles[o].points.size() >= 3 && pointInPolygon(p, spec.obstacles[o].points)) return static_cast<int>(o);
        return -1;
    };
    int inside = 0, insideHallOnly = 0;
    for (int q = 0; q < 40000; ++q) {
        const Vec2 p(rng.uniform(-3, 63), rng.uniform(-3, 63));
        const int o = scanAt(p);
        BOOST_TEST(world.obstacleAt(p) == o);
        BOOST_TEST(world.insideObstacle(p) == (o >= 0));
        inside += o >= 0 ? 1 : 0;
        insideHallOnly += o == 300 ? 1 : 0;
    }
    // Vertices and points a hair to either side of them, where the crossings are interpolated
    // (down to a few units in the last place: a crossing may round past the vertices' bounds).
    for (const ObstacleSpec& ob : spec.obstacles)
        for (const Vec2& v : ob.points) {
            for (const Vec2& d : {Vec2(0, 0), Vec2(1e-12, 0), Vec2(-1e-12, 0), Vec2(0, 1e-12), Vec2(1e-9, -1e-9)})
                BOOST_TEST(world.obstacleAt(v + d) == scanAt(v + d));
            Vec2 right = v, left = v;
            for (int k = 0; k < 4; ++k) {
                right.x() = std::nextafter(right.x(), kInf);
                left.x() = std::nextafter(left.x(), -kInf);
                BOOST_TEST(world.obstacleAt(right) == scanAt(right));
                BOOST_TEST(world.obstacleAt(left) == scanAt(left));
            }
        }
    // A case where it does: pointInPolygon puts this point, one unit in the last place right of
    // the triangle's rightmost vertex, inside the triangle.
    ObstacleSpec tri;
    tri.points = {{27.4579810196322, -44.928906881234894}, {-36.279110627786807, -40.350208675382298},
                  {-3.8168176545457726, 7.1622508825139732}};
    const Vec2 past(std::nextafter(tri.points[0].x(), kInf), tri.points[0].y());
    BOOST_TEST(pointInPolygon(past, tri.points));
    BOOST_TEST(!Box::around(tri.points).contains(past));
    BOOST_TEST(World(WorldSpec{}, {tri}).obstacleAt(past) == 0);
    BOOST_TEST(inside > 8000);        // the test covers both answers
    BOOST_TEST(insideHallOnly > 3000);  // and points only the large polygon holds
    // The depth, by a scan of every obstacle and segment.
    double worst = 0;
    const AgentStore& a = sim.agents();
    for (std::size_t i = 0; i < a.size(); ++i) {
        const Vec2& p = a.pos[i];
        const int o = scanAt(p);
        double d = kInf;
        for (const Segment& seg : world.segments())
            if (o < 0 || seg.obstacle == o) d = std::min(d, std::sqrt(distanceToSegmentSquared(p, seg.a, seg.b)));
        worst = std::max(worst, o >= 0 ? a.radius[i] + d : a.radius[i] - d);
    }
    BOOST_TEST(worst > 1.0);  // someone is deep inside the hall polygon
    BOOST_TEST(sim.maxWallPenetration() == worst);
}

BOOST_AUTO_TEST_CASE(reordering_agents_keeps_every_agents_state) {
    // A dense SPH crowd listed in reverse order, so re-ordering in grid order moves almost every
    // agent. Re-ordered every step or never, each agent (found by id) must end in the same place
    // and with the same health record up to rounding: a state left behind by the permutation
    // (SPH rest density, held accelerations, health records) would move agents by centimetres.
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 100; ++k) {
        AgentSpec a = test::agent(99 - k, {0.5 * (k % 10), 0.5 * (k / 10)}, {20, 2.25}, 0.24, 1.4, 1.8);
        a.maxAcceleration = 5;
        agents.push_back(a);
    }
    std::reverse(agents.begin(), agents.end());
    auto spec = test::scenario(agents,
                               {test::policy(0, OptimisationMethod::Gradient,
                                             {test::component("GoalReachingForce", {{"range", 0.0}}),
                                              test::component("SPH", {{"range", 1.0}, {"restDensityMax", 3.0}}),
                                              test::component("ContactForces", {{"range", 1.0}})},
                                             0.5, {}, StepTiming::Fine, 0.0)},
                               0.1, 2.0);
    spec.deltaTimeFine = 0.02;
    Simulation every(spec), never(spec);
    every.setReorderInterval(1);
    never.setReorderInterval(0);
    while (!every.finished()) every.stepCoarse();
    while (!never.finished()) never.stepCoarse();
    const AgentStore& a = every.agents();
    const AgentStore& b = never.agents();
    BOOST_TEST_REQUIRE(a.size() == b.size());
    BOOST_TEST(a.id != b.id);  // the stores really are in different orders
    std::map<AgentId, std::size_t> inB;
    for (std::size_t i = 0; i < b.size(); ++i) inB[b.id[i]] = i;
    double worst = 0, worstForce = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const std::size_t j = inB.at(a.id[i]);
        worst = std::max(worst, (a.pos[i] - b.pos[j]).norm());
        worstForce = std::max(worstForce, std::abs(every.health().recordOf(a, i).peakContactAccel -
                                                   never.health().recordOf(b, j).peakContactAccel));
    }
    BOOST_TEST(worst < 1e-6);
    BOOST_TEST(worstForce < 1e-6);
    BOOST_TEST(never.agents().pos.size() == 100u);  // nobody left in 2 s: all 100 compared
}

BOOST_AUTO_TEST_CASE(agents_leave_at_their_goal_or_out_of_the_world_in_agent_order) {
    // 60 walkers in rows 1 m apart inside a planar world x in [-5, 5]: a third leave at a goal
    // 2 m ahead (removed at the goal), a third walk out through the right edge, a third stay
    // (goal far ahead but kept at the goal). The removals are listed in agent order within a step,
    // the evacuations by id, and both are the same with one and two threads (the scan is parallel).
    auto make = [] {
        std::vector<AgentSpec> agents;
        for (int k = 0; k < 60; ++k) {
            const double y = static_cast<double>(k);
            const int kind = (k * 7) % 3;  // mixed along the rows
            AgentSpec a = test::agent(static_cast<AgentId>(100 - k), {-2.0 + 0.05 * (k % 5), y},
                                      kind == 0 ? Vec2(0.0, y) : kind == 1 ? Vec2(20.0, y) : Vec2(3.0, y), 0.2, 1.3, 1.6);
            a.removeAtGoal = kind == 0;
            agents.push_back(a);
        }
        auto spec = test::scenario(agents, {test::policy(0, OptimisationMethod::Gradient, {test::component("GoalReachingForce")}, 0.5)},
                                   0.1, 12);
        spec.world.type = WorldType::Planar;
        spec.world.xmin = -5;
        spec.world.xmax = 5;
        spec.world.ymin = -1;
        spec.world.ymax = 61;
        return spec;
    };
    std::vector<std::vector<AgentId>> removedIds(2), evacuatedIds(2);
    std::vector<std::size_t> leftWorld(2);
    for (int threads = 1; threads <= 2; ++threads) {
        Simulation sim(make());
        sim.setThreads(threads);
        while (!sim.finished()) {
            // Where each agent is in the store before the step: a step's removals follow that order.
            std::map<AgentId, std::size_t> at;
            for (std::size_t i = 0; i < sim.agents().size(); ++i) at[sim.agents().id[i]] = i;
            const std::size_t before = sim.removed().size();
            sim.stepCoarse();
            for (std::size_t k = before + 1; k < sim.removed().size(); ++k)
                if (sim.removed()[k].time == sim.removed()[k - 1].time)
                    BOOST_TEST(at.at(sim.removed()[k - 1].id) < at.at(sim.removed()[k].id));
        }
        for (const auto& r : sim.removed()) removedIds[threads - 1].push_back(r.id);
        for (const Evacuation& e : sim.evacuations()) {
            evacuatedIds[threads - 1].push_back(e.id);
            BOOST_TEST(e.exit == -1);
        }
        leftWorld[threads - 1] = sim.leftWorld();
        BOOST_TEST(sim.agents().size() == 20u);  // the third that stays
        for (std::size_t i = 0; i < sim.agents().size(); ++i) BOOST_TEST(sim.world().inside(sim.agents().pos[i]));
    }
    BOOST_TEST(evacuatedIds[0].size() == 20u);
    BOOST_TEST(leftWorld[0] == 20u);
    BOOST_TEST(removedIds[0].size() == 40u);
    BOOST_TEST(removedIds[0] == removedIds[1]);
    BOOST_TEST(evacuatedIds[0] == evacuatedIds[1]);
    BOOST_TEST(leftWorld[1] == leftWorld[0]);
}

BOOST_AUTO_TEST_CASE(umans_post_clamp_contact_pushes_overlapping_agents_apart) {
    // UMANS' implicit contact (PolicySpec::contactForceScale > 0, a policy with no contact
    // component) acts after the clamps: two overlapping agents standing at their goals are pushed
    // apart along their centre line, equally and oppositely. With the scale 0 the buffer is not
    // kept and nothing pushes them.
    for (const double scale : {62.5, 0.0}) {
        auto spec = test::scenario({test::agent(1, {0, 0}, {0, 0}), test::agent(2, {0.4, 0}, {0.4, 0})},
                                   {test::policy(0, OptimisationMethod::Gradient, {test::component("GoalReachingForce")}, 0.5,
                                                 {}, StepTiming::Fine, scale)},
                                   0.1, -1);
        Simulation sim(spec);
        sim.stepCoarse();
        BOOST_TEST_REQUIRE(sim.agents().size() == 2u);
        const std::size_t a = sim.agents().id[0] == 1 ? 0 : 1;
        const Vec2 va = sim.agents().vel[a], vb = sim.agents().vel[1 - a];
        if (scale > 0) {
            BOOST_TEST(va.x() < -0.1);
            BOOST_TEST(vb.x() == -va.x());
            BOOST_TEST(va.y() == 0.0);
            BOOST_TEST(sim.agents().pos[a].x() < 0.0);
        } else {
            BOOST_TEST(va.norm() == 0.0);
            BOOST_TEST(vb.norm() == 0.0);
        }
    }
}
