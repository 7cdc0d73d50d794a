// CrowdHealth tests — the limits every step obeys and the weights that shape social forces:
// |a| <= a_max and |v| <= s_max on every fine step of a hard push (paper eq. 1–2), checked on the
// motion itself, and Helbing & Molnár's field of view (interactions from behind weighted by
// `behind`, 0.5 in UMANS) checked on the force itself.
#define BOOST_TEST_MODULE core_limits
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/core/simulation.h"

#include <cmath>

using namespace ch;
using namespace ch::test;

namespace {

/// The social force on agent 0 (at the origin, walking +x) from one neighbour standing still at
/// `where` (1 m away, bodies not touching), with the component's defaults and `overrides`.
Vec2 forceFrom(const Vec2& where, const std::map<std::string, double>& overrides = {}) {
    Frame f;
    f.add({0, 0}, {10, 0}, {1.2, 0}, 0.25);
    f.add(where, where, {0, 0}, 0.25);  // goal = position: no preferred velocity
    const StepContext ctx = f.context();
    auto sf = make("SocialForcesAvoidance", overrides);
    sf->prepare(ctx);
    const OwnedQuery q = f.query(0);
    return dynamic_cast<const ForceComponent&>(*sf).acceleration(q, ctx);
}

}  // namespace

BOOST_AUTO_TEST_CASE(social_forces_from_behind_count_half) {
    // A neighbour standing still exerts an isotropic force (its step is 0): the same magnitude
    // ahead and behind, before the field-of-view weight.
    const Vec2 ahead = forceFrom({1, 0});
    const Vec2 behind = forceFrom({-1, 0});
    BOOST_TEST(ahead.norm() > 0.1);
    BOOST_TEST(ahead.x() < 0);   // pushed back, away from the one ahead
    BOOST_TEST(behind.x() > 0);  // pushed forward
    BOOST_TEST(std::abs(behind.norm() - 0.5 * ahead.norm()) < 1e-12 * ahead.norm(),
               "behind " << behind.norm() << " ahead " << ahead.norm());
    // The field of view is 100° to either side (UMANS): 95° counts fully, 105° by half.
    const auto at = [](double deg) { return Vec2(std::cos(deg * kPi / 180), std::sin(deg * kPi / 180)); };
    BOOST_TEST(std::abs(forceFrom(at(95)).norm() - ahead.norm()) < 1e-12 * ahead.norm());
    BOOST_TEST(std::abs(forceFrom(at(105)).norm() - 0.5 * ahead.norm()) < 1e-12 * ahead.norm());
    // The weight is the parameter: behind = 0.2 gives a fifth, behind = 1 no difference.
    BOOST_TEST(std::abs(forceFrom({-1, 0}, {{"behind", 0.2}}).norm() - 0.2 * ahead.norm()) < 1e-12 * ahead.norm());
    BOOST_TEST(std::abs(forceFrom({-1, 0}, {{"behind", 1.0}}).norm() - ahead.norm()) < 1e-12 * ahead.norm());
}

BOOST_AUTO_TEST_CASE(every_fine_step_obeys_the_acceleration_and_speed_limits) {
    // Two columns of agents driven hard into each other (goal force strength 20, stiff contact,
    // strong social forces) so that the unclamped acceleration is far above a_max and the
    // preferred speed above s_max: on every fine step and for every agent, the velocity change is
    // at most a_max·Δt and the speed at most s_max. UMANS' post-clamp contact is off (it acts
    // after the limits by design).
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 8; ++k) {
        agents.push_back(agent(k, {0.0, 0.6 * k}, {40.0, 0.6 * k}, 0.25, 3.0, 1.5));
        agents.push_back(agent(100 + k, {4.0, 0.6 * k + 0.3}, {-40.0, 0.6 * k + 0.3}, 0.25, 3.0, 1.5));
    }
    for (AgentSpec& a : agents) a.maxAcceleration = 2.0;
    PolicySpec p = policy(0, OptimisationMethod::Gradient,
                          {component("GoalReachingForce", {{"range", 0.0}, {"strength", 20.0}}),
                           component("SocialForcesAvoidance", {{"V0", 50.0}}),
                           component("ContactForces", {{"range", 1.0}, {"agentStiffness", 5000.0}})},
                          0.5, {}, StepTiming::Fine, 0.0);
    // Coarse step = fine step, so every step of the loop below is one integration step.
    ScenarioSpec s = scenario(agents, {p}, 0.02, 6);
    s.deltaTimeFine = 0.02;
    Simulation sim(s);
    std::map<AgentId, Vec2> previous;
    double largestAccel = 0, largestSpeed = 0;
    int steps = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& a = sim.agents();
        for (std::size_t i = 0; i < a.size(); ++i) {
            const double speed = a.vel[i].norm();
            largestSpeed = std::max(largestSpeed, speed);
            BOOST_TEST(speed <= 1.5 * (1 + 1e-12));
            const auto it = previous.find(a.id[i]);
            if (it != previous.end()) {
                const double accel = (a.vel[i] - it->second).norm() / 0.02;
                largestAccel = std::max(largestAccel, accel);
                BOOST_TEST(accel <= 2.0 * (1 + 1e-9));
            }
            previous[a.id[i]] = a.vel[i];
        }
        ++steps;
    }
    BOOST_TEST(steps == 300);
    // The limits were reached, so the checks above had something to hold back.
    BOOST_TEST(largestSpeed > 1.45);
    BOOST_TEST(largestAccel > 1.9);
}
