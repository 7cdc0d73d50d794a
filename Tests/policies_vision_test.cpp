// The prediction- and vision-based UMANS cost functions: Paris, TtcaDca (Dutra), FOEAvoidance,
// VanToll and RandomFunction. Every scenario runs with the optimisation settings of the matching
// UMANS policy file (../shared/umans-examples/policies/*.xml).
#define BOOST_TEST_MODULE policies_vision
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "FOEAvoidance.h"
#include "Paris.h"
#include "RandomFunction.h"
#include "TtcaDca.h"
#include "VanToll.h"
#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/rng.h"
#include "crowdhealth/io/xml.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

using namespace ch;

namespace {

// ---- the UMANS policy files, by hand -------------------------------------------------------

/// policies/Paris.xml: regular sampling, 4 speeds × 36 directions up to the maximum speed; our
/// exact variant (UMANS', the default, lets bodies overlap: see paris_umans_variant_*).
PolicySpec parisPolicy() {
    SamplingSpec s;
    s.type = SamplingSpec::Type::Regular;
    s.base = SamplingSpec::Base::Zero;
    s.baseDirection = SamplingSpec::BaseDirection::Unit;
    s.angle = 360;
    s.speedSamples = 4;
    s.angleSamples = 36;
    s.radius = SamplingSpec::Radius::MaximumSpeed;
    return test::policy(0, OptimisationMethod::Sampling, {test::component("Paris", {{"range", 5}, {"variant", 0}})}, 0.0,
                        s);
}

/// policies/Dutra.xml: gradient, TtcaDca with coeff 20.
PolicySpec dutraPolicy() {
    return test::policy(0, OptimisationMethod::Gradient,
                        {test::component("TtcaDca",
                                         {{"range", 5}, {"sigmaTtca", 1}, {"sigmaDca", 0.3}, {"sigmaAngle_goal", 2},
                                          {"sigmaSpeed_goal", 2}},
                                         20.0)});
}

/// policies/FOEAvoidance.xml: gradient, FOEAvoidance (coeff 3) + GoalReachingForce.
PolicySpec foePolicy() {
    return test::policy(0, OptimisationMethod::Gradient,
                        {test::component("FOEAvoidance", {{"range", 5}}, 3.0), test::component("GoalReachingForce")});
}

/// policies/VanToll.xml: regular sampling, 2 speeds × 19 directions in a 180° cone around the
/// preferred velocity up to the preferred speed, relaxation time 0.25 s.
PolicySpec vanTollPolicy() {
    SamplingSpec s;
    s.type = SamplingSpec::Type::Regular;
    s.base = SamplingSpec::Base::Zero;
    s.baseDirection = SamplingSpec::BaseDirection::PreferredVelocity;
    s.angle = 180;
    s.speedSamples = 2;
    s.angleSamples = 19;
    s.radius = SamplingSpec::Radius::PreferredSpeed;
    return test::policy(0, OptimisationMethod::Sampling, {test::component("VanToll", {{"range", 5}})}, 0.25, s);
}

/// No UMANS file: RandomFunction is noise added to a navigation (here goal reaching).
PolicySpec randomPolicy() {
    return test::policy(0, OptimisationMethod::Gradient,
                        {test::component("GoalReachingForce"), test::component("RandomFunction", {}, 1.0)}, 0.5);
}

struct Model {
    std::string name;
    std::function<PolicySpec()> policy;
    bool avoids;  ///< promises collision avoidance
};

std::vector<Model> models() {
    return {
        {"Paris", parisPolicy, true},
        {"TtcaDca", dutraPolicy, true},
        {"FOEAvoidance", foePolicy, true},
        {"VanToll", vanTollPolicy, true},
        // RandomFunction avoids nothing: it is noise (not in the encounter tests).
        {"RandomFunction", randomPolicy, false},
    };
}

// UMANS' example agents: radius 0.3 m, preferred speed 1.3 m/s, maximum speed 1.6 m/s.
constexpr double kRad = 0.3, kPref = 1.3, kMax = 1.6;

AgentSpec walker(AgentId id, Vec2 from, Vec2 to) { return test::agent(id, from, to, kRad, kPref, kMax); }

/// A hand-made frozen state: agent 0 is the query agent; the others are its neighbours.
struct Scene {
    AgentStore agents;
    World world;
    PointGrid grid;
    test::OwnedQuery q;

    Scene() = default;
    /// World holds pointers into itself: build it in place, never copy or move it.
    Scene(const WorldSpec& ws, const std::vector<ObstacleSpec>& obstacles) : world(ws, obstacles) {}

    int add(Vec2 pos, Vec2 vel, double radius = kRad) {
        AgentSpec a = walker(static_cast<AgentId>(agents.size()), pos, pos + Vec2(10, 0));
        a.radius = radius;
        const int i = static_cast<int>(agents.add(a, 0));
        agents.vel[i] = vel;
        agents.viewDir[i] = vel.squaredNorm() > 0 ? Vec2(vel.normalized()) : Vec2(1, 0);
        return i;
    }
    /// Fills the query for agent 0 with every other agent and the walls within `range`.
    StepContext finish(Vec2 prefVel, double range = 5.0) {
        q.i = 0;
        q.position = agents.pos[0];
        q.velocity = agents.vel[0];
        q.prefVelocity = prefVel;
        agents.prefVel[0] = prefVel;
        q.radius = agents.radius[0];
        q.prefSpeed = kPref;
        q.maxSpeed = kMax;
        q.maxAcceleration = 5;
        q.agentStore.clear();
        for (std::size_t j = 1; j < agents.size(); ++j) {
            const Vec2 off = agents.pos[j] - agents.pos[0];
            if (off.norm() <= range) q.agentStore.push_back(NeighbourAgent{off, static_cast<int>(j)});
        }
        world.segmentsNear(q.position, range, q.segmentStore);
        q.bind();
        return StepContext{agents, world, grid, 0.1, 0.0, 0, 1, 0.0};
    }
};

using test::make;

}  // namespace

// ---- every model: a lone agent, a head-on and a 90° crossing encounter --------------------

BOOST_AUTO_TEST_CASE(lone_agent_reaches_its_goal) {
    // 15 m along a direction that is not a sampled one (36.87°), so direction quantisation is
    // exercised. Allowed time: D/v_pref × 1.25 + 2 s. The 25 % cover the sampled cruising speed
    // (Paris: 1.2 of 1.3 m/s, −8 %) and direction steps (Paris: ±5°, VanToll: ±10° around the goal
    // direction, ≤ 1.5 % longer paths); the 2 s cover the start from rest (a_max = 5 m/s², τ ≤ 0.5 s)
    // and the final approach into the 0.3 m goal radius.
    const Vec2 goal(12, 9);
    const double D = goal.norm() - kRad;
    const double allowed = D / kPref * 1.25 + 2.0;
    for (const Model& m : models()) {
        BOOST_TEST_CONTEXT(m.name) {
            auto spec = test::scenario({walker(1, {0, 0}, goal)}, {m.policy()}, 0.1, 40);
            const test::RunResult r = test::run(spec);
            BOOST_TEST(r.finite);
            BOOST_TEST_REQUIRE(r.arrival.count(1) == 1u, m.name << " never reached its goal");
            BOOST_TEST(r.arrival.at(1) <= allowed, m.name << " arrived after " << r.arrival.at(1) << " s");
            BOOST_TEST(r.arrival.at(1) >= D / kMax, m.name << " arrived faster than its maximum speed allows");
        }
    }
}

namespace {
void checkEncounter(const Model& m, AgentSpec a, AgentSpec b, const char* what) {
    const double D = (*a.goal - a.position).norm();
    const double allowed = D / kPref * 1.5 + 4.0;  // a detour and a slow-down are fine, a stall is not
    auto spec = test::scenario({a, b}, {m.policy()}, 0.1, 40);
    const test::RunResult r = test::run(spec);
    BOOST_TEST(r.finite);
    BOOST_TEST(r.maxOverlapRatio <= 0.10, m.name << " " << what << ": overlap " << r.maxOverlapRatio * 100
                                                 << " % of the radius");
    for (AgentId id : {a.id, b.id}) {
        // Not a REQUIRE: the other models of the loop must still run.
        BOOST_TEST(r.arrival.count(id) == 1u, m.name << " " << what << ": agent " << id << " never arrived");
        if (r.arrival.count(id))
            BOOST_TEST(r.arrival.at(id) <= allowed, m.name << " " << what << ": agent " << id << " arrived after "
                                                           << r.arrival.at(id) << " s");
    }
    if (r.arrival.size() == 2u)
        BOOST_TEST_MESSAGE(m.name << " " << what << ": arrivals " << r.arrival.at(a.id) << " / "
                                  << r.arrival.at(b.id) << " s, max overlap " << r.maxOverlapRatio * 100 << " %");
}
}  // namespace

BOOST_AUTO_TEST_CASE(head_on_encounter_without_overlap) {
    // Exactly head-on: a perfectly symmetric situation, the hardest case for gradient methods.
    for (const Model& m : models()) {
        if (!m.avoids) continue;
        BOOST_TEST_CONTEXT(m.name) {
            checkEncounter(m, walker(1, {-6, 0}, {6, 0}), walker(2, {6, 0}, {-6, 0}), "head-on");
        }
    }
}

BOOST_AUTO_TEST_CASE(crossing_at_right_angles_without_overlap) {
    // Both reach the crossing point at the same time: mirror-symmetric about the diagonal.
    for (const Model& m : models()) {
        if (!m.avoids) continue;
        BOOST_TEST_CONTEXT(m.name) {
            checkEncounter(m, walker(1, {-6, 0}, {6, 0}), walker(2, {0, -6}, {0, 6}), "crossing");
        }
    }
}

// ---- analytic gradients against central differences ---------------------------------------

namespace {
/// Compares gradient() with central differences of cost() at random velocities; returns how many
/// samples had a gradient clearly different from zero (so the check is not vacuous).
int checkGradient(const Component& c, const AgentQuery& q, const StepContext& ctx, std::uint64_t seed) {
    Rng rng(seed);
    int nonZero = 0;
    for (int k = 0; k < 40; ++k) {
        const double speed = rng.uniform(0.3, 2.0), angle = rng.uniform(-kPi, kPi);
        const Vec2 v = rotated(Vec2(speed, 0), angle);
        const double h = 1e-6;
        const Vec2 fd((c.cost(v + Vec2(h, 0), q, ctx) - c.cost(v - Vec2(h, 0), q, ctx)) / (2 * h),
                      (c.cost(v + Vec2(0, h), q, ctx) - c.cost(v - Vec2(0, h), q, ctx)) / (2 * h));
        const Vec2 g = c.gradient(v, q, ctx);
        BOOST_TEST((g - fd).norm() <= 1e-5 * std::max(1.0, fd.norm()),
                   "v = (" << v.x() << ", " << v.y() << "): analytic (" << g.x() << ", " << g.y()
                           << ") vs finite differences (" << fd.x() << ", " << fd.y() << ")");
        if (fd.norm() > 1e-3) ++nonZero;
    }
    return nonZero;
}
}  // namespace

BOOST_AUTO_TEST_CASE(ttcadca_gradient_matches_finite_differences) {
    // A wall (a 4 m box edge) and four neighbours moving in various directions, one occluding another.
    ObstacleSpec box;
    box.points = {{-1, 2}, {3, 2}, {3, 2.5}, {-1, 2.5}};
    WorldSpec ws;
    Scene scene(ws, {box});
    scene.add({0, 0}, {1.0, 0.2});
    scene.add({3, 0.4}, {-1.2, 0.0});
    scene.add({4.5, 0.6}, {-0.8, 0.3});  // partly behind the previous one
    scene.add({1.5, -2.0}, {0.0, 1.1});
    scene.add({-2.0, -1.0}, {1.3, 0.0});  // behind the agent: outside the 180° view
    const StepContext ctx = scene.finish({1.3, 0.0});
    // vision="pixels": the gradient of the rendered cost (the default, "umans", maps UMANS'
    // (heading, speed) derivatives back as UMANS does, which is not the gradient of its cost).
    auto c = make("TtcaDca", {{"vision", 0}});
    std::vector<TtcaDca::Pixel> view;
    static_cast<const TtcaDca&>(*c).perceive(scene.q, ctx, view);
    BOOST_TEST(view.size() > 50u);  // the neighbours and the wall are seen
    BOOST_TEST(checkGradient(*c, scene.q, ctx, 11) >= 30);
}

BOOST_AUTO_TEST_CASE(foe_gradient_matches_finite_differences) {
    Scene scene;
    scene.add({0, 0}, {1.0, 0.0});
    scene.add({3, 0.7}, {-1.2, 0.1});
    scene.add({2.0, 2.5}, {0.2, -1.0});
    scene.add({-2.5, 1.0}, {1.5, -0.4});
    scene.add({1.0, -3.0}, {-0.3, 1.2});
    const StepContext ctx = scene.finish({1.3, 0.0});
    auto c = make("FOEAvoidance");
    BOOST_TEST(checkGradient(*c, scene.q, ctx, 12) >= 20);
}

BOOST_AUTO_TEST_CASE(foe_cost_is_the_miss_distance_form) {
    // One neighbour straight ahead on a collision course costs I(ttc); displaced sideways by the
    // combined radius it costs a tenth of that.
    FOEAvoidance foe(ParamSet(Registry::fullTable(FOEAvoidance::Info())));
    const Vec2 v(1, 0), u(-1, 0);
    const double R = 0.6;
    const double ttc = 4.0 / 2.0;                    // depth 4 m, closing at 2 m/s
    const double I = 10.0 - 2.0 * ttc;               // UMANS' importance: 10 − (10/5)·t
    BOOST_TEST(foe.pairCost(v, Vec2(4, 0), u, R, nullptr) == I, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(foe.pairCost(v, Vec2(4, R), u, R, nullptr) == I / 10, boost::test_tools::tolerance(1e-12));
    // Receding or behind: nothing.
    BOOST_TEST(foe.pairCost(v, Vec2(4, 0), Vec2(2, 0), R, nullptr) == 0.0);
    BOOST_TEST(foe.pairCost(v, Vec2(-4, 0), u, R, nullptr) == 0.0);
    // Exact head-on: the gradient points to the agent's left, so descent swerves right.
    Vec2 g(0, 0);
    foe.pairCost(v, Vec2(4, 0), u, R, &g);
    BOOST_TEST(g.y() > 0);
}

// ---- Paris' forbidden speed intervals -------------------------------------------------------

BOOST_AUTO_TEST_CASE(paris_forbidden_speeds_match_brute_force) {
    // The interval from the truncated velocity obstacle must be exactly the set of speeds whose
    // time to collision is within the horizon.
    Rng rng(21);
    int nonEmpty = 0, unbounded = 0;
    for (int k = 0; k < 400; ++k) {
        const Vec2 d = rotated(Vec2(1, 0), rng.uniform(-kPi, kPi));
        const Vec2 rel = rotated(Vec2(rng.uniform(0.2, 6.0), 0), rng.uniform(-kPi, kPi));
        const Vec2 u = k % 5 == 0 ? Vec2(0, 0) : rotated(Vec2(rng.uniform(0, 2), 0), rng.uniform(-kPi, kPi));
        const double R = 0.6, T = rng.uniform(1.0, 10.0);
        const Paris::SpeedInterval iv = Paris::forbiddenSpeeds(d, rel, u, R, T);
        if (!iv.empty()) ++nonEmpty;
        if (!iv.empty() && std::isinf(iv.hi)) ++unbounded;
        const bool overlapping = rel.norm() <= R;
        for (double s = 0; s <= 4.0; s += 0.002) {
            bool collides;
            if (overlapping) collides = (s * d - u).dot(rel) > 0;
            else collides = timeToCollision(Vec2(0, 0), s * d, 0.0, rel, u, R) <= T;
            const double tol = 1e-6;
            if (collides)
                BOOST_TEST((iv.contains(s) || iv.contains(s - tol) || iv.contains(s + tol)),
                           "k=" << k << " s=" << s << " collides but [" << iv.lo << ", " << iv.hi << "]");
            else
                BOOST_TEST(!(iv.lo + tol < s && s < iv.hi - tol),
                           "k=" << k << " s=" << s << " is free but [" << iv.lo << ", " << iv.hi << "]");
        }
    }
    BOOST_TEST(nonEmpty > 40);
    BOOST_TEST(unbounded > 5);
}

BOOST_AUTO_TEST_CASE(paris_forbidden_speeds_for_walls_match_brute_force) {
    Rng rng(22);
    const Vec2 a(-1.0, 2.0), b(3.0, 2.5);
    int nonEmpty = 0;
    for (int k = 0; k < 200; ++k) {
        const Vec2 p(rng.uniform(-3, 5), rng.uniform(-2, 1.5));
        const Vec2 d = rotated(Vec2(1, 0), rng.uniform(-kPi, kPi));
        const double r = 0.3, T = rng.uniform(1.0, 10.0);
        const Paris::SpeedInterval iv = Paris::forbiddenSpeedsWall(d, p, r, a, b, T);
        if (!iv.empty()) ++nonEmpty;
        for (double s = 0.001; s <= 4.0; s += 0.01) {
            const bool collides = timeToCollisionSegment(p, s * d, r, a, b) <= T;
            BOOST_TEST(collides == (s >= iv.lo - 1e-9 && s <= iv.hi) , "k=" << k << " s=" << s);
        }
    }
    BOOST_TEST(nonEmpty > 20);
}

BOOST_AUTO_TEST_CASE(paris_prefers_a_free_direction_and_speed) {
    // A neighbour standing 3 m straight ahead: the straight direction is forbidden at the preferred
    // speed, so the best sampled velocity turns away, at a speed close to the preferred one.
    Scene scene;
    scene.add({0, 0}, {1.3, 0});
    scene.add({3, 0}, {0, 0});
    const StepContext ctx = scene.finish({1.3, 0});
    auto c = make("Paris", {{"variant", 0}});
    const double straight = c->cost({1.2, 0}, scene.q, ctx);
    const double turned = c->cost(rotated(Vec2(1.2, 0), 20 * kPi / 180), scene.q, ctx);
    BOOST_TEST(turned < straight);
    // Without the neighbour the straight velocity is best.
    Scene empty;
    empty.add({0, 0}, {1.3, 0});
    const StepContext ctx2 = empty.finish({1.3, 0});
    BOOST_TEST(c->cost({1.2, 0}, empty.q, ctx2) < c->cost(rotated(Vec2(1.2, 0), 20 * kPi / 180), empty.q, ctx2));
}

BOOST_AUTO_TEST_CASE(vantoll_cost_terms) {
    // Free space: cost = angle to v_pref + relative speed deviation + angle to the current velocity.
    Scene scene;
    scene.add({0, 0}, {1.0, 0});
    const StepContext ctx = scene.finish({0, 1.3});
    auto c = make("VanToll");
    const Vec2 v = rotated(Vec2(0.65, 0), kPi / 4);
    BOOST_TEST(c->cost(v, scene.q, ctx) == kPi / 4 + 0.5 + kPi / 4, boost::test_tools::tolerance(1e-12));
    // A static neighbour 3 m ahead (2.4 m of free walking): the collision term is 8 − 2.4.
    Scene blocked;
    blocked.add({0, 0}, {0, 0});
    blocked.add({0, 3}, {0, 0});
    const StepContext ctx2 = blocked.finish({0, 1.3});
    BOOST_TEST(c->cost({0, 1.3}, blocked.q, ctx2) == 8.0 - 2.4, boost::test_tools::tolerance(1e-9));
    // Overlapping: moving apart is not a collision, moving closer is.
    Scene touching;
    touching.add({0, 0}, {0, 0});
    touching.add({0.5, 0}, {0, 0});
    const StepContext ctx3 = touching.finish({1.3, 0});
    const VanToll& vt = static_cast<const VanToll&>(*c);
    BOOST_TEST(vt.timeToFirstCollision({-1, 0}, touching.q, ctx3) == kInf);
    BOOST_TEST(vt.timeToFirstCollision({1, 0}, touching.q, ctx3) == 0.0);
}

// ---- randomness --------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(random_function_is_reproducible_and_thread_independent) {
    auto spec = [](std::uint64_t seed) {
        auto s = test::scenario({walker(1, {0, 0}, {12, 0}), walker(2, {0, 3}, {12, 3}), walker(3, {0, -3}, {12, -3}),
                                 walker(4, {0, 6}, {12, 6})},
                                {randomPolicy()}, 0.1, 6);
        s.seed = seed;
        return s;
    };
    const test::RunResult one = test::run(spec(7), 1);
    const test::RunResult two = test::run(spec(7), 2);
    const test::RunResult again = test::run(spec(7), 1);
    const test::RunResult other = test::run(spec(8), 2);
    BOOST_TEST_REQUIRE(one.finalPosition.size() == 4u);
    double differs = 0;
    for (const auto& [id, p] : one.finalPosition) {
        BOOST_TEST(p.x() == two.finalPosition.at(id).x());
        BOOST_TEST(p.y() == two.finalPosition.at(id).y());
        BOOST_TEST(p.x() == again.finalPosition.at(id).x());
        BOOST_TEST(p.y() == again.finalPosition.at(id).y());
        differs = std::max(differs, (p - other.finalPosition.at(id)).norm());
    }
    BOOST_TEST(differs > 1e-3, "another seed must give another run");
    // The noise is real: agents drift off their straight lines.
    const std::map<AgentId, double> line{{1, 0.0}, {2, 3.0}, {3, -3.0}, {4, 6.0}};
    double drift = 0;
    for (const auto& [id, p] : one.finalPosition) drift = std::max(drift, std::abs(p.y() - line.at(id)));
    BOOST_TEST(drift > 1e-3);
}

BOOST_AUTO_TEST_CASE(random_cost_depends_on_candidate_not_on_call_order) {
    Scene scene;
    scene.add({0, 0}, {1, 0});
    const StepContext ctx = scene.finish({1.3, 0});
    auto c = make("RandomFunction");
    const double a1 = c->cost({1, 0}, scene.q, ctx);
    const double b = c->cost({0, 1}, scene.q, ctx);
    const double a2 = c->cost({1, 0}, scene.q, ctx);
    BOOST_TEST(a1 == a2);
    BOOST_TEST(a1 != b);
    double lo = 1, hi = -1;
    for (int k = 0; k < 2000; ++k) {
        const double x = c->cost({0.001 * k, 0.5}, scene.q, ctx);
        lo = std::min(lo, x);
        hi = std::max(hi, x);
    }
    BOOST_TEST(lo >= -1.0);
    BOOST_TEST(hi <= 1.0);
    BOOST_TEST(lo < -0.95);
    BOOST_TEST(hi > 0.95);
    const Vec2 g1 = c->gradient({1, 0}, scene.q, ctx), g2 = c->gradient({0, 1}, scene.q, ctx);
    BOOST_TEST(g1.x() == g2.x());  // one random gradient per agent and step
    BOOST_TEST(std::abs(g1.x()) <= 1.0);
}

// ---- UMANS' Toric.xml: a VanToll agent keeps walking round a 10 × 10 torus ---------------------

BOOST_AUTO_TEST_CASE(vantoll_agent_wraps_around_a_torus) {
    auto a = test::agent(1, {0, 0}, {1000, 0}, 0.3, 1.3, 2.0);
    auto spec = test::scenario({a}, {vanTollPolicy()}, 0.1, 100);
    spec.world.type = WorldType::Toric;
    spec.world.width = 10;
    spec.world.height = 10;
    Simulation sim(spec);
    double travelled = 0, minX = 1e9, maxX = -1e9;
    Vec2 last = sim.agents().pos[0];
    while (!sim.finished()) {
        sim.stepCoarse();
        const Vec2 p = sim.agents().pos[0];
        BOOST_TEST_REQUIRE((std::isfinite(p.x()) && std::isfinite(p.y())));
        travelled += sim.world().offset(last, p).norm();
        minX = std::min(minX, p.x());
        maxX = std::max(maxX, p.x());
        last = p;
    }
    // 100 s at 1.3 m/s, minus the first relaxation.
    BOOST_TEST(travelled > 125.0);
    BOOST_TEST(travelled < 131.0);
    BOOST_TEST(minX >= -5.0);
    BOOST_TEST(maxX < 5.0);
    BOOST_TEST(std::abs(sim.agents().vel[0].x() - 1.3) < 1e-6);
}

BOOST_AUTO_TEST_CASE(ttcadca_umans_vision_maps_heading_and_speed_derivatives_back) {
    // No neighbour: only the goal terms. Velocity (1, 0), preferred velocity (0, 1.3): the heading
    // error α = +90° (counter-clockwise), h = α/(2σ²)·exp(−α²/(2σ²)) with σ = 2 rad; the speed error
    // ds = −0.3 m/s, g_s = ds/(2σ_s²)·exp(−ds²/(2σ_s²)). UMANS turns the velocity by h: the gradient
    // is sin(h)·|v| along the right-hand normal plus ((1 − cos h)·|v| + g_s) along v, so −gradient
    // turns the agent towards its goal.
    Scene scene;
    scene.add({0, 0}, {1.0, 0.0});
    const StepContext ctx = scene.finish({0.0, 1.3});
    auto c = make("TtcaDca");
    const double a = kPi / 2, h = a / 8 * std::exp(-a * a / 8), gs = -0.3 / 8 * std::exp(-0.09 / 8);
    const Vec2 expected(1 - std::cos(h) + gs, -std::sin(h));
    const Vec2 g = c->gradient({1.0, 0.0}, scene.q, ctx);
    BOOST_TEST((g - expected).norm() < 1e-12, "gradient (" << g.x() << ", " << g.y() << ")");
    BOOST_TEST(-g.y() > 0);  // turns left, towards the goal
}

BOOST_AUTO_TEST_CASE(ttcadca_umans_circle_matches_umans) {
    // UMANS' Circle10-Dutra: 10 agents on a circle of 5 m cross it. UMANS: mean arrival 8.3 s.
    // vision="umans" (default): 8.3 s; the rendered pixels ("pixels") avoid much earlier and wider:
    // 12.5 s (+51 %), and in Circle15/25/50 some agents then orbit their goal for ever.
    Diagnostics diags;
    std::optional<ScenarioSpec> spec =
        loadScenario((std::filesystem::path(CH_SHARED_DIR) / "umans-examples" / "Circle10-Dutra.xml").string(), diags);
    BOOST_TEST_REQUIRE(spec.has_value());
    const test::RunResult r = test::run(*spec);
    BOOST_TEST_REQUIRE(r.arrival.size() == 10u);
    double mean = 0;
    for (const auto& [id, t] : r.arrival) mean += t / 10.0;
    BOOST_TEST(std::abs(mean - 8.3) <= 0.35 * 8.3, "mean arrival " << mean << " s");
}

BOOST_AUTO_TEST_CASE(paris_umans_variant_conflict_at_the_crossing_point) {
    // UMANS' Paris (variant="umans", default): a neighbour 3 m ahead and 3 m to the left walks at
    // 1 m/s towards −y, crossing the agent's path at X = (3, 0); with R = 0.6 m it covers X from
    // t1 = 2.4 s to t2 = t1 + R/1 m/s = 3.0 s. Walking along x the agent passes X before it at
    // s1 = 3/2.4 = 1.25 m/s or faster, after it at s2 = 3/3 = 1 m/s or slower. UMANS' speed cost is
    // max(0, (s1 − s)/v_p, (s − s2)/v_p) (so no speed is free of it while the conflict lasts), its
    // direction cost w_a·C_speed·C_pred with C_speed = min(1 − s1/v_p, (s2 − v_p)/v_p) clipped at 0
    // (0 here), plus 0.001·|v − v_pref|.
    Scene scene;
    scene.add({0, 0}, {1.3, 0});
    scene.add({3, 3}, {0, -1.0});
    const StepContext ctx = scene.finish({1.3, 0});
    auto c = make("Paris");
    const double s1 = 1.25, s2 = 1.0, ps = 1.3;
    for (double s : {1.3, 1.1, 0.8}) {
        const double expected = std::max({0.0, (s1 - s) / ps, (s - s2) / ps}) + 0.001 * std::abs(s - ps);
        BOOST_TEST(c->cost({s, 0}, scene.q, ctx) == expected, boost::test_tools::tolerance(1e-9));
    }
    // Its conflict counts only while the agent, at its current velocity, would reach X within the
    // horizon: walking away from it (current velocity −x), the same candidates cost no conflict.
    Scene away;
    away.add({0, 0}, {-1.3, 0});
    away.add({3, 3}, {0, -1.0});
    const StepContext ctx2 = away.finish({1.3, 0});
    BOOST_TEST(c->cost({1.1, 0}, away.q, ctx2) == 0.001 * 0.2, boost::test_tools::tolerance(1e-9));
}

BOOST_AUTO_TEST_CASE(paris_umans_variant_circle_matches_umans) {
    // UMANS' Circle25-Paris: mean arrival 39.7 s in UMANS (one run, single precision); the exact
    // variant gives about 13.5 s (−66 %). The ring is symmetric and breaks at a random moment (the
    // symmetry jitter), so one seed's mean arrival ranges from 37 to 66 s: the median over eight
    // seeds is compared (43.8 s; 49.6 s with the jitter drawn as before 2026-12-02), over four
    // under the sanitizers (CROWDHEALTH_SHORT: 47.2 s).
    Diagnostics diags;
    std::optional<ScenarioSpec> spec =
        loadScenario((std::filesystem::path(CH_SHARED_DIR) / "umans-examples" / "Circle25-Paris.xml").string(), diags);
    BOOST_TEST_REQUIRE(spec.has_value());
    const std::uint64_t seeds = std::getenv("CROWDHEALTH_SHORT") ? 4 : 8;
    std::vector<double> means;
    for (std::uint64_t seed = 0; seed < seeds; ++seed) {
        ScenarioSpec s = *spec;
        s.seed = seed;
        const test::RunResult r = test::run(s);
        BOOST_TEST_REQUIRE(r.arrival.size() == 25u, "seed " << seed);
        double mean = 0;
        for (const auto& [id, t] : r.arrival) mean += t / 25.0;
        means.push_back(mean);
    }
    std::sort(means.begin(), means.end());
    const std::size_t h = means.size() / 2;
    const double median = 0.5 * (means[h - 1] + means[h]);
    BOOST_TEST(std::abs(median - 39.7) <= 0.35 * 39.7,
               "median over " << seeds << " seeds of the mean arrival " << median << " s");
}
