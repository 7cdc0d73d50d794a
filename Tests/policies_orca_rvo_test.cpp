#define BOOST_TEST_MODULE policies_orca_rvo
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "ORCA.h"
#include "RVO.h"

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/rng.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

// Tests of the velocity-obstacle family: ORCA (van den Berg et al. 2011) and RVO (van den Berg et
// al. 2008).
//
// Scenario tests use the optimisation method of UMANS' policy files: policies/ORCA.xml
// (OptimizationMethod="global", range 5) and policies/RVO.xml (random sampling: 250 samples around
// the current velocity, radius max_acceleration·Δt, full circle, range 5), with UMANS' example
// agents (radius 0.3 m, preferred speed 1.3 m/s, maximum speed 1.6 m/s) and delta_time 0.1 s. Both
// models promise collision avoidance, so both get the head-on and crossing checks; ORCA, whose
// guarantee is exact, is also held to (near) zero overlap in circle scenarios and must respect
// walls. Only RVO draws random numbers (through the sampling stream); the thread-count test is run
// for both.

using namespace ch;
using namespace ch::test;

namespace {

SamplingSpec umansRvoSampling() {
    SamplingSpec s;
    s.type = SamplingSpec::Type::Random;
    s.base = SamplingSpec::Base::CurrentVelocity;
    s.baseDirection = SamplingSpec::BaseDirection::Unit;
    s.angle = 360;
    s.randomSamples = 250;
    s.radius = SamplingSpec::Radius::MaximumAcceleration;
    return s;
}

/// The policy of UMANS' policies/<model>.xml.
PolicySpec umansPolicy(const std::string& model, int id = 0, double contactForceScale = 62.5) {
    if (model == "ORCA")
        return policy(id, OptimisationMethod::Global, {component("ORCA", {{"range", 5}})}, 0.0, {},
                      StepTiming::Coarse, contactForceScale);
    if (model == "RVO")
        return policy(id, OptimisationMethod::Sampling, {component("RVO", {{"range", 5}})}, 0.0, umansRvoSampling(),
                      StepTiming::Coarse, contactForceScale);
    throw std::runtime_error("no policy for " + model);
}

/// Upper bound (s) on a lone straight walk of `dist` m at 1.3 m/s.
/// ORCA: the LP returns v_pref at once; a_max = 5 m/s² reaches 1.3 m/s in 0.3 s (costing 0.13 s of
/// travel). RVO: samples lie within a_max·Δt = 0.5 m/s of the current velocity, so 3 steps to reach
/// v_pref; 250 random samples in a disc of radius 0.5 m/s leave the best one typically ~0.02 m/s
/// off v_pref (≈ 2 % slower, plus some sideways wobble). 10 % + 1 s covers both with room; a model
/// that walked 20 % slow or detoured would fail.
double travelTimeBound(double dist) { return 1.1 * dist / 1.3 + 1.0; }


ObstacleSpec box(double xmin, double ymin, double xmax, double ymax) {
    ObstacleSpec o;
    o.points = {Vec2(xmin, ymin), Vec2(xmax, ymin), Vec2(xmax, ymax), Vec2(xmin, ymax)};
    return o;
}

orca::HalfPlane randomPlane(Rng& rng, double offsetLo, double offsetHi) {
    const double a = rng.uniform(-kPi, kPi);
    return orca::HalfPlane{Vec2(std::cos(a), std::sin(a)), rng.uniform(offsetLo, offsetHi)};
}

double maxViolation(const std::vector<orca::HalfPlane>& planes, std::size_t from, const Vec2& v) {
    double worst = -kInf;
    for (std::size_t k = from; k < planes.size(); ++k) worst = std::max(worst, planes[k].violation(v));
    return worst;
}

/// Points of the disc |v| ≤ radius on a square lattice of spacing h.
std::vector<Vec2> discLattice(double radius, double h) {
    std::vector<Vec2> out;
    const int n = static_cast<int>(std::ceil(radius / h));
    for (int i = -n; i <= n; ++i)
        for (int j = -n; j <= n; ++j) {
            const Vec2 v(i * h, j * h);
            if (v.norm() <= radius) out.push_back(v);
        }
    return out;
}

// ---- scenario helpers ------------------------------------------------------------------------

RunResult runPair(const std::string& model, Vec2 p0, Vec2 g0, Vec2 p1, Vec2 g1, double endTime = 40.0) {
    return run(scenario({agent(0, p0, g0), agent(1, p1, g1)}, {umansPolicy(model)}, 0.1, endTime));
}

void checkAvoidance(const std::string& model, const RunResult& r, double dist) {
    BOOST_TEST(r.finite);
    BOOST_TEST(r.maxOverlapRatio <= 0.10, model << ": overlap " << r.maxOverlapRatio << " of a radius");
    // Standing still would avoid overlaps trivially: both must also arrive. The encounter may cost
    // a detour or a wait, so allow twice the lone-walk bound.
    const double bound = 2.0 * travelTimeBound(dist);
    for (AgentId id : {0, 1}) {
        BOOST_TEST_REQUIRE(r.arrival.count(id) == 1u, model << ": agent " << id << " never reached its goal");
        BOOST_TEST(r.arrival.at(id) <= bound,
                   model << ": agent " << id << " arrived at " << r.arrival.at(id) << " s, bound " << bound << " s");
    }
}

/// n agents evenly on a circle of radius R, each walking to the opposite point (UMANS' CircleN).
/// With `jitter` > 0 every start is moved by up to ±jitter m in x and y (goals stay antipodal to
/// the unjittered start), from a fixed random stream.
ScenarioSpec circle(const std::string& model, int n, double R, double endTime, double jitter = 0.0,
                    std::uint64_t jitterSeed = 1) {
    std::vector<AgentSpec> agents;
    Rng rng(jitterSeed);
    for (int k = 0; k < n; ++k) {
        const double a = 2 * kPi * k / n;
        const Vec2 p(R * std::cos(a), R * std::sin(a));
        const Vec2 shift = jitter > 0 ? Vec2(rng.uniform(-jitter, jitter), rng.uniform(-jitter, jitter)) : Vec2(0, 0);
        agents.push_back(agent(k, p + shift, -p));
    }
    return scenario(agents, {umansPolicy(model)}, 0.1, endTime);
}

double lastArrival(const RunResult& r) {
    double last = 0;
    for (const auto& [id, t] : r.arrival) last = std::max(last, t);
    return last;
}

}  // namespace

// ---- registration ------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(registered_with_umans_names_and_parameters) {
    const ComponentInfo* orcaInfo = Registry::instance().find("ORCA");
    BOOST_TEST_REQUIRE(orcaInfo != nullptr);
    BOOST_TEST(orcaInfo->reference.find("van den Berg") != std::string::npos);
    auto orcaC = make("ORCA");
    BOOST_TEST(orcaC->parameter("timeHorizon") == 5.0);      // UMANS' default
    BOOST_TEST(orcaC->parameter("timeHorizonObst") == 5.0);  // our addition, RVO2's usual value
    BOOST_TEST(orcaC->parameter("range") == 5.0);

    const ComponentInfo* rvoInfo = Registry::instance().find("RVO");
    BOOST_TEST_REQUIRE(rvoInfo != nullptr);
    auto rvoC = make("RVO", {{"w", 2.5}});
    BOOST_TEST(rvoC->parameter("w") == 2.5);
    BOOST_TEST(make("RVO")->parameter("w") == 1.0);  // UMANS' default
    BOOST_TEST(rvoC->setParameter("w", 3.0));
    BOOST_TEST(rvoC->parameter("w") == 3.0);
}

// ---- the linear programs -----------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(lp_simple_cases) {
    Vec2 v;
    // No constraint: v_pref itself, or clamped to the speed disc.
    BOOST_TEST(orca::solve2D({}, 2.0, Vec2(1, 1), false, v) == 0u);
    BOOST_TEST((v - Vec2(1, 1)).norm() < 1e-12);
    orca::solve2D({}, 1.0, Vec2(3, 4), false, v);
    BOOST_TEST((v - Vec2(0.6, 0.8)).norm() < 1e-12);
    // One plane x ≤ 0.5: projection of (1, 0.3) onto it.
    std::vector<orca::HalfPlane> p = {{Vec2(1, 0), 0.5}};
    BOOST_TEST(orca::solve2D(p, 2.0, Vec2(1, 0.3), false, v) == 1u);
    BOOST_TEST((v - Vec2(0.5, 0.3)).norm() < 1e-12);
    // Two planes x ≤ 0.5 and y ≤ −0.2: the corner.
    p.push_back({Vec2(0, 1), -0.2});
    orca::solve2D(p, 2.0, Vec2(1, 0.3), false, v);
    BOOST_TEST((v - Vec2(0.5, -0.2)).norm() < 1e-12);
    // x ≤ −3 is outside the disc of radius 2: infeasible at plane 0.
    BOOST_TEST(orca::solve2D({{Vec2(1, 0), -3.0}}, 2.0, Vec2(1, 0), false, v) == 0u);
    // Contradictory x ≥ 0.5 and x ≤ −0.5 (both soft): the 3D program lands on x = 0, violating both by 0.5.
    const std::vector<orca::HalfPlane> clash = {{Vec2(-1, 0), -0.5}, {Vec2(1, 0), -0.5}};
    const orca::Solution s = orca::solve(clash, 0, 2.0, Vec2(1, 0));
    BOOST_TEST(!s.feasible);
    BOOST_TEST(std::abs(s.velocity.x()) < 1e-9);
    BOOST_TEST(std::abs(maxViolation(clash, 0, s.velocity) - 0.5) < 1e-9);
    // The same with the first plane hard (a wall): it must hold exactly, the second takes it all.
    const orca::Solution h = orca::solve(clash, 1, 2.0, Vec2(1, 0));
    BOOST_TEST(!h.feasible);
    BOOST_TEST(clash[0].violation(h.velocity) <= 1e-9);
    BOOST_TEST(std::abs(clash[1].violation(h.velocity) - 1.0) < 1e-9);
}

// The incremental 2D program finds the true optimum and the 3D fallback the true least-violating
// velocity: compared with exhaustive search on a fine lattice of the speed disc, for random sets.
BOOST_AUTO_TEST_CASE(lp_matches_brute_force) {
    const double R = 1.6, h = 0.004;
    const std::vector<Vec2> lattice = discLattice(R, h);
    Rng rng(12345);
    int feasibleCases = 0, infeasibleCases = 0, hardCases = 0;
    for (int trial = 0; trial < 150; ++trial) {
        const int n = 1 + trial % 9;
        std::vector<orca::HalfPlane> planes;
        for (int k = 0; k < n; ++k) planes.push_back(randomPlane(rng, -0.9, 1.0));
        // A third of the cases keep the first plane (or two) hard, like walls; they always
        // contain 0 here, as wall half-planes do.
        std::size_t numHard = 0;
        if (trial % 3 == 0 && n >= 3) {
            numHard = 1 + (trial % 2);
            for (std::size_t k = 0; k < numHard; ++k) planes[k].offset = std::abs(planes[k].offset);
        }
        const Vec2 target(rng.uniform(-2, 2), rng.uniform(-2, 2));
        const orca::Solution s = orca::solve(planes, numHard, R, target);
        BOOST_TEST_REQUIRE(std::isfinite(s.velocity.x()));
        BOOST_TEST(s.velocity.norm() <= R + 1e-9);
        for (std::size_t k = 0; k < numHard; ++k) BOOST_TEST(planes[k].violation(s.velocity) <= 1e-9);

        // Exhaustive search: best feasible distance to the target, and least max soft violation.
        double bestDist = kInf, bestWorst = kInf;
        for (const Vec2& v : lattice) {
            bool hardOk = true;
            for (std::size_t k = 0; k < numHard; ++k) hardOk = hardOk && planes[k].violation(v) <= 0;
            if (!hardOk) continue;
            const double worst = maxViolation(planes, numHard, v);
            bestWorst = std::min(bestWorst, worst);
            if (worst <= 0) bestDist = std::min(bestDist, (v - target).norm());
        }
        if (s.feasible) {
            ++feasibleCases;
            BOOST_TEST(maxViolation(planes, 0, s.velocity) <= 1e-9);
            // The lattice's best is within half a diagonal of the true optimum.
            // No lattice point inside every plane is closer to the target.
            BOOST_TEST((s.velocity - target).norm() <= bestDist + 1e-9, "trial " << trial);
        } else {
            ++infeasibleCases;
            if (numHard > 0) ++hardCases;
            // Really infeasible: no lattice point lies inside every plane by a margin.
            BOOST_TEST(bestWorst > -h, "trial " << trial << ": declared infeasible but " << bestWorst);
            const double worst = maxViolation(planes, numHard, s.velocity);
            // No lattice point that respects the hard planes violates the soft ones less.
            BOOST_TEST(worst <= bestWorst + 1e-9, "trial " << trial << ": " << worst << " vs " << bestWorst);
        }
    }
    // The random sets must exercise both programs, with and without hard planes.
    BOOST_TEST(feasibleCases >= 30);
    BOOST_TEST(infeasibleCases >= 20);
    BOOST_TEST(hardCases >= 3);
}

// ---- the half-planes ---------------------------------------------------------------------------

// The paper's guarantee (its Theorem on reciprocal avoidance): if A picks any velocity of
// ORCA_{A|B} and B any of ORCA_{B|A}, they do not collide within τ. Checked for random pairs and
// random picks; also that the half-planes are each other's mirror (u is shared equally).
BOOST_AUTO_TEST_CASE(agent_half_planes_are_collision_free_for_tau) {
    Rng rng(7);
    const double tau = 5.0, dt = 0.1;
    int picks = 0;
    for (int trial = 0; trial < 400; ++trial) {
        const double ra = rng.uniform(0.2, 0.4), rb = rng.uniform(0.2, 0.4);
        const double dist = rng.uniform(ra + rb + 0.01, 8.0), ang = rng.uniform(-kPi, kPi);
        const Vec2 p(dist * std::cos(ang), dist * std::sin(ang));  // x_B − x_A
        const Vec2 va(rng.uniform(-1.6, 1.6), rng.uniform(-1.6, 1.6)), vb(rng.uniform(-1.6, 1.6), rng.uniform(-1.6, 1.6));
        const orca::HalfPlane ha = orca::agentHalfPlane(p, va - vb, ra + rb, tau, dt, va);
        const orca::HalfPlane hb = orca::agentHalfPlane(-p, vb - va, ra + rb, tau, dt, vb);
        BOOST_TEST((ha.normal + hb.normal).norm() < 1e-9);  // opposite normals
        for (int k = 0; k < 20; ++k) {
            Vec2 a(rng.uniform(-3, 3), rng.uniform(-3, 3)), b(rng.uniform(-3, 3), rng.uniform(-3, 3));
            if (ha.violation(a) > 0 || hb.violation(b) > 0) continue;
            ++picks;
            const double t = timeToCollision(Vec2(0, 0), a, ra, p, b, rb);
            BOOST_TEST(t >= tau * (1 - 1e-9), "trial " << trial << ": collision after " << t << " s");
        }
    }
    BOOST_TEST(picks > 1000);
}

// Walls: any velocity of the obstacle half-plane stays clear of the segment for timeHorizonObst,
// 0 is always allowed, and the current velocity is kept when it is already safe.
BOOST_AUTO_TEST_CASE(obstacle_half_planes_are_collision_free_and_contain_zero) {
    Rng rng(99);
    const double tau = 5.0, r = 0.3;
    int picks = 0, kept = 0, safeCurrent = 0;
    for (int trial = 0; trial < 600; ++trial) {
        Vec2 a(rng.uniform(-4, 4), rng.uniform(-4, 4));
        Vec2 b = trial % 10 == 0 ? a : Vec2(a + Vec2(rng.uniform(-4, 4), rng.uniform(-4, 4)));  // some points
        if (distanceToSegmentSquared(Vec2(0, 0), a, b) <= r * r * 1.0001) continue;
        const Vec2 v(rng.uniform(-1.6, 1.6), rng.uniform(-1.6, 1.6));
        const auto h = orca::obstacleHalfPlane(a, b, r, tau, v);
        BOOST_TEST_REQUIRE(h.has_value());
        BOOST_TEST(h->violation(Vec2(0, 0)) <= 1e-9, "trial " << trial);
        if (timeToCollisionSegment(Vec2(0, 0), v, r, a, b) > tau) {
            ++safeCurrent;
            if (h->violation(v) <= 1e-9) ++kept;
        }
        for (int k = 0; k < 20; ++k) {
            const Vec2 w(rng.uniform(-3, 3), rng.uniform(-3, 3));
            if (h->violation(w) > 0) continue;
            ++picks;
            const double t = timeToCollisionSegment(Vec2(0, 0), w, r, a, b);
            BOOST_TEST(t >= tau * (1 - 1e-6), "trial " << trial << ": wall hit after " << t << " s");
        }
    }
    BOOST_TEST(picks > 2000);
    BOOST_TEST(safeCurrent > 50);
    BOOST_TEST(kept == safeCurrent);  // a safe velocity lies outside the VO, hence in its half-plane
    // Touching a wall: only velocities that do not push further in.
    const auto touch = orca::obstacleHalfPlane(Vec2(-1, 0.2), Vec2(1, 0.2), r, tau, Vec2(0, 0));
    BOOST_TEST_REQUIRE(touch.has_value());
    BOOST_TEST(touch->violation(Vec2(1, 0)) <= 0);
    BOOST_TEST(touch->violation(Vec2(0, 0.01)) > 0);
}

// Walking parallel to a long wall and past the end of a box is not slowed down: the velocity
// obstacle of a segment is exact, not a half-plane through the nearest point.
BOOST_AUTO_TEST_CASE(orca_walks_along_a_wall_at_full_speed) {
    Frame f({box(-5, 0.5, 1.0, 1.5)});  // the box's lower face is 0.5 m left of the walking line
    const int i = f.add(Vec2(-3, 0), Vec2(20, 0), Vec2(1.3, 0));
    const StepContext ctx = f.context();
    const test::OwnedQuery q = f.query(i);
    auto orcaC = make("ORCA");
    const std::optional<Vec2> v = orcaC->globalMinimum(q, ctx);
    BOOST_TEST_REQUIRE(v.has_value());
    BOOST_TEST((*v - Vec2(1.3, 0)).norm() < 1e-9);
    BOOST_TEST(orcaC->cost(Vec2(1.3, 0), q, ctx) < 1e-12);
    // Straight at the wall at full speed is forbidden (0.5 − 0.3 m in 5 s allows 0.04 m/s).
    BOOST_TEST(orcaC->cost(Vec2(0, 1.3), q, ctx) > 2 * 1.6);
}

// ---- cost and gradient -------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(orca_cost_prefers_feasible_velocities) {
    Frame f;
    const int i = f.add(Vec2(0, 0), Vec2(10, 0), Vec2(1.3, 0));
    f.add(Vec2(3, 0.1), Vec2(-10, 0.1), Vec2(-1.3, 0));
    const StepContext ctx = f.context();
    const test::OwnedQuery q = f.query(i);
    auto orcaC = make("ORCA");
    std::vector<orca::HalfPlane> planes;
    static_cast<ORCA&>(*orcaC).halfPlanes(q, ctx, planes);
    BOOST_TEST_REQUIRE(planes.size() == 1u);
    BOOST_TEST(planes[0].violation(q.prefVelocity) > 0);  // walking on collides within 5 s
    const Vec2 best = *orcaC->globalMinimum(q, ctx);
    BOOST_TEST(planes[0].violation(best) <= 1e-9);
    // The closed-form minimum is no worse than any sampled velocity.
    const double bestCost = orcaC->cost(best, q, ctx);
    Rng rng(3);
    for (int k = 0; k < 2000; ++k) {
        const Vec2 v(rng.uniform(-1.6, 1.6), rng.uniform(-1.6, 1.6));
        BOOST_TEST(orcaC->cost(v, q, ctx) >= bestCost - 1e-9);
    }
    BOOST_TEST(orcaC->cost(q.prefVelocity, q, ctx) > 2 * 1.6);  // infeasible ⇒ above every feasible cost
}

// The analytic gradient of ORCA's cost equals central differences of cost() wherever the cost is
// smooth (it has kinks where the active piece changes; points next to a kink are skipped, detected
// by disagreeing one-sided differences).
BOOST_AUTO_TEST_CASE(orca_gradient_matches_cost_differences) {
    Frame f({box(2.0, -2.5, 2.5, -1.2)});
    const int i = f.add(Vec2(0, 0), Vec2(10, 0), Vec2(1.0, 0.2));
    f.add(Vec2(3.0, 0.5), Vec2(-10, 0.5), Vec2(-1.2, 0));
    f.add(Vec2(1.5, 3.0), Vec2(1.5, -10), Vec2(0, -1.0));
    const StepContext ctx = f.context();
    const test::OwnedQuery q = f.query(i);
    auto orcaC = make("ORCA");
    std::vector<orca::HalfPlane> planes;
    const std::size_t walls = static_cast<ORCA&>(*orcaC).halfPlanes(q, ctx, planes);
    BOOST_TEST_REQUIRE(walls >= 3u);  // the box's faces within range
    BOOST_TEST_REQUIRE(orca::solve(planes, walls, q.maxSpeed, q.prefVelocity).feasible);  // both pieces exist
    Rng rng(2024);
    const double d = 1e-6;
    int checked = 0, inside = 0, outside = 0;
    // Half the points anywhere (mostly infeasible), half near the feasible optimum.
    const Vec2 best = *orcaC->globalMinimum(q, ctx);
    for (int k = 0; k < 300; ++k) {
        const Vec2 v = k % 2 == 0 ? Vec2(rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0))
                                  : Vec2(best + Vec2(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)));
        const Vec2 g = orcaC->gradient(v, q, ctx);
        const double c0 = orcaC->cost(v, q, ctx);
        bool smooth = true;
        Vec2 fd;
        for (int axis = 0; axis < 2; ++axis) {
            Vec2 e(0, 0);
            e[axis] = d;
            const double cp = orcaC->cost(v + e, q, ctx), cm = orcaC->cost(v - e, q, ctx);
            if (std::abs((cp - c0) - (c0 - cm)) > 1e-4 * d) smooth = false;
            fd[axis] = (cp - cm) / (2 * d);
        }
        if (!smooth) continue;
        ++checked;
        (c0 > 2 * q.maxSpeed ? outside : inside)++;
        BOOST_TEST((g - fd).norm() < 1e-5, "v = (" << v.x() << ", " << v.y() << "): analytic (" << g.x() << ", "
                                                   << g.y() << ") vs (" << fd.x() << ", " << fd.y() << ")");
    }
    BOOST_TEST(checked >= 250);
    BOOST_TEST(inside >= 20);
    BOOST_TEST(outside >= 20);
}

BOOST_AUTO_TEST_CASE(rvo_penalty_is_the_papers) {
    Frame f({box(-1, 3.0, 1, 3.5)});
    const int i = f.add(Vec2(0, 0), Vec2(10, 0), Vec2(1.3, 0));
    f.add(Vec2(4, 0), Vec2(-10, 0), Vec2(-1.3, 0));
    const StepContext ctx = f.context();
    const test::OwnedQuery q = f.query(i);
    auto rvo = make("RVO", {{"w", 2.0}});
    const auto& model = static_cast<const RVO&>(*rvo);
    // Head-on at v' = v_A = (1.3, 0): reciprocal velocity 2v' − v_A = v', closing speed 2.6 m/s over
    // 4 − 0.6 m.
    const double tc = model.timeToFirstCollision(Vec2(1.3, 0), q, ctx);
    BOOST_TEST(std::abs(tc - 3.4 / 2.6) < 1e-12);
    BOOST_TEST(std::abs(rvo->cost(Vec2(1.3, 0), q, ctx) - 2.0 / tc) < 1e-12);  // v' = v_pref
    // v' = (0.65, 0): reciprocal velocity (0, 0), closing speed 1.3 m/s.
    BOOST_TEST(std::abs(model.timeToFirstCollision(Vec2(0.65, 0), q, ctx) - 3.4 / 1.3) < 1e-12);
    // Sideways, clear of the agent: only |v_pref − v'| … unless heading for the wall (VO, not RVO):
    // at (0, 1.5) the wall 3 m up is reached after (3 − 0.3)/1.5 s.
    BOOST_TEST(std::abs(model.timeToFirstCollision(Vec2(0, 1.5), q, ctx) - 2.7 / 1.5) < 1e-12);
    BOOST_TEST(std::abs(rvo->cost(Vec2(0, -1.5), q, ctx) - (Vec2(1.3, 0) - Vec2(0, -1.5)).norm()) < 1e-12);
    // Faster than max_speed: never preferred.
    BOOST_TEST(rvo->cost(Vec2(1.7, 0), q, ctx) >= RVO::kOverSpeedCost);
    // Out of range: nothing counts.
    auto blind = make("RVO", {{"range", 2.0}});
    BOOST_TEST(std::abs(blind->cost(Vec2(1.3, 0), q, ctx)) < 1e-12);
}

// ---- scenarios ---------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(lone_agent_reaches_goal) {
    for (const std::string model : {"ORCA", "RVO"}) {
        const double dist = 15.0;
        const RunResult r =
            run(scenario({agent(0, Vec2(0, 0), Vec2(dist, 0))}, {umansPolicy(model)}, 0.1, 40.0));
        BOOST_TEST(r.finite);
        BOOST_TEST_REQUIRE(r.arrival.count(0) == 1u, model << " never arrived");
        BOOST_TEST(r.arrival.at(0) <= travelTimeBound(dist),
                   model << ": arrived at " << r.arrival.at(0) << " s, bound " << travelTimeBound(dist) << " s");
        BOOST_TEST(r.arrival.at(0) >= dist / 1.6, model << " faster than max_speed");
    }
}

BOOST_AUTO_TEST_CASE(head_on_no_overlap) {
    for (const std::string model : {"ORCA", "RVO"}) {
        checkAvoidance(model, runPair(model, Vec2(-7.5, 0), Vec2(7.5, 0), Vec2(7.5, 0), Vec2(-7.5, 0)), 15.0);
        // Slightly off the axis too, so the symmetric tie-break is not all that is tested.
        checkAvoidance(model, runPair(model, Vec2(-7.5, 0), Vec2(7.5, 0), Vec2(7.5, 0.1), Vec2(-7.5, 0.1)), 15.0);
    }
}

BOOST_AUTO_TEST_CASE(crossing_90_degrees_no_overlap) {
    for (const std::string model : {"ORCA", "RVO"})
        checkAvoidance(model, runPair(model, Vec2(-7.5, 0), Vec2(7.5, 0), Vec2(0, -7.5), Vec2(0, 7.5)), 15.0);
}

// The overlap measure must catch a collision: a model that only walks to its goal (range 0: no
// neighbour counted) runs into the other agent head-on.
BOOST_AUTO_TEST_CASE(overlap_check_can_fail_without_avoidance) {
    const RunResult r = run(scenario({agent(0, Vec2(-5, 0), Vec2(5, 0)), agent(1, Vec2(5, 0), Vec2(-5, 0))},
                                     {policy(0, OptimisationMethod::Global, {component("ORCA", {{"range", 0}})})},
                                     0.1, 20.0));
    BOOST_TEST(r.maxOverlapRatio > 0.5);
}

// ORCA in UMANS' circle layouts (CircleN: n agents evenly on a circle, radius 5 m for n = 10,
// 7.5 m otherwise). The start is symmetric, and ORCA deadlocks there (see ORCA.h): adjacent
// agents converge from the start, each pair's relative velocity stays on the truncation disc
// (collision exactly τ ahead), so the ring shrinks exponentially onto the touching radius and
// stops. The promise that remains is no overlap at all — checked here; the arrivals are reported.
BOOST_AUTO_TEST_CASE(orca_symmetric_circle_no_overlap) {
    for (int n : {10, 25, 50}) {
        const RunResult r = run(circle("ORCA", n, n == 10 ? 5.0 : 7.5, 60.0));
        BOOST_TEST(r.finite);
        BOOST_TEST(r.maxOverlapRatio <= 0.02, "Circle" << n << ": overlap " << r.maxOverlapRatio << " of a radius");
        BOOST_TEST_MESSAGE("ORCA symmetric Circle" << n << ": max overlap " << r.maxOverlapRatio << ", "
                                                   << r.arrival.size() << "/" << n << " arrived in 60 s");
    }
}

// The same circles with the symmetry broken (starts moved by up to ±0.2 m): everyone crosses.
// Circle10 stays (near) overlap-free. Circle25 packs 25 agents into the centre at once, where the
// ORCA half-planes have no common point and the 3D program's least-violating velocity lets some
// pairs overlap (0.2–0.36 of a radius over jitter seeds 1–6, also without the acceleration limit
// or contact forces) — the paper's "dense situations" caveat; the bound there only rules out
// agents walking through each other.
BOOST_AUTO_TEST_CASE(orca_jittered_circle_crosses) {
    for (std::uint64_t seed : {1, 2, 3}) {
        const RunResult r10 = run(circle("ORCA", 10, 5.0, 60.0, 0.2, seed));
        BOOST_TEST(r10.finite);
        BOOST_TEST(r10.maxOverlapRatio <= 0.10, "Circle10 seed " << seed << ": overlap " << r10.maxOverlapRatio);
        BOOST_TEST(r10.arrival.size() == 10u, "Circle10 seed " << seed << ": " << r10.arrival.size() << " arrived");
        BOOST_TEST(lastArrival(r10) <= 2 * travelTimeBound(10.0), "Circle10 seed " << seed << ": last arrival " << lastArrival(r10));
        BOOST_TEST_MESSAGE("ORCA jittered Circle10 seed " << seed << ": max overlap " << r10.maxOverlapRatio
                                                          << ", last arrival " << lastArrival(r10) << " s");

        const RunResult r25 = run(circle("ORCA", 25, 7.5, 80.0, 0.2, seed));
        BOOST_TEST(r25.finite);
        BOOST_TEST(r25.maxOverlapRatio <= 0.5, "Circle25 seed " << seed << ": overlap " << r25.maxOverlapRatio);
        BOOST_TEST(r25.arrival.size() == 25u, "Circle25 seed " << seed << ": " << r25.arrival.size() << " arrived");
        BOOST_TEST(lastArrival(r25) <= 3 * travelTimeBound(15.0), "Circle25 seed " << seed << ": last arrival " << lastArrival(r25));
        BOOST_TEST_MESSAGE("ORCA jittered Circle25 seed " << seed << ": max overlap " << r25.maxOverlapRatio
                                                          << ", last arrival " << lastArrival(r25) << " s");
    }
}

// RVO in UMANS' circle layouts: no exact guarantee, but with 250 random samples per step the
// agents cross (random sampling also breaks the symmetry). Circle10 must stay within the 10 %
// criterion; Circle25 is reported (0.094 with seed 1) and only held to no walking-through.
BOOST_AUTO_TEST_CASE(rvo_circle_avoids_and_arrives) {
    for (int n : {10, 25}) {
        const RunResult r = run(circle("RVO", n, n == 10 ? 5.0 : 7.5, 100.0));
        BOOST_TEST(r.finite);
        BOOST_TEST(r.maxOverlapRatio <= (n == 10 ? 0.10 : 0.5), "Circle" << n << ": overlap " << r.maxOverlapRatio);
        BOOST_TEST(r.arrival.size() == static_cast<std::size_t>(n), "Circle" << n << ": " << r.arrival.size() << " arrived");
        BOOST_TEST_MESSAGE("RVO Circle" << n << ": max overlap " << r.maxOverlapRatio << " of a radius, last arrival "
                                        << lastArrival(r) << " s");
    }
}

// A wall (0.2 m thick, 6 m long) stands between the agent and its goal: the straight line from
// (0, 0) to the goal (10, 4) crosses it at y = 2. Without the contact force
// (ContactForceScale 0), only ORCA's wall half-planes can keep the agent out of it: the agent must
// never touch the wall by more than rounding, and must get around it to the goal. The same run with
// range 0 (walls ignored) must walk into the wall — so the check can fail.
BOOST_AUTO_TEST_CASE(orca_does_not_walk_through_a_wall) {
    auto wallRun = [](double range, double& maxPenetration, bool& arrived, double& minY) {
        ScenarioSpec spec = scenario({agent(0, Vec2(0, 0), Vec2(10, 4))},
                                     {policy(0, OptimisationMethod::Global, {component("ORCA", {{"range", range}})},
                                             0.0, {}, StepTiming::Coarse, 0.0)},
                                     0.1, 40.0);
        spec.obstacles.push_back(box(4.9, -3.0, 5.1, 3.0));
        Simulation sim(spec);
        maxPenetration = 0;
        arrived = false;
        minY = kInf;
        Vec2 previous = spec.agents[0].position;
        while (!sim.finished()) {
            sim.stepCoarse();
            maxPenetration = std::max(maxPenetration, sim.maxWallPenetration());
            const AgentStore& A = sim.agents();
            if (A.size() == 0) break;
            if (!std::isfinite(A.pos[0].x())) return;
            if (A.atGoal(0)) arrived = true;
            // Where the agent crossed x = 5 (the wall's plane), interpolated between steps.
            const Vec2 p = A.pos[0];
            if ((previous.x() - 5.0) * (p.x() - 5.0) <= 0 && previous.x() != p.x()) {
                const double s = (5.0 - previous.x()) / (p.x() - previous.x());
                minY = std::min(minY, std::abs(previous.y() + s * (p.y() - previous.y())));
            }
            previous = p;
        }
    };
    double penetration = 0, minY = 0;
    bool arrived = false;
    wallRun(5.0, penetration, arrived, minY);
    BOOST_TEST(penetration <= 1e-3, "ORCA penetrated the wall by " << penetration << " m");
    BOOST_TEST(arrived, "ORCA did not get around the wall");
    BOOST_TEST(minY >= 3.0 + 0.3 - 1e-3, "crossed the wall's plane at |y| = " << minY);

    wallRun(0.0, penetration, arrived, minY);
    BOOST_TEST(penetration > 0.2, "control run without walls only penetrated " << penetration << " m");
}

// Same seed ⇒ identical results with 1 and 2 threads (RVO samples randomly; ORCA is
// deterministic by construction but is checked too).
BOOST_AUTO_TEST_CASE(same_result_with_one_and_two_threads) {
    for (const std::string model : {"RVO", "ORCA"}) {
        ScenarioSpec spec = circle(model, 12, 5.0, 12.0);
        spec.seed = 77;
        const RunResult one = run(spec, 1), two = run(spec, 2);
        BOOST_TEST_REQUIRE(one.finalPosition.size() == two.finalPosition.size());
        for (const auto& [id, p] : one.finalPosition) {
            BOOST_TEST(p.x() == two.finalPosition.at(id).x(), model << " agent " << id);
            BOOST_TEST(p.y() == two.finalPosition.at(id).y(), model << " agent " << id);
        }
        if (model == "RVO") {
            // …and a different seed changes RVO's random samples, hence the result.
            spec.seed = 78;
            const RunResult other = run(spec, 1);
            bool differs = false;
            for (const auto& [id, p] : one.finalPosition) differs = differs || (p - other.finalPosition.at(id)).norm() > 1e-9;
            BOOST_TEST(differs);
        }
    }
}
