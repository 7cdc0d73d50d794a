// CrowdHealth tests — the SPH crowd model (Policies/SPH, ContactForces, WallArea): kernels,
// density, dynamic rest density, absolute pressure, contact, analytic walls, the doorway base case.
#define BOOST_TEST_MODULE sph_model
#include <boost/test/unit_test.hpp>

#include "ContactForces.h"
#include "SPH.h"
#include "WallArea.h"
#include "test_support.h"

#include "crowdhealth/core/kernels.h"
#include "crowdhealth/core/rng.h"
#include "crowdhealth/io/xml.h"

#include <omp.h>

#include <cmath>
#include <memory>

using namespace ch;
using namespace ch::test;

namespace {

/// A frozen state built by hand, to call prepare()/acceleration() directly.
struct Frozen {
    AgentStore agents;
    World world;
    PointGrid grid;
    double dt = 0.02;
    std::uint64_t step = 0;

    Frozen(const std::vector<AgentSpec>& specs, const std::vector<ObstacleSpec>& obstacles = {})
        : world(WorldSpec{}, obstacles) {
        for (const AgentSpec& a : specs) agents.add(a, 0);
        rebuild();
    }
    void rebuild() { grid.build(agents.pos, 2.0); }
    StepContext ctx() const { return StepContext{agents, world, grid, dt, step * dt, step, 1, 0.5}; }
    test::OwnedQuery query(std::size_t i, double range = 2.0) const {
        test::OwnedQuery q;
        setQueryAgent(q, agents, i);
        grid.forEachWithin(q.position, range, [&](int j, const Vec2& d, double) {
            if (j != q.i) q.agentStore.push_back(NeighbourAgent{d, j});
        });
        world.segmentsNear(q.position, range, q.segmentStore);
        q.bind();
        return q;
    }
};

std::unique_ptr<SPH> makeSPH(const std::map<std::string, double>& values) {
    ComponentSpec c = component("SPH", values);
    return std::unique_ptr<SPH>(static_cast<SPH*>(createComponent("SPH", c.params).release()));
}
std::unique_ptr<ContactForces> makeContact(const std::map<std::string, double>& values) {
    ComponentSpec c = component("ContactForces", values);
    return std::unique_ptr<ContactForces>(static_cast<ContactForces*>(createComponent("ContactForces", c.params).release()));
}

AgentSpec still(AgentId id, Vec2 pos, double radius = 0.24, double mass = 1.0) {
    AgentSpec a = agent(id, pos, pos, radius, 0.0, 1.8);
    a.goal.reset();
    a.mass = mass;
    return a;
}

ObstacleSpec box(double x, double y, double w, double h) {
    ObstacleSpec b;
    b.points = {Vec2(x, y), Vec2(x + w, y), Vec2(x + w, y + h), Vec2(x, y + h)};
    return b;
}

std::vector<Segment> segmentsOf(const std::vector<ObstacleSpec>& obs) {
    return World(WorldSpec{}, obs).segments();
}

}  // namespace

// ---- kernels ---------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(poly6_integrates_to_one_and_spiky_gradient_to_zero) {
    for (double h : {0.5, 1.0}) {
        // Midpoint rule on a fine Cartesian grid over the disc.
        const int n = 800;
        const double cell = 2 * h / n;
        double w = 0, gx = 0, gy = 0, gAbs = 0;
        for (int iy = 0; iy < n; ++iy)
            for (int ix = 0; ix < n; ++ix) {
                const Vec2 x(-h + (ix + 0.5) * cell, -h + (iy + 0.5) * cell);
                const double r = x.norm();
                w += kernels::poly6(r * r, h) * cell * cell;
                if (r > 0) {
                    const Vec2 g = -kernels::spikyGradMagnitude(r, h) * x / r;  // ∇W points inwards
                    gx += g.x() * cell * cell;
                    gy += g.y() * cell * cell;
                    gAbs += g.norm() * cell * cell;
                }
            }
        BOOST_TEST(w == 1.0, boost::test_tools::tolerance(2e-3));
        BOOST_TEST(std::abs(gx) < 1e-6 * gAbs);
        BOOST_TEST(std::abs(gy) < 1e-6 * gAbs);
        // The gradient is that of the 2D spiky kernel 10/(πh⁵)(h−r)³, which integrates to 1:
        // ∫|∇W| dA = ∫0^h S(r) 2πr dr = 2π·30/(πh⁵)·h⁴/12 = 5/h.
        BOOST_TEST(gAbs == 5.0 / h, boost::test_tools::tolerance(3e-3));
    }
    BOOST_TEST(kernels::poly6(1.0, 1.0) == 0.0);
    BOOST_TEST(kernels::spikyGradMagnitude(1.0, 1.0) == 0.0);
    BOOST_TEST(kernels::viscosityLaplacian(1.0, 1.0) == 0.0);
}

// ---- density ----------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(lone_agent_density_is_its_mass_times_four_over_pi) {
    const double m = (0.3 / 0.24) * (0.3 / 0.24);
    Frozen f({still(1, Vec2(0, 0), 0.3, m)});
    auto sph = makeSPH({{"range", 1}});
    sph->prepare(f.ctx());
    BOOST_TEST((*sph->field("density"))[0] == m * 4.0 / kPi, boost::test_tools::tolerance(1e-12));
    // The rest density starts at the first density.
    BOOST_TEST((*sph->field("rest_density"))[0] == m * 4.0 / kPi, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(sph->smoothingLength() == 1.0);
}

BOOST_AUTO_TEST_CASE(smoothing_length_is_capped) {
    BOOST_TEST(makeSPH({{"range", 5}})->smoothingLength() == SPH::kMaxSmoothingLength);
    BOOST_TEST(makeSPH({{"range", 0.7}})->smoothingLength() == 0.7);
}

BOOST_AUTO_TEST_CASE(grid_of_400_agents_starts_at_mean_density_1_27) {
    std::vector<AgentSpec> specs;
    for (int row = 0; row < 20; ++row)
        for (int col = 0; col < 20; ++col) {
            Rng rng(7, 1, 0, static_cast<std::uint64_t>(row * 20 + col));
            const double r = rng.uniform(0.215, 0.265);
            specs.push_back(still(row * 20 + col, Vec2(0.5 + col, 0.5 + row), r, (r / 0.24) * (r / 0.24)));
        }
    Frozen f(specs);
    auto sph = makeSPH({{"range", 1}});
    sph->prepare(f.ctx());
    const auto& d = *sph->field("density");
    double sum = 0;
    for (double v : d) sum += v;
    BOOST_TEST(std::abs(sum / d.size() - 1.27) <= 0.02);
}

BOOST_AUTO_TEST_CASE(rest_density_follows_the_moving_average_and_its_clamp) {
    // Agent 0 alone for 5 steps, then a second agent appears 0.5 m away: its density jumps and
    // the rest density relaxes with weight w = Δt/T_ρ per step. gasConstant 0: nobody moves.
    Frozen f({still(1, Vec2(0, 0))});
    const double T = 0.1, dt = 0.02, w = dt / T;
    auto sph = makeSPH({{"range", 1}, {"gasConstant", 0}, {"restDensityMax", 100}, {"densityAdaptationTime", T}});
    auto capped = makeSPH({{"range", 1}, {"gasConstant", 0}, {"restDensityMax", 1.5}, {"densityAdaptationTime", T}});
    for (int k = 0; k < 5; ++k) {
        sph->prepare(f.ctx());
        capped->prepare(f.ctx());
        ++f.step;
    }
    const double rho1 = 4.0 / kPi;
    BOOST_TEST((*sph->field("rest_density"))[0] == rho1, boost::test_tools::tolerance(1e-12));

    f.agents.add(still(2, Vec2(0.5, 0)), 0);
    f.rebuild();
    sph->remapAgents({0, -1});
    capped->remapAgents({0, -1});
    const double rho2 = rho1 + kernels::poly6(0.25, 1.0);
    double expected = rho1;
    for (int k = 0; k < 8; ++k) {
        sph->prepare(f.ctx());
        capped->prepare(f.ctx());
        ++f.step;
        expected = (1 - w) * expected + w * rho2;
        BOOST_TEST((*sph->field("density"))[0] == rho2, boost::test_tools::tolerance(1e-12));
        BOOST_TEST((*sph->field("rest_density"))[0] == expected, boost::test_tools::tolerance(1e-12));
        BOOST_TEST((*capped->field("rest_density"))[0] == std::min(expected, 1.5), boost::test_tools::tolerance(1e-12));
        // The newcomer's rest density started at its own first density.
        BOOST_TEST((*sph->field("rest_density"))[1] == rho2, boost::test_tools::tolerance(1e-12));
    }
    // T_ρ shorter than the step: the weight is capped at 1, the rest density is the density.
    auto fast = makeSPH({{"range", 1}, {"gasConstant", 0}, {"restDensityMax", 100}, {"densityAdaptationTime", 0.001}});
    fast->prepare(f.ctx());
    fast->prepare(f.ctx());
    BOOST_TEST((*fast->field("rest_density"))[0] == rho2, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(no_pressure_force_below_rest_density) {
    Frozen f({still(1, Vec2(0, 0)), still(2, Vec2(0.5, 0))});
    // ρ0 forced to 10 > ρ: no pressure force (absolute pressure), and μ = 0: nothing at all.
    auto relaxed = makeSPH({{"range", 1}, {"restDensityMin", 10}, {"restDensityMax", 10}});
    relaxed->prepare(f.ctx());
    BOOST_TEST((*relaxed->field("pressure"))[0] < 0);
    BOOST_TEST(relaxed->acceleration(f.query(0), f.ctx()).norm() == 0.0);
    // ρ0 forced to 0 < ρ: compressed, pushed apart along the centre line.
    auto compressed = makeSPH({{"range", 1}, {"restDensityMin", 0}, {"restDensityMax", 0}});
    compressed->prepare(f.ctx());
    const Vec2 a0 = compressed->acceleration(f.query(0), f.ctx());
    const Vec2 a1 = compressed->acceleration(f.query(1), f.ctx());
    BOOST_TEST(a0.x() < -1.0);
    BOOST_TEST(std::abs(a0.y()) < 1e-12);
    BOOST_TEST(a1.x() == -a0.x(), boost::test_tools::tolerance(1e-12));  // equal masses and densities
}

BOOST_AUTO_TEST_CASE(viscosity_pulls_velocities_together) {
    Frozen f({still(1, Vec2(0, 0)), still(2, Vec2(0.5, 0))});
    f.agents.vel[1] = Vec2(0, 1);
    auto sph = makeSPH({{"range", 1}, {"restDensityMin", 10}, {"restDensityMax", 10}, {"viscosity", 3}});
    sph->prepare(f.ctx());
    const Vec2 a0 = sph->acceleration(f.query(0), f.ctx());
    BOOST_TEST(a0.y() > 0);  // dragged along by the moving neighbour
    BOOST_TEST(std::abs(a0.x()) < 1e-12);
}

// ---- analytic walls --------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(wall_area_of_a_straight_wall_is_the_circular_segment) {
    const std::vector<ObstacleSpec> obs = {box(-10, 0.3, 20, 1)};  // thick wall, near face at y = 0.3
    const auto segs = segmentsOf(obs);
    std::vector<int> all(segs.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
    std::vector<wallarea::WallPiece> pieces;
    wallarea::occludedAreas(Vec2(0, 0), 1.0, segs, all, pieces);
    const double d = 0.3, expected = std::acos(d) - d * std::sqrt(1 - d * d);
    BOOST_TEST_REQUIRE(pieces.size() == 1u);  // the back face (y = 1.3) is occluded / out of reach
    BOOST_TEST(pieces[0].area == expected, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(pieces[0].distance == d, boost::test_tools::tolerance(1e-12));
    // Split the same wall in two collinear segments: the areas add up to the same.
    ObstacleSpec a, b;
    a.points = {Vec2(-5, 0.3), Vec2(0.2, 0.3)};
    b.points = {Vec2(0.2, 0.3), Vec2(5, 0.3)};
    const auto two = segmentsOf({a, b});
    wallarea::occludedAreas(Vec2(0, 0), 1.0, two, {0, 1}, pieces);
    BOOST_TEST_REQUIRE(pieces.size() == 2u);
    BOOST_TEST(pieces[0].area + pieces[1].area == expected, boost::test_tools::tolerance(1e-9));
}

BOOST_AUTO_TEST_CASE(wall_area_with_occlusion_matches_ray_sampling) {
    // A door edge: a 1 m thick wall ending beside the agent, plus a wall farther away partly
    // hidden behind it. Compare with brute force: for each of many rays, the first segment hit.
    const std::vector<ObstacleSpec> obs = {box(0.2, -3, 1, 3.0), box(0.2, 0.6, 1, 3), box(-0.5, -0.9, 0.4, 0.1)};
    const auto segs = segmentsOf(obs);
    std::vector<int> all(segs.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
    const Vec2 p(-0.1, 0.15);
    const double h = 1.0;
    std::vector<wallarea::WallPiece> pieces;
    wallarea::occludedAreas(p, h, segs, all, pieces);
    std::vector<double> exact(segs.size(), 0.0), sampled(segs.size(), 0.0);
    for (const auto& s : pieces) exact[static_cast<std::size_t>(s.segment)] = s.area;
    const int rays = 200000;
    for (int k = 0; k < rays; ++k) {
        const double th = (k + 0.5) * 2 * kPi / rays;
        const Vec2 dir(std::cos(th), std::sin(th));
        double best = h;
        int hit = -1;
        for (std::size_t s = 0; s < segs.size(); ++s) {
            // Ray p + t·dir against segment a + u·(b − a).
            const Vec2 e = segs[s].b - segs[s].a, w = segs[s].a - p;
            const double den = dir.x() * e.y() - dir.y() * e.x();
            if (std::abs(den) < 1e-14) continue;
            const double t = (w.x() * e.y() - w.y() * e.x()) / den;
            const double u = (w.x() * dir.y() - w.y() * dir.x()) / den;
            if (t > 0 && u >= 0 && u <= 1 && t < best) {
                best = t;
                hit = static_cast<int>(s);
            }
        }
        if (hit >= 0) sampled[static_cast<std::size_t>(hit)] += 0.5 * (h * h - best * best) * 2 * kPi / rays;
    }
    double total = 0;
    for (std::size_t s = 0; s < segs.size(); ++s) {
        BOOST_TEST(std::abs(exact[s] - sampled[s]) < 1e-4);
        total += exact[s];
    }
    BOOST_TEST(total > 0.5);
    BOOST_TEST(total < kPi * h * h / 2 + 0.5);
}

BOOST_AUTO_TEST_CASE(analytic_wall_raises_density_and_pushes_away) {
    std::vector<ObstacleSpec> obs = {box(-10, 0.3, 20, 1)};
    Frozen f({still(1, Vec2(0, 0))}, obs);
    auto sph = makeSPH({{"range", 1}, {"restDensityMin", 2}, {"restDensityMax", 2}});
    sph->prepare(f.ctx());
    const double area = std::acos(0.3) - 0.3 * std::sqrt(1 - 0.09), r = 0.65;
    const double expected = 4.0 / kPi + area * 2.0 * kernels::poly6(r * r, 1.0);
    BOOST_TEST((*sph->field("density"))[0] == expected, boost::test_tools::tolerance(1e-9));
    auto squeezed = makeSPH({{"range", 1}, {"restDensityMin", 0}, {"restDensityMax", 0}});
    squeezed->prepare(f.ctx());
    const Vec2 a = squeezed->acceleration(f.query(0), f.ctx());
    BOOST_TEST(a.y() < 0);  // away from the wall at y = 0.3
    BOOST_TEST(std::abs(a.x()) < 1e-9);
}

BOOST_AUTO_TEST_CASE(walls_found_in_prepare_push_as_walls_found_again) {
    // acceleration() reads the wall pieces prepare() found at the same step (kept per thread of
    // its loop, in each thread's chunk of the agents); asked at another step it finds them again.
    // The two must agree to the bit for every agent, on one thread and on two (ctest runs the
    // team for small crowds: CROWDHEALTH_PARALLEL_MIN_AGENTS=1).
    const std::vector<ObstacleSpec> room = {box(-1, -1, 8, 1), box(-1, 4, 8, 1), box(-1, 0, 1, 4), box(6, 0, 1, 4),
                                            box(2.8, 1.6, 0.4, 0.8)};  // a pillar in the middle
    std::vector<AgentSpec> specs;
    Rng rng(7);
    for (int k = 0; k < 110; ++k)
        specs.push_back(still(static_cast<AgentId>(k), Vec2(rng.uniform(0.1, 5.9), rng.uniform(0.1, 3.9))));
    Frozen f(specs, room);
    for (const int threads : {1, 2}) {
        omp_set_num_threads(threads);
        auto sph = makeSPH({{"range", 1}, {"restDensityMin", 0}, {"restDensityMax", 0}});  // everyone pressed
        sph->prepare(f.ctx());  // two steps' prepare(): the second keeps only its own pieces
        sph->prepare(f.ctx());
        Frozen later(specs, room);  // the same state, one step on (a World is not copied)
        later.step = f.step + 1;
        int walled = 0;
        for (std::size_t i = 0; i < f.agents.size(); ++i) {
            const Vec2 kept = sph->acceleration(f.query(i), f.ctx());
            const Vec2 again = sph->acceleration(later.query(i), later.ctx());
            BOOST_TEST(kept.x() == again.x(), "agent " << i << " threads " << threads);
            BOOST_TEST(kept.y() == again.y(), "agent " << i << " threads " << threads);
            std::vector<int> near;
            f.world.segmentsNear(f.agents.pos[i], 1.0, near);
            if (!near.empty()) ++walled;
        }
        BOOST_TEST(walled >= 40);  // most of the room's agents have a wall within h
    }
    omp_set_num_threads(2);
}

// ---- boundary particles (walls = particles) ---------------------------------------------------

namespace {
/// A 6 m long, 1 m thick wall with its near face at y = 0.3, packed like <Box particles="true">
/// (rows 0.26 m and 0.74 m inside, every 0.48 m).
ObstacleSpec particleWall() {
    ObstacleSpec b = box(-3, 0.3, 6, 1);
    for (double y : {0.56, 1.04})
        for (int k = 0; k < 12; ++k) b.particles.emplace_back(-2.76 + 0.48 * k, y);
    return b;
}
}  // namespace

BOOST_AUTO_TEST_CASE(particle_walls_keep_their_rest_state) {
    // fixed (default): a boundary particle's rest density is its density without agents, so it
    // has no pressure until an agent comes within h, then a positive one; with the agents'
    // dynamic rule its rest density starts at its current density (p_k = 0 at the first step).
    Frozen far({still(1, Vec2(-0.12, -0.8))}, {particleWall()});  // 1.1 m from the face
    Frozen near({still(1, Vec2(-0.12, 0))}, {particleWall()});    // midway between two columns
    BOOST_TEST_REQUIRE(near.world.boundaryParticles().size() == 24u);
    auto fixed = makeSPH({{"range", 1}, {"walls", 0}});
    fixed->prepare(far.ctx());
    for (double p : fixed->boundaryPressure()) BOOST_TEST(p == 0.0, boost::test_tools::tolerance(1e-9));
    fixed->prepare(near.ctx());
    double most = 0;
    for (double p : fixed->boundaryPressure()) {
        BOOST_TEST(p >= -1e-9);
        most = std::max(most, p);
    }
    BOOST_TEST(most > 10.0);
    auto dynamic = makeSPH({{"range", 1}, {"walls", 0}, {"wallPressure", 1}});
    dynamic->prepare(near.ctx());
    for (double p : dynamic->boundaryPressure()) BOOST_TEST(p == 0.0, boost::test_tools::tolerance(1e-9));

    // A compressed agent (ρ0 forced to 0) is pushed straight away from the wall by every rule but
    // densityOnly, where the wall counts in its density only.
    for (int rule = 0; rule < 4; ++rule) {
        auto c = makeSPH({{"range", 1}, {"walls", 0}, {"restDensityMin", 0}, {"restDensityMax", 0}, {"wallPressure", rule}});
        c->prepare(near.ctx());
        const Vec2 a = c->acceleration(near.query(0), near.ctx());
        BOOST_TEST((*c->field("density"))[0] > 4.0 / kPi + 0.5);
        BOOST_TEST(std::abs(a.x()) < 1e-9);
        if (rule == 3) BOOST_TEST(a.norm() < 1e-12);
        else BOOST_TEST(a.y() < -1.0);
    }
}

BOOST_AUTO_TEST_CASE(particle_walls_take_part_in_the_viscosity) {
    // An agent sliding along a particle wall (no pressure: rest density above its density) is
    // slowed by the wall at rest when wallViscosity is on (default), untouched when off.
    Frozen f({still(1, Vec2(-0.12, 0))}, {particleWall()});
    f.agents.vel[0] = Vec2(1, 0);
    auto on = makeSPH({{"range", 1}, {"walls", 0}, {"restDensityMin", 10}, {"restDensityMax", 10}, {"viscosity", 3}});
    auto off = makeSPH({{"range", 1}, {"walls", 0}, {"restDensityMin", 10}, {"restDensityMax", 10}, {"viscosity", 3},
                        {"wallViscosity", 0}});
    on->prepare(f.ctx());
    off->prepare(f.ctx());
    test::OwnedQuery q = f.query(0);
    q.velocity = f.agents.vel[0];
    const Vec2 a = on->acceleration(q, f.ctx());
    BOOST_TEST(a.x() < -0.1);
    BOOST_TEST(std::abs(a.y()) < 1e-9);
    BOOST_TEST(off->acceleration(q, f.ctx()).norm() < 1e-12);
}

// ---- contact ---------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(contact_forces_are_equal_and_opposite) {
    const double m0 = 0.8, m1 = 1.3;
    Frozen f({still(1, Vec2(0, 0), 0.25, m0), still(2, Vec2(0.3, 0.4), 0.26, m1)});  // overlap 0.01
    auto c = makeContact({{"range", 1}});
    c->prepare(f.ctx());
    const Vec2 a0 = c->acceleration(f.query(0), f.ctx()), a1 = c->acceleration(f.query(1), f.ctx());
    const Vec2 F0 = a0 * m0, F1 = a1 * m1;
    BOOST_TEST((F0 + F1).norm() < 1e-12);
    BOOST_TEST(F0.norm() == 50 * 0.01, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(F0.dot(Vec2(0.3, 0.4)) < 0);  // pushed away from the other
    BOOST_TEST((*c->contactField())[0] == a0);
}

BOOST_AUTO_TEST_CASE(wall_contact_rules) {
    // Agent near the convex corner of a box: within its radius of two faces.
    const std::vector<ObstacleSpec> obs = {box(0, 0, 1, 1)};
    Frozen f({still(1, Vec2(-0.1, 0.9), 0.24), still(2, Vec2(0.5, 0.45), 0.24)}, obs);  // 2: centre inside
    auto vt = makeContact({{"range", 1}, {"wallRule", 0}});
    auto proto = makeContact({{"range", 1}, {"wallRule", 1}});
    vt->prepare(f.ctx());
    proto->prepare(f.ctx());
    // van Toll: the left face (d = 0.1) and the top face through its end point (0, 1) (d = √0.02).
    const Vec2 v0 = vt->acceleration(f.query(0), f.ctx());
    const double dc = std::sqrt(0.02), pc = 200 * (0.24 - dc) * 0.1 / dc;
    BOOST_TEST(v0.x() == -200 * 0.14 - pc, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(v0.y() == -pc, boost::test_tools::tolerance(1e-9));
    // prototype: one wall per obstacle, the adjacent one (left face, foot inside it).
    const Vec2 p0 = proto->acceleration(f.query(0), f.ctx());
    BOOST_TEST(p0.x() == -200 * 0.14, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(std::abs(p0.y()) < 1e-12);
    // Centre inside: the prototype pushes out towards the nearest face (y = 1 is 0.55 away,
    // x = 0/1 are 0.5 away, y = 0 is 0.45 away) by D + d.
    const Vec2 p1 = proto->acceleration(f.query(1), f.ctx());
    BOOST_TEST(p1.y() == -200 * (0.24 + 0.45), boost::test_tools::tolerance(1e-9));
    BOOST_TEST(std::abs(p1.x()) < 1e-12);
    // van Toll's rule has no inside/outside notion: nothing within the radius, nothing happens.
    BOOST_TEST(vt->acceleration(f.query(1), f.ctx()).norm() == 0.0);
}

BOOST_AUTO_TEST_CASE(prototype_takes_one_wall_per_obstacle) {
    // Agent beside the left face of a box, near its corner (0, 0): within its radius of the left
    // face (foot inside it: adjacent) and of the bottom face's end point.
    const std::vector<ObstacleSpec> obs = {box(0, 0, 1, 1)};
    Frozen f({still(1, Vec2(-0.2, 0.05), 0.24)}, obs);
    auto proto = makeContact({{"range", 1}, {"wallRule", 1}});
    auto vt = makeContact({{"range", 1}, {"wallRule", 0}});
    proto->prepare(f.ctx());
    vt->prepare(f.ctx());
    const Vec2 p = proto->acceleration(f.query(0), f.ctx());
    BOOST_TEST(p.x() == -200 * 0.04, boost::test_tools::tolerance(1e-9));  // left face only
    BOOST_TEST(std::abs(p.y()) < 1e-12);
    const Vec2 v = vt->acceleration(f.query(0), f.ctx());
    // van Toll: left face (d = 0.2) plus the bottom face's end point (0,0) at d = √0.0425.
    const double dc = std::sqrt(0.0425);
    BOOST_TEST(v.x() == -200 * 0.04 - 200 * (0.24 - dc) * 0.2 / dc, boost::test_tools::tolerance(1e-9));
}

BOOST_AUTO_TEST_CASE(simulation_records_the_contact_acceleration) {
    // Two overlapping agents under a ContactForces-only fine policy: AgentStore::contactAccel is
    // the component's report (times coeff), not UMANS' post-clamp contact (scale 0).
    PolicySpec p = policy(0, OptimisationMethod::Gradient, {component("ContactForces", {{"range", 1}}, 2.0)}, 0.5, {},
                          StepTiming::Fine, 0.0);
    p.steps[0].stopAtGoal = false;  // goal-less agents count as "at their goal"
    AgentSpec a = agent(1, Vec2(0, 0), Vec2(0, 0), 0.25), b = agent(2, Vec2(0.4, 0), Vec2(0.4, 0), 0.25);
    a.goal.reset();
    b.goal.reset();
    ScenarioSpec s = scenario({a, b}, {p}, 0.1, 1.0);
    s.deltaTimeFine = 0.02;
    Simulation sim(s);
    sim.stepCoarse();
    const AgentStore& A = sim.agents();
    BOOST_TEST(A.contactAccel[0].x() < 0);
    BOOST_TEST((A.contactAccel[0] + A.contactAccel[1]).norm() < 1e-12);
    const double d = (A.pos[1] - A.pos[0]).norm();
    // The last fine step's report: coeff 2 × K_ag 50 × overlap at the start of that step (≥ now).
    BOOST_TEST(A.contactAccel[0].norm() >= 2 * 50 * (0.5 - d) - 1e-12);
}

BOOST_AUTO_TEST_CASE(contact_reaches_across_a_torus_seam) {
    // Two agents touching across the seam of a 10 m torus push each other as two agents touching
    // in the open plane do: the stored lists' offsets are the shortest ones on a torus, and the
    // pair sums (pairs::setList) must not compute them as plain differences of positions there.
    const auto run = [](bool torus) {
        PolicySpec p = policy(0, OptimisationMethod::Gradient, {component("ContactForces", {{"range", 1}}, 2.0)}, 0.5, {},
                              StepTiming::Fine, 0.0);
        p.steps[0].stopAtGoal = false;
        const double x = torus ? 4.8 : -0.2;  // 0.4 m apart: across the seam at ±5, or across 0
        AgentSpec a = agent(1, Vec2(x, 0), Vec2(x, 0), 0.25), b = agent(2, Vec2(-x, 0), Vec2(-x, 0), 0.25);
        a.goal.reset();
        b.goal.reset();
        ScenarioSpec s = scenario({a, b}, {p}, 0.1, 1.0);
        s.deltaTimeFine = 0.1;  // one fine step per coarse step
        if (torus) {
            s.world.type = WorldType::Toric;
            s.world.width = s.world.height = 10.0;
        }
        Simulation sim(s);
        sim.stepCoarse();
        const AgentStore& A = sim.agents();  // agent 1's report (the store may have re-ordered them)
        return A.contactAccel[A.id[0] == 1 ? 0 : 1];
    };
    const Vec2 plane = run(false), torus = run(true);
    BOOST_TEST(plane.x() < 0);  // agent 1 (left, at −0.2) is pushed left
    // On the torus agent 1 sits at 4.8, its neighbour across the seam at −4.8 ≡ 5.2: pushed left too.
    BOOST_TEST(std::abs(torus.x() - plane.x()) < 1e-9, torus.transpose() << " plane " << plane.transpose());
    BOOST_TEST(std::abs(torus.y()) < 1e-12);
}

// ---- the base case ---------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(base_case_walls_hold) {
    Diagnostics diags;
    auto spec = loadScenario(std::string(CH_SOURCE_DIR) + "/Examples/doorway/base-case.xml", diags);
    BOOST_TEST_REQUIRE(spec.has_value());
    BOOST_TEST(spec->agents.size() == 400u);
    spec->endTime = 40.0;  // a congested crowd is still pressing against the door then
    Simulation sim(*spec);
    double worstBeyondRadius = -1, maxPenetration = 0;
    std::vector<int> near;
    while (!sim.finished()) {
        sim.stepCoarse();
        maxPenetration = std::max(maxPenetration, sim.maxWallPenetration());
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            // How far the centre is inside a wall (negative: outside).
            if (!sim.world().insideObstacle(A.pos[i])) continue;
            double d = kInf;
            for (const Segment& s : sim.world().segments())
                d = std::min(d, std::sqrt(distanceToSegmentSquared(A.pos[i], s.a, s.b)));
            worstBeyondRadius = std::max(worstBeyondRadius, d);
        }
    }
    BOOST_TEST_MESSAGE("base case: max wall penetration " << maxPenetration << " m, deepest centre inside a wall "
                                                         << worstBeyondRadius << " m");
    BOOST_TEST(sim.agents().size() > 100u);
    // At the end no agent is more than its radius inside a wall ...
    for (std::size_t i = 0; i < sim.agents().size(); ++i) BOOST_TEST(!sim.world().insideObstacle(sim.agents().pos[i]));
    // ... and on the way no centre went deeper than 0.15 m into one (walls are 1 m thick; the
    // prototype's corner rule lets centres graze door corners, see docs/model.md).
    BOOST_TEST(worstBeyondRadius < 0.15);
    BOOST_TEST(maxPenetration < 0.45);
}
