// CrowdHealth benchmark — a plain timed program (not a ctest test). Builds its scenes in code
// (no XML) and reports ms per fine step, agent-steps per second, peak memory and where the time
// goes. See docs/performance.md for the numbers and how to read them.
//
//   crowdhealth-bench [--quick] [--large] [--threads 1,2] [--steps N] [--sizes LIST] [--only TEXT] [--csv FILE]
//
// Every case runs in its own forked child process, so the peak memory (VmHWM) is that case's
// own (the parent never starts an OpenMP region, so forking is safe with libgomp).
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/kernels.h"
#include "crowdhealth/core/near_filter.h"
#include "crowdhealth/core/neighbours.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/core/registry.h"
#include "crowdhealth/health/safety.h"
#include "crowdhealth/navigation/field.h"
#include "crowdhealth/core/scenario.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/core/world.h"
#include "crowdhealth/navigation/field.h"
#include "crowdhealth/navigation/venue.h"

#include "../test_support.h"
#include "PairSums.h"
#include "SocialForcesAvoidance.h"

#include <omp.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace ch;
using Clock = std::chrono::steady_clock;

namespace {

/// --stored-lists: every step stores all neighbour lists even where no component needs them
/// stored (Simulation::setStoreNeighbourLists), to compare with gathering them agent by agent.
bool gStoredLists = false;

// ---------------------------------------------------------------------------------------------
// Scenes

using test::component;
using test::policy;

ObstacleSpec box(double x0, double y0, double x1, double y1) {
    ObstacleSpec o;
    o.points = {Vec2(x0, y0), Vec2(x1, y0), Vec2(x1, y1), Vec2(x0, y1)};  // counter-clockwise
    return o;
}

constexpr double kDenseDensity = 4.5;  // P/m² at the start

/// Dense SPH crowd: a square room with one 1.2 m exit in the middle of its right wall, agents on a
/// jittered lattice at 4.5 P/m², goal 2 m past the door; van Toll's SPH profile (goal + SPH +
/// contact, analytic walls) on the fine step 0.02 s. The coarse step equals the fine step so that
/// one stepCoarse() is one fine step (the policy has fine steps only, so the dynamics are the same
/// as with delta_time = 0.1).
ScenarioSpec denseSph(std::size_t n, std::uint64_t seed = 1) {
    ScenarioSpec s;
    s.sourceFile = "<bench:dense-sph>";
    s.deltaTime = 0.02;
    s.deltaTimeFine = 0.02;
    s.endTime = -1;
    s.seed = seed;
    s.world.type = WorldType::Infinite;

    s.policies.push_back(policy(0, OptimisationMethod::Gradient,
                                {component("GoalReachingForce", {{"range", 0}, {"strength", 1}}),
                                 component("SPH", {{"range", 1}}), component("ContactForces", {{"range", 1}})},
                                0.5, {}, StepTiming::Fine, 0.0));

    const double spacing = 1.0 / std::sqrt(kDenseDensity);
    const std::size_t perRow = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n))));
    const double L = static_cast<double>(perRow) * spacing;
    const double door = 1.2, t = 1.0;
    s.obstacles = {box(-t, -t, 0, L + t), box(0, -t, L, 0), box(0, L, L, L + t),
                   box(L, -t, L + t, 0.5 * (L - door)), box(L, 0.5 * (L + door), L + t, L + t)};

    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> radius(0.215, 0.265), jitter(-0.05 * spacing, 0.05 * spacing);
    s.agents.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
        AgentSpec a;
        a.id = static_cast<AgentId>(k);
        const double x = (static_cast<double>(k % perRow) + 0.5) * spacing + jitter(rng);
        const double y = (static_cast<double>(k / perRow) + 0.5) * spacing + jitter(rng);
        a.position = Vec2(x, y);
        a.goal = Vec2(L + 2.0, 0.5 * L);
        a.goalRadius = 0.5;
        a.removeAtGoal = true;
        a.radius = radius(rng);
        a.mass = (a.radius / 0.24) * (a.radius / 0.24);
        a.prefSpeed = 1.4;
        a.maxSpeed = 1.8;
        a.maxAcceleration = 5.0;
        s.agents.push_back(std::move(a));
    }
    return s;
}

/// UMANS social forces: n agents on a 1 m lattice (1 P/m²) in an open plane, alternate rows
/// walking +x and −x (counter-flow); SocialForcesAvoidance range 5 m + GoalReachingForce, gradient
/// method, delta_time 0.1 s, UMANS post-clamp contact (ContactForceScale 62.5), as
/// Examples/policies/social-forces.xml.
ScenarioSpec socialForces(std::size_t n, std::uint64_t seed = 1) {
    ScenarioSpec s;
    s.sourceFile = "<bench:social-forces>";
    s.deltaTime = 0.1;
    s.endTime = -1;
    s.seed = seed;
    s.policies.push_back(policy(0, OptimisationMethod::Gradient,
                                {component("SocialForcesAvoidance", {{"range", 5}}), component("GoalReachingForce")},
                                0.5, {}, StepTiming::Coarse, 62.5));
    const std::size_t perRow = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n))));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> jitter(-0.1, 0.1);
    for (std::size_t k = 0; k < n; ++k) {
        AgentSpec a;
        a.id = static_cast<AgentId>(k);
        const std::size_t row = k / perRow;
        a.position = Vec2(static_cast<double>(k % perRow) + jitter(rng), static_cast<double>(row) + jitter(rng));
        a.goal = Vec2(row % 2 == 0 ? 1000.0 : -1000.0, a.position.y());
        a.radius = 0.24;
        s.agents.push_back(std::move(a));
    }
    return s;
}

/// A hall 220 m × 120 m with a grid of 1 m pillars and two 2 m exits in its east wall; n agents at
/// 1 P/m² from x = 10 m, each walking to the nearer exit (a plain goal, removed there). With
/// `navigation` the world has <Navigation/> (two fields: one per exit) and the goals are reached
/// round the pillars; without it they walk straight (UMANS). The difference is what navigation
/// adds to a step.
/// The hall's navigation: none (straight at the goals, UMANS), along distance fields to the same
/// goals, or leaving by the quickest of the two exits (re-evaluated every 2 s, docs/navigation.md).
enum class HallNavigation { None, Fields, Quickest };

ScenarioSpec socialForcesHall(std::size_t n, HallNavigation navigation, std::uint64_t seed = 1) {
    ScenarioSpec s;
    s.sourceFile = navigation == HallNavigation::None     ? "<bench:social-forces-hall>"
                   : navigation == HallNavigation::Fields ? "<bench:social-forces-hall-nav>"
                                                          : "<bench:social-forces-hall-quickest>";
    s.deltaTime = 0.1;
    s.endTime = -1;
    s.seed = seed;
    s.world.type = WorldType::Planar;
    s.world.xmin = -1, s.world.xmax = 221, s.world.ymin = -1, s.world.ymax = 121;
    s.policies.push_back(policy(0, OptimisationMethod::Gradient,
                                {component("SocialForcesAvoidance", {{"range", 5}}), component("GoalReachingForce")},
                                0.5, {}, StepTiming::Coarse, 62.5));
    auto wall = [&](double x0, double y0, double x1, double y1) {
        ObstacleSpec o;
        o.points = {Vec2(x0, y0), Vec2(x1, y1)};
        s.obstacles.push_back(std::move(o));
    };
    wall(0, 0, 220, 0), wall(0, 120, 220, 120), wall(0, 0, 0, 120);
    wall(220, 0, 220, 29), wall(220, 31, 220, 89), wall(220, 91, 220, 120);  // exits at y 29–31 and 89–91
    for (double x = 125; x < 215; x += 10)
        for (double y = 5; y < 120; y += 10) s.obstacles.push_back(box(x, y, x + 1, y + 1));
    if (navigation != HallNavigation::None) s.venue.navigation = NavigationSpec{};
    if (navigation == HallNavigation::Quickest) {
        // Two exits just outside the doors, one exit set choosing the quickest, one journey.
        ExitSetSpec doors;
        doors.name = "doors";
        doors.choice = ExitChoice::Quickest;
        for (const double y : {30.0, 90.0}) {
            TargetSpec exit;
            exit.name = y < 60 ? "south_door" : "north_door";
            exit.exit = true;
            exit.width = 2;
            exit.shape.kind = TargetShape::Kind::Polygon;
            exit.shape.polygon = {Vec2(220.3, y - 1), Vec2(221, y - 1), Vec2(221, y + 1), Vec2(220.3, y + 1)};
            doors.exits.push_back(exit.name);
            s.venue.targets.push_back(std::move(exit));
        }
        s.venue.exitSets.push_back(std::move(doors));
        JourneySpec out;
        out.name = "out";
        out.leaveBy = "doors";
        s.venue.journeys.push_back(std::move(out));
    }
    const std::size_t perRow = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n))));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> jitter(-0.1, 0.1);
    for (std::size_t k = 0; k < n; ++k) {
        AgentSpec a;
        a.id = static_cast<AgentId>(k);
        const double y = 10 + (100.0 / static_cast<double>(perRow)) * static_cast<double>(k / perRow);
        a.position = Vec2(10 + static_cast<double>(k % perRow) + jitter(rng), y + jitter(rng));
        a.goal = Vec2(221, y < 60 ? 30 : 90);
        a.goalRadius = 1.5;
        a.removeAtGoal = true;
        a.radius = 0.24;
        if (navigation == HallNavigation::Quickest) a.journey = "out";
        s.agents.push_back(std::move(a));
    }
    return s;
}

// ---------------------------------------------------------------------------------------------
// Measurement helpers

/// Reads a "Key:   123 kB" line of /proc/self/status (KiB), or getrusage's maxrss for VmHWM.
double statusKiB(const char* key) {
    std::ifstream in("/proc/self/status");
    std::string line;
    const std::size_t len = std::strlen(key);
    while (std::getline(in, line))
        if (line.compare(0, len, key) == 0) return std::atof(line.c_str() + len + 1);
    if (std::strcmp(key, "VmHWM") == 0) {
        rusage u{};
        getrusage(RUSAGE_SELF, &u);
        return static_cast<double>(u.ru_maxrss);
    }
    return 0;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

std::uint64_t stateHash(const AgentStore& A) {
    std::uint64_t h = 1469598103934665603ull;
    auto mix = [&](const void* p, std::size_t bytes) {
        const unsigned char* c = static_cast<const unsigned char*>(p);
        for (std::size_t k = 0; k < bytes; ++k) h = (h ^ c[k]) * 1099511628211ull;
    };
    const std::size_t n = A.size();
    mix(&n, sizeof n);
    for (std::size_t i = 0; i < n; ++i) {
        mix(A.pos[i].data(), 2 * sizeof(double));
        mix(A.vel[i].data(), 2 * sizeof(double));
    }
    return h;
}

/// The result of one case, passed from the child to the parent through a pipe (plain data).
struct Result {
    char kind[24] = {};
    char scene[32] = {};
    double n = 0, threads = 0;
    double msMedian = 0, msMin = 0, msMax = 0;
    double agentStepsPerSec = 0;
    double hwmMiB = 0, rssMiB = 0;
    double phaseMs[Simulation::kPhases] = {};
    /// Mean ms per step outside every timed phase: the health layer's endStep (crush, injuries,
    /// falls, the heading change with its atan2), the swaps of the state arrays and the schedule.
    double otherMs = 0;
    double limitMs = 0;      ///< tight-kernel lower bound for the same pair work (dense SPH)
    double pairsPerAgent = 0;
    double extra1 = 0, extra2 = 0;  ///< neighbour search: build ms, ns per query; kernel: pairs/s
    double extra3 = 0;              ///< navigation: grid ms; vs-umans: median wall-time ratio
    std::uint64_t hash = 0;
    bool ok = false;
};

/// Tight SPH kernel loops over precomputed neighbour lists (CSR, ordered pairs within h, i
/// included for the density): one density pass and one pressure-force pass, as a step needs.
/// Returns the shortest wall time (ms) of one density + force evaluation, and the pair count.
std::pair<double, double> kernelLimit(const std::vector<Vec2>& pos, const std::vector<double>& mass, int threads,
                                      int reps) {
    const double h = 1.0;
    const std::size_t n = pos.size();
    PointGrid grid;
    grid.build(pos, h);
    std::vector<int> start(n + 1, 0), nb;
    nb.reserve(n * 16);
    for (std::size_t i = 0; i < n; ++i) {
        grid.forEachWithin(pos[i], h, [&](int j, const Vec2&, double d2) {
            if (d2 < h * h) nb.push_back(j);
        });
        start[i + 1] = static_cast<int>(nb.size());
    }
    std::vector<double> rho(n), pr(n);
    std::vector<Vec2> acc(n);
    const double c6 = 4.0 / (kPi * std::pow(h, 8)), cs = 30.0 / (kPi * std::pow(h, 5));
    omp_set_num_threads(threads);
    std::vector<double> times;
    for (int r = 0; r < reps; ++r) {
        const auto t0 = Clock::now();
#pragma omp parallel
        {
#pragma omp for schedule(static)
            for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
                const Vec2 p = pos[static_cast<std::size_t>(ii)];
                double s = 0;
                for (int k = start[ii]; k < start[ii + 1]; ++k) {
                    const int j = nb[k];
                    const double d = h * h - (pos[j] - p).squaredNorm();
                    s += mass[j] * c6 * d * d * d;
                }
                rho[ii] = s;
                pr[ii] = 200.0 * std::max(0.0, s - 4.0);
            }
#pragma omp for schedule(static)
            for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
                const Vec2 p = pos[static_cast<std::size_t>(ii)];
                Vec2 a(0, 0);
                for (int k = start[ii]; k < start[ii + 1]; ++k) {
                    const int j = nb[k];
                    if (j == ii) continue;
                    const Vec2 d = p - pos[j];
                    const double rr = d.norm();
                    if (rr < 1e-12) continue;
                    a += mass[j] * (pr[ii] + pr[j]) / (2.0 * rho[j]) * cs * (h - rr) * (h - rr) / rr * d;
                }
                acc[ii] = a / rho[ii];
            }
        }
        times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    volatile double sink = acc.empty() ? 0.0 : acc[n / 2].x();
    (void)sink;
    // The best of the repetitions: the limit is a best case (other work on the machine only slows it).
    return {*std::min_element(times.begin(), times.end()), static_cast<double>(nb.size())};
}

struct Case {
    std::string kind;  // "dense-sph", "social-forces", "neighbours"
    std::size_t n;
    int threads;
    int warmup, steps;
};

void fillPhases(Result& r, const Simulation& sim, int steps) {
    for (std::size_t p = 0; p < Simulation::kPhases; ++p) r.phaseMs[p] = 1e3 * sim.phaseSeconds()[p] / steps;
}
void resetPhases(Simulation& sim) { sim.resetPhaseTimes(); }

Result runSimCase(const Case& c) {
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "step");
    std::snprintf(r.scene, sizeof r.scene, "%s", c.kind.c_str());
    r.n = static_cast<double>(c.n);
    r.threads = c.threads;
    const bool dense = c.kind.rfind("dense-sph", 0) == 0;
    const bool hall = c.kind.rfind("sf-hall", 0) == 0;
    const HallNavigation hallNavigation = c.kind == "sf-hall-nav"        ? HallNavigation::Fields
                                          : c.kind == "sf-hall-quickest" ? HallNavigation::Quickest
                                                                         : HallNavigation::None;
    ScenarioSpec spec = dense ? denseSph(c.n) : hall ? socialForcesHall(c.n, hallNavigation) : socialForces(c.n);
    if (c.kind.find("shuffled") != std::string::npos) {
        // Agents listed in random order (as after much mixing): neighbours far apart in memory.
        std::mt19937_64 rng(7);
        std::shuffle(spec.agents.begin(), spec.agents.end(), rng);
    }
    // The spec is moved into the Simulation: one copy of a million agent specs.
    auto sim = std::make_unique<Simulation>(std::move(spec));
    if (c.kind.find("unordered") != std::string::npos) sim->setReorderInterval(0);
    if (gStoredLists) sim->setStoreNeighbourLists(true);
    sim->setThreads(c.threads);
    for (int k = 0; k < c.warmup; ++k) sim->stepCoarse();
    resetPhases(*sim);
    std::vector<double> ms;
    std::uint64_t agentSteps = 0;
    double total = 0;
    for (int k = 0; k < c.steps; ++k) {
        const std::size_t agents = sim->agents().size();
        const auto t0 = Clock::now();
        sim->stepCoarse();
        const double dt = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        ms.push_back(dt);
        total += dt;
        agentSteps += agents;
    }
    r.msMedian = median(ms);
    r.msMin = *std::min_element(ms.begin(), ms.end());
    r.msMax = *std::max_element(ms.begin(), ms.end());
    r.agentStepsPerSec = static_cast<double>(agentSteps) / (total * 1e-3);
    fillPhases(r, *sim, c.steps);
    {
        double phases = 0;
        for (double p : r.phaseMs) phases += p;
        r.otherMs = std::max(0.0, total / c.steps - phases);
    }
    r.hash = stateHash(sim->agents());
    r.hwmMiB = statusKiB("VmHWM") / 1024.0;
    r.rssMiB = statusKiB("VmRSS") / 1024.0;
    if (dense) {
        const auto [limit, pairs] = kernelLimit(sim->agents().pos, sim->agents().mass, c.threads, 5);
        r.limitMs = limit;
        r.pairsPerAgent = pairs / std::max<double>(1.0, static_cast<double>(sim->agents().size()));
        r.extra1 = pairs / (limit * 1e-3);  // kernel pair evaluations (density + force) per second
    }
    r.ok = true;
    return r;
}

/// Neighbour search alone on the dense scene's positions: grid build (one thread) and one query
/// per agent with radius 1 m (cell 1 m) — what SPH density and the per-agent gather do.
Result runNeighbourCase(const Case& c, double radius) {
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "neighbours");
    std::snprintf(r.scene, sizeof r.scene, "grid r=%.1fm", radius);
    r.n = static_cast<double>(c.n);
    r.threads = c.threads;
    const ScenarioSpec spec = radius > 2 ? socialForces(c.n) : denseSph(c.n);
    std::vector<Vec2> pos;
    pos.reserve(spec.agents.size());
    for (const AgentSpec& a : spec.agents) pos.push_back(a.position);
    omp_set_num_threads(c.threads);
    PointGrid grid;
    std::vector<double> build, query;
    std::uint64_t hits = 0;
    for (int k = 0; k < c.warmup + c.steps; ++k) {
        auto t0 = Clock::now();
        grid.build(pos, radius);
        const double b = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        t0 = Clock::now();
        std::uint64_t count = 0;
#pragma omp parallel for schedule(static) reduction(+ : count)
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(pos.size()); ++i)
            grid.forEachWithin(pos[static_cast<std::size_t>(i)], radius, [&](int, const Vec2&, double) { ++count; });
        const double q = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        hits = count;
        if (k >= c.warmup) {
            build.push_back(b);
            query.push_back(q);
        }
    }
    r.extra1 = median(build);
    r.extra2 = 1e6 * median(query) / static_cast<double>(pos.size());  // ns per query
    r.msMedian = r.extra1 + median(query);
    r.pairsPerAgent = static_cast<double>(hits) / static_cast<double>(pos.size());
    r.hwmMiB = statusKiB("VmHWM") / 1024.0;
    r.rssMiB = statusKiB("VmRSS") / 1024.0;
    r.ok = true;
    return r;
}

/// Navigation fields: a 200 m × 200 m planar venue (long walls with doors, a thick wall, a diagonal
/// wall, 22 square pillars: ~100 wall segments) rasterised at 0.2 m (1M cells), and 10 distance
/// fields (exits round the edge and points inside), all on one thread. Reports the preparation
/// time (grid + 10 fields) and the cost of one direction() + distance() query at random walkable
/// points.
Result runNavigationCase(int reps) {
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "navigation");
    std::snprintf(r.scene, sizeof r.scene, "%s", "venue 200m h0.2");
    r.threads = 1;
    omp_set_num_threads(1);
    WorldSpec ws;
    ws.type = WorldType::Planar;
    ws.xmin = 0;
    ws.ymin = 0;
    ws.xmax = 200;
    ws.ymax = 200;
    auto wall = [](double x0, double y0, double x1, double y1) {
        ObstacleSpec o;
        o.points = {Vec2(x0, y0), Vec2(x1, y1)};
        return o;
    };
    std::vector<ObstacleSpec> obstacles = {
        wall(20, 50, 90, 50),   wall(95, 50, 180, 50),    // a long wall with a 5 m door
        wall(20, 150, 120, 150), wall(126, 150, 200, 150),
        wall(60, 60, 60, 140),  wall(140, 60, 140, 100),  wall(140, 106, 140, 145),
        wall(150, 10, 190, 40),  // diagonal
        box(95, 160, 105, 190),  // a thick wall
    };
    for (int i = 0; i < 22; ++i) {
        const double x = 70 + 6.0 * (i % 11), y = 80 + 30.0 * (i / 11);
        obstacles.push_back(box(x, y, x + 1, y + 1));
    }
    const World world(ws, obstacles);
    std::vector<TargetShape> targets;
    for (const Vec2& c : {Vec2(1, 100), Vec2(199, 100), Vec2(100, 1), Vec2(100, 199), Vec2(1, 1), Vec2(199, 199),
                          Vec2(30, 170), Vec2(100, 100), Vec2(170, 80), Vec2(40, 20)}) {
        TargetShape t;
        t.kind = TargetShape::Kind::Polygon;
        t.polygon = {c + Vec2(-1, -1), c + Vec2(1, -1), c + Vec2(1, 1), c + Vec2(-1, 1)};
        targets.push_back(t);
    }
    WalkableGridSettings settings;
    settings.cellSize = 0.2;
    settings.clearance = 0.5;
    std::vector<double> gridMs, fieldMs, queryNs;
    std::uint64_t hash = 0;
    for (int k = 0; k < reps; ++k) {
        auto t0 = Clock::now();
        const WalkableGrid grid(world, settings, Vec2(0, 0), Vec2(200, 200));
        const double g = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        t0 = Clock::now();
        std::vector<DistanceField> fields;
        fields.reserve(targets.size());
        for (const TargetShape& t : targets) fields.emplace_back(grid, t);
        const double f = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        // Queries at random walkable points, each field in turn.
        std::mt19937_64 rng(11);
        std::uniform_real_distribution<double> u(0.0, 200.0);
        std::vector<Vec2> pts;
        while (pts.size() < 200000) {
            const Vec2 p(u(rng), u(rng));
            if (grid.walkable(p)) pts.push_back(p);
        }
        double sink = 0;
        t0 = Clock::now();
        for (std::size_t i = 0; i < pts.size(); ++i) {
            const DistanceField& field = fields[i % fields.size()];
            double dist = 0;
            const Vec2 d = field.sample(pts[i], dist);  // what the simulation calls per agent and step
            sink += dist + d.x();
        }
        const double q = std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / pts.size();
        gridMs.push_back(g);
        fieldMs.push_back(f);
        queryNs.push_back(q);
        hash = 0;
        for (int iy = 0; iy < grid.ny(); iy += 7)
            for (int ix = 0; ix < grid.nx(); ix += 7) {
                const float v = fields[0].value(ix, iy);
                std::uint32_t bits;
                std::memcpy(&bits, &v, sizeof bits);
                hash = hash * 1099511628211ULL + bits;
            }
        r.n = static_cast<double>(grid.cellCount());
        r.pairsPerAgent = sink > 0 ? 0 : 1;  // keeps the queries
    }
    r.extra3 = *std::min_element(gridMs.begin(), gridMs.end());
    r.extra1 = *std::min_element(fieldMs.begin(), fieldMs.end());
    r.extra2 = *std::min_element(queryNs.begin(), queryNs.end());
    r.msMedian = median(gridMs) + median(fieldMs);
    r.msMin = r.extra3 + r.extra1;
    r.hash = hash;
    r.hwmMiB = statusKiB("VmHWM") / 1024.0;
    r.rssMiB = statusKiB("VmRSS") / 1024.0;
    r.ok = true;
    return r;
}

/// What a run's outputs cost per coarse step for the dense crowd of n agents after one step, on
/// one thread (issue 6): one metrics.csv row as MetricsRecorder takes it (measureMetrics: density,
/// crowd pressure grid, …, then the CSV text) and its two largest parts, SafetyRecorder::record
/// (heat map and verdict, every coarse step), and one trajectory frame streamed to
/// trajectories.bin (with or without velocities) or trajectories.txt. msMedian = mean ms per
/// frame including the final flush and rename (the file goes to the page cache; a slow disk adds
/// its own time), msMin = fastest frame, extra1 = MB per frame (10^6 bytes). Files go to a
/// temporary folder, removed after.
Result runOutputCase(const std::string& what, std::size_t n, int reps) {
    namespace fs = std::filesystem;
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "output");
    std::snprintf(r.scene, sizeof r.scene, "%s", what.c_str());
    r.n = static_cast<double>(n);
    r.threads = 1;
    Simulation sim(denseSph(n));
    sim.setThreads(1);
    sim.stepCoarse();  // densities, contacts and health of a real step
    const fs::path dir = fs::temp_directory_path() / ("crowdhealth-bench-output-" + std::to_string(getpid()));
    fs::create_directories(dir);

    std::vector<double> ms;
    double bytes = 0, total = 0;
    auto timed = [&](const std::function<void()>& f) {
        const auto t0 = Clock::now();
        f();
        const double d = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        total += d;
        return d;
    };
    if (what == "metrics row") {
        for (int k = 0; k < reps; ++k) {
            MetricsRecorder metrics(1.0);
            std::string csv;
            ms.push_back(timed([&] {
                metrics.sample(sim);
                csv = metrics.csv();
            }));
            bytes = static_cast<double>(csv.size() - csv.find('\n') - 1);  // the row, without the header
        }
    } else if (what == "  density h=1") {  // the parts of a metrics row
        for (int k = 0; k < reps; ++k) ms.push_back(timed([&] { sim.measureDensity(1.0); }));
    } else if (what == "  crowd field") {
        const SafetyThresholds grid;
        for (int k = 0; k < reps; ++k)
            ms.push_back(timed([&] { (void)crowdField(sim.agents(), grid.cellSize, grid.gaussianRadius); }));
    } else if (what == "safety record") {
        // It records once per simulated time: a step between two records (not timed).
        SafetyRecorder safety;
        for (int k = 0; k < reps; ++k) {
            ms.push_back(timed([&] { safety.record(sim); }));
            sim.stepCoarse();
        }
    } else {
        const fs::path file = dir / (what == "txt frame" ? "trajectories.txt" : "trajectories.bin");
        std::optional<BinaryTrajectoryWriter> bin;
        std::optional<PedPyTrajectoryWriter> txt;
        if (what == "txt frame") txt.emplace(file, sim.deltaTime());
        else bin.emplace(file, sim.deltaTime(), sim.deltaTime(), what == "bin+v frame");
        const auto headerBytes = fs::file_size(file.string() + ".tmp");
        for (int k = 0; k < reps; ++k)
            ms.push_back(timed([&] { txt ? txt->writeFrame(sim) : bin->writeFrame(sim); }));
        timed([&] { txt ? txt->commit() : bin->commit(); });
        bytes = static_cast<double>(fs::file_size(file) - headerBytes) / reps;
    }
    fs::remove_all(dir);
    r.msMedian = total / reps;
    r.msMin = *std::min_element(ms.begin(), ms.end());
    r.msMax = *std::max_element(ms.begin(), ms.end());
    r.extra1 = bytes / 1e6;
    r.hwmMiB = statusKiB("VmHWM") / 1024.0;
    r.rssMiB = statusKiB("VmRSS") / 1024.0;
    r.ok = true;
    return r;
}

// ---------------------------------------------------------------------------------------------
// Side by side with UMANS 1.x (issue 20): the same scene as an XML scenario both programs load,
// each run as a whole process as users run it, one thread, interleaved and repeated.

/// The social-forces scene (socialForces(n)) as a UMANS scenario file: inline <Policies> and
/// <Agents>, every agent attribute written out (the two programs' defaults agree, but the file
/// should not depend on that), positions to the last bit of a double (UMANS rounds them to float).
void writeUmansScenario(const std::filesystem::path& file, std::size_t n, double endTime) {
    const ScenarioSpec s = socialForces(n);
    std::ofstream out(file);
    char buf[512];
    std::snprintf(buf, sizeof buf, "<Simulation delta_time=\"%g\" end_time=\"%g\">\n", s.deltaTime, endTime);
    out << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- crowdhealth-bench: the social-forces scene -->\n" << buf
        << "\t<World type=\"Infinite\" />\n"
           "\t<Policies>\n"
           "\t\t<Policy id=\"0\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\" ContactForceScale=\"62.5\">\n"
           "\t\t\t<costfunction name=\"SocialForcesAvoidance\" range=\"5\" />\n"
           "\t\t\t<costfunction name=\"GoalReachingForce\" />\n"
           "\t\t</Policy>\n"
           "\t</Policies>\n"
           "\t<Agents>\n";
    for (const AgentSpec& a : s.agents) {
        std::snprintf(buf, sizeof buf,
                      "\t\t<Agent rad=\"%g\" pref_speed=\"%g\" max_speed=\"%g\" max_acceleration=\"%g\">"
                      "<pos x=\"%.17g\" y=\"%.17g\"/><goal x=\"%.17g\" y=\"%.17g\"/><Policy id=\"0\"/></Agent>\n",
                      a.radius, a.prefSpeed, a.maxSpeed, a.maxAcceleration, a.position.x(), a.position.y(),
                      a.goal->x(), a.goal->y());
        out << buf;
    }
    out << "\t</Agents>\n</Simulation>\n";
}

/// One whole-process run: CPU time (user + system, from wait4; what `perf stat -e task-clock`
/// counts) and wall time, in seconds; ok = exit status 0. stdout and stderr go to `log`.
struct ProcessTime {
    double cpu = 0, wall = 0;
    bool ok = false;
};
ProcessTime runProcess(const std::vector<std::string>& args, const std::filesystem::path& log) {
    ProcessTime t;
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const auto t0 = Clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) return t;
    if (pid == 0) {
        const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        execv(argv[0], argv.data());
        _exit(127);
    }
    int status = 0;
    rusage u{};
    if (wait4(pid, &status, 0, &u) != pid) return t;
    t.wall = std::chrono::duration<double>(Clock::now() - t0).count();
    t.cpu = static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
            1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    t.ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    return t;
}

/// The UMANS console application: --umans PATH, else $CROWDHEALTH_UMANS, else where
/// ../shared/reference/umans/build-umans.sh leaves it. Empty if none is there.
std::string findUmans(const std::string& option) {
    namespace fs = std::filesystem;
    std::vector<std::string> tries;
    if (!option.empty()) tries.push_back(option);
    if (const char* e = std::getenv("CROWDHEALTH_UMANS"); e != nullptr && *e) tries.emplace_back(e);
    tries.emplace_back("/tmp/umans-ref/build/UMANS-ConsoleApplication-Linux");
    for (const std::string& p : tries)
        if (access(p.c_str(), X_OK) == 0 && fs::is_regular_file(p)) return p;
    return {};
}

/// The crowdhealth program: --crowdhealth PATH, else beside this benchmark (build/bin).
std::string findCrowdHealth(const std::string& option) {
    namespace fs = std::filesystem;
    if (!option.empty()) return option;
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    return ec ? std::string("crowdhealth") : (self.parent_path() / "crowdhealth").string();
}

/// Runs UMANS and crowdhealth on the social-forces scene (n agents, endTime simulated seconds),
/// one thread each, `reps` times in turn (UMANS, then us), and prints each pair's CPU and wall
/// times and their ratios; the medians go into a Result (msMedian: our CPU ms per step; extra1:
/// UMANS' CPU ms per step; extra2: the median of the per-pair CPU ratios; extra3: of the wall ratios).
Result runUmansCase(const std::string& umans, const std::string& crowdhealth, std::size_t n, double endTime, int reps) {
    namespace fs = std::filesystem;
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "vs-umans");
    std::snprintf(r.scene, sizeof r.scene, "%s", "social-forces");
    r.n = static_cast<double>(n);
    r.threads = 1;
    const fs::path dir = fs::temp_directory_path() / ("crowdhealth-bench-umans-" + std::to_string(getpid()));
    fs::create_directories(dir);
    const fs::path scene = dir / "social-forces.xml";
    writeUmansScenario(scene, n, endTime);
    const double steps = std::round(endTime / 0.1);
    std::printf("scene %s: %zu agents, %g steps of 0.1 s; UMANS: %s -i SCENE -t 1 (no -o: no trajectories)\n"
                "crowdhealth: %s -i SCENE -o OUT -t 1 -q --trajectories none (metrics, verdict, summary as default)\n",
                scene.c_str(), n, steps, umans.c_str(), crowdhealth.c_str());
    std::printf("%4s  %10s %10s  %10s %10s  %8s %8s  %s\n", "rep", "UMANS cpu", "wall", "ours cpu", "wall",
                "cpu ratio", "wall rat", "load");
    std::vector<double> cpuRatio, wallRatio, oursCpu, umansCpu;
    bool ok = true;
    for (int k = 0; k < reps && ok; ++k) {
        const ProcessTime u = runProcess({umans, "-i", scene.string(), "-t", "1"}, dir / "umans.log");
        const ProcessTime c = runProcess({crowdhealth, "-i", scene.string(), "-o", (dir / "out").string(), "-t", "1",
                                          "-q", "--trajectories", "none"},
                                         dir / "crowdhealth.log");
        if (!u.ok || !c.ok) {
            std::printf("  %s failed: see %s\n", !u.ok ? "UMANS" : "crowdhealth",
                        (dir / (!u.ok ? "umans.log" : "crowdhealth.log")).c_str());
            ok = false;
            break;
        }
        double load[1] = {0};
        if (getloadavg(load, 1) < 1) load[0] = -1;
        cpuRatio.push_back(u.cpu / c.cpu);
        wallRatio.push_back(u.wall / c.wall);
        oursCpu.push_back(c.cpu);
        umansCpu.push_back(u.cpu);
        std::printf("%4d  %9.2fs %9.2fs  %9.2fs %9.2fs  %7.2fx %7.2fx  %.1f\n", k + 1, u.cpu, u.wall, c.cpu, c.wall,
                    cpuRatio.back(), wallRatio.back(), load[0]);
        std::fflush(stdout);
    }
    if (ok) {
        r.msMedian = 1e3 * median(oursCpu) / steps;
        r.msMin = 1e3 * *std::min_element(oursCpu.begin(), oursCpu.end()) / steps;
        r.extra1 = 1e3 * median(umansCpu) / steps;
        r.extra2 = median(cpuRatio);
        r.extra3 = median(wallRatio);
        r.ok = true;
        fs::remove_all(dir);  // kept when a run failed, for its log
    }
    return r;
}

/// Runs f in a forked child and returns its Result (or !ok if the child failed).
Result inChild(const std::function<Result()>& f, bool fork) {
    if (!fork) return f();
    int fd[2];
    if (pipe(fd) != 0) return f();
    const pid_t pid = ::fork();
    if (pid == 0) {
        close(fd[0]);
        Result r;
        try {
            r = f();
        } catch (const std::exception& e) {
            std::fprintf(stderr, "case failed: %s\n", e.what());
        }
        const ssize_t w = write(fd[1], &r, sizeof r);
        (void)w;
        close(fd[1]);
        _exit(r.ok ? 0 : 1);
    }
    close(fd[1]);
    Result r;
    std::size_t got = 0;
    while (got < sizeof r) {
        const ssize_t k = read(fd[0], reinterpret_cast<char*>(&r) + got, sizeof r - got);
        if (k <= 0) break;
        got += static_cast<std::size_t>(k);
    }
    close(fd[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    if (got != sizeof r) r.ok = false;
    return r;
}

// ---------------------------------------------------------------------------------------------
// The program as users run it against the bare step (issue 20): the same scene as an XML file,
// run by `crowdhealth` (metrics, safety recorder, verdict, evacuations, summary: the defaults;
// trajectories off), against Simulation::stepCoarse() alone in this program, one thread each.

/// The dense-sph scene (denseSph(n)) as a crowdhealth scenario file, as a user would write it:
/// delta_time 0.1 s with fine steps of 0.02 s (the policy has fine steps only, so the motion is the
/// bench's, whose coarse step is one fine step), walls as the same polygons, every agent attribute
/// written out to the last bit.
void writeDenseSphScenario(const std::filesystem::path& file, std::size_t n, double endTime) {
    const ScenarioSpec s = denseSph(n);
    std::ofstream out(file);
    char buf[512];
    std::snprintf(buf, sizeof buf, "<Simulation delta_time=\"0.1\" delta_time_fine=\"%g\" end_time=\"%g\">\n",
                  s.deltaTimeFine, endTime);
    out << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- crowdhealth-bench: the dense-sph scene -->\n" << buf
        << "\t<World type=\"Infinite\">\n";
    for (const ObstacleSpec& o : s.obstacles) {
        out << "\t\t<Obstacle>";
        for (const Vec2& q : o.points) {
            std::snprintf(buf, sizeof buf, "<Point x=\"%.17g\" y=\"%.17g\"/>", q.x(), q.y());
            out << buf;
        }
        out << "</Obstacle>\n";
    }
    out << "\t</World>\n"
           "\t<Policies>\n"
           "\t\t<Policy id=\"0\">\n"
           "\t\t\t<Step DeltaTime=\"fine\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\">\n"
           "\t\t\t\t<CostFunction name=\"GoalReachingForce\" range=\"0\" strength=\"1\" />\n"
           "\t\t\t\t<CostFunction name=\"SPH\" range=\"1\" />\n"
           "\t\t\t\t<CostFunction name=\"ContactForces\" range=\"1\" />\n"
           "\t\t\t</Step>\n"
           "\t\t</Policy>\n"
           "\t</Policies>\n"
           "\t<Agents>\n";
    for (const AgentSpec& a : s.agents) {
        std::snprintf(buf, sizeof buf,
                      "\t\t<Agent rad=\"%.17g\" mass=\"%.17g\" pref_speed=\"%g\" max_speed=\"%g\" max_acceleration=\"%g\" "
                      "remove_at_goal=\"true\" goal_radius=\"%g\"><pos x=\"%.17g\" y=\"%.17g\"/>"
                      "<goal x=\"%.17g\" y=\"%.17g\"/><Policy id=\"0\"/></Agent>\n",
                      a.radius, a.mass, a.prefSpeed, a.maxSpeed, a.maxAcceleration, a.goalRadius, a.position.x(),
                      a.position.y(), a.goal->x(), a.goal->y());
        out << buf;
    }
    out << "\t</Agents>\n</Simulation>\n";
}

/// CPU seconds of this process so far (every thread).
double processCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The safety grid's and the metrics rows' wall seconds in a log of `crowdhealth --timing` (its
/// second line; −1 where the line is missing, e.g. a build from before it).
struct RunTiming {
    double safety = -1, metrics = -1;
};
RunTiming readTiming(const std::filesystem::path& log) {
    RunTiming t;
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("  recording ", 0) == 0)
            std::sscanf(line.c_str(), "  recording %lf s safety grid (%*f %%), %lf s metrics", &t.safety, &t.metrics);
    return t;
}

/// The bare step: `steps` calls of Simulation::stepCoarse() on the scene built in code, one thread,
/// no recorder; msMedian = CPU ms per fine step (the mean over the steps, first included, as for
/// the process), extra1 = CPU seconds of building the Simulation.
Result runBareCpu(const std::string& scene, std::size_t n, int steps) {
    Result r;
    std::snprintf(r.kind, sizeof r.kind, "%s", "bare");
    std::snprintf(r.scene, sizeof r.scene, "%s", scene.c_str());
    r.n = static_cast<double>(n);
    r.threads = 1;
    const double c0 = processCpuSeconds();
    auto sim = std::make_unique<Simulation>(scene == "dense-sph" ? denseSph(n) : socialForces(n));
    sim->setThreads(1);
    if (gStoredLists) sim->setStoreNeighbourLists(true);
    const double c1 = processCpuSeconds();
    for (int k = 0; k < steps; ++k) sim->stepCoarse();
    const double c2 = processCpuSeconds();
    r.msMedian = 1e3 * (c2 - c1) / steps;
    r.extra1 = c1 - c0;
    r.hash = stateHash(sim->agents());
    r.ok = true;
    return r;
}

/// For each scene: `reps` times in turn, the bare step (in a child), the program on the scene's
/// file for endTime simulated seconds, and the program stopped at 0.1 s (loading, the first
/// records and the outputs: the fixed cost, plus one coarse step). Prints CPU ms per fine step:
/// the bare step's, the whole program's (its CPU / steps), the marginal one (the difference of the
/// two runs / the difference of their steps), and the ratios to the bare step.
void runProcessCases(const std::string& crowdhealth, std::size_t n, int reps, bool quick, bool fork) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("crowdhealth-bench-process-" + std::to_string(getpid()));
    fs::create_directories(dir);
    struct Scene {
        const char* name;
        double endTime, fine;  // simulated s, fine step s
    };
    const Scene scenes[] = {{"social-forces", quick ? 1.0 : 10.0, 0.1}, {"dense-sph", quick ? 0.4 : 4.0, 0.02}};
    for (const Scene& sc : scenes) {
        const fs::path file = dir / (std::string(sc.name) + ".xml");
        if (std::string(sc.name) == "dense-sph") writeDenseSphScenario(file, n, sc.endTime);
        else writeUmansScenario(file, n, sc.endTime);
        const int steps = static_cast<int>(std::lround(sc.endTime / sc.fine));
        const int shortSteps = static_cast<int>(std::lround(0.1 / sc.fine));  // of the run stopped at 0.1 s
        std::printf("\nprocess %s: %zu agents, %d fine steps of %g s, one thread; crowdhealth -i %s -o OUT -t 1 -q "
                    "--trajectories none [--end-time 0.1]\n",
                    sc.name, n, steps, sc.fine, file.c_str());
        std::printf("%4s  %12s  %12s  %12s  %12s  %8s  %8s  %9s  %9s  %s\n", "rep", "bare ms/step", "whole ms/st",
                    "fixed s", "marginal ms", "whole/b", "marg/b", "safety ms", "metric ms", "load");
        std::vector<double> bare, whole, perStep, fixed, safety, metrics;
        bool ok = true;
        for (int k = 0; k < reps && ok; ++k) {
            const Result b = inChild([&] { return runBareCpu(sc.name, n, steps); }, fork);
            const ProcessTime p = runProcess({crowdhealth, "-i", file.string(), "-o", (dir / "out").string(), "-t",
                                              "1", "-q", "--trajectories", "none", "--timing"},
                                             dir / "crowdhealth.log");
            const RunTiming timing = readTiming(dir / "crowdhealth.log");
            const ProcessTime z = runProcess({crowdhealth, "-i", file.string(), "-o", (dir / "out0").string(), "-t",
                                              "1", "-q", "--trajectories", "none", "--end-time", "0.1"},
                                             dir / "crowdhealth0.log");
            if (!b.ok || !p.ok || !z.ok) {
                std::printf("  %s failed (logs in %s)\n", !b.ok ? "the bare step" : "crowdhealth", dir.c_str());
                ok = false;
                break;
            }
            double load[1] = {0};
            if (getloadavg(load, 1) < 1) load[0] = -1;
            bare.push_back(b.msMedian);
            whole.push_back(1e3 * p.cpu / steps);
            fixed.push_back(z.cpu);
            perStep.push_back(1e3 * (p.cpu - z.cpu) / (steps - shortSteps));
            safety.push_back(1e3 * timing.safety / steps);
            metrics.push_back(1e3 * timing.metrics / steps);
            std::printf("%4d  %12.2f  %12.2f  %12.2f  %12.2f  %7.2fx  %7.2fx  %9.3f  %9.3f  %.1f\n", k + 1, bare.back(),
                        whole.back(), fixed.back(), perStep.back(), whole.back() / bare.back(),
                        perStep.back() / bare.back(), safety.back(), metrics.back(), load[0]);
            std::fflush(stdout);
        }
        if (ok) {
            std::printf("process %-16s %6zu   1  median: bare %.2f ms/step, whole process %.2f (%.2fx), marginal "
                        "(fixed %.2f s apart) %.2f (%.2fx); of the whole, safety grid %.3f ms/step, metrics %.3f\n",
                        sc.name, n, median(bare), median(whole), median(whole) / median(bare), median(fixed),
                        median(perStep), median(perStep) / median(bare), median(safety), median(metrics));
            for (const char* f : {"out", "out0", "crowdhealth.log", "crowdhealth0.log"}) fs::remove_all(dir / f);
            fs::remove(file);
        }
    }
    std::error_code ec;
    if (fs::is_empty(dir, ec)) fs::remove_all(dir, ec);
}

std::vector<int> parseList(const std::string& s) {
    std::vector<int> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (!item.empty()) out.push_back(std::stoi(item));
    return out;
}

void usage() {
    std::cout << "crowdhealth-bench — timed benchmark scenes (see docs/performance.md)\n"
                 "  --quick         1k and 10k agents only, few steps (smoke run)\n"
                 "  --large         also the 1M-agent dense SPH crowd\n"
                 "  --threads LIST  thread counts, comma separated (default 1,2)\n"
                 "  --steps N       timed steps per case (default: by size)\n"
                 "  --sizes LIST    crowd sizes of the dense, order, neighbour and output cases, comma separated (default\n"
                 "                  1000,10000,100000; --quick 1000,10000; --large adds 1000000)\n"
                 "  --only TEXT     run only cases whose name contains TEXT (dense, order, social, hall, sf-hall-quickest, neigh,\n"
                 "                  navigation, output, umans, process)\n"
                 "  --csv FILE      also write every row as CSV\n"
                 "  --umans PATH    UMANS' console application for the side-by-side case (default: $CROWDHEALTH_UMANS,\n"
                 "                  else /tmp/umans-ref/build/UMANS-ConsoleApplication-Linux as\n"
                 "                  ../shared/reference/umans/build-umans.sh leaves it; the case is skipped without it)\n"
                 "  --crowdhealth PATH  the crowdhealth program it runs (default: beside this benchmark)\n"
                 "  --umans-reps N  runs of each program, interleaved (default 3; --quick 1)\n"
                 "  --umans-time T  simulated seconds of each run (default 10 = 100 steps; --quick 1)\n"
                 "  --write-umans-scene FILE  write that scene (end_time: --umans-time given before it) and stop\n"
                 "  --process-reps N  runs of the bare step and the program per scene in the process case (default 3)\n"
                 "  --no-fork       run cases in this process (peak memory then accumulates)\n"
                 "  --isa NAME      the hand-vectorised loops' build to run: generic, avx2 or avx512 (default: the best this\n"
                 "                  CPU runs) for social forces' pair loop, the neighbour-list gather, the crowd field's\n"
                 "                  scatter and the safety recorder's cells; the SPH and contact pair sums, UMANS' contact filter and\n"
                 "                  navigation's sampling have no AVX2 build\n"
                 "                  (generic below avx512), the health layer's end of step no AVX-512 build (avx2 from\n"
                 "                  avx2 up). The results are the same bits. Not the side-by-side case's program, nor the\n"
                 "                  process case's, which pick their own.\n"
                 "  --stored-lists  store every neighbour list at each step even where only the per-agent calls read\n"
                 "                  them (by default those lists are gathered agent by agent; the same bits)\n";
}

}  // namespace

int main(int argc, char** argv) {
    bool quick = false, large = false, fork = true;
    std::vector<int> threads = {1, 2};
    int stepsOverride = 0;
    std::string csvPath, only, umansOption, crowdhealthOption;
    int umansReps = 0, processReps = 0;
    double umansTime = 0;
    std::vector<std::size_t> sizesOverride;
    for (int k = 1; k < argc; ++k) {
        const std::string a = argv[k];
        auto next = [&]() -> std::string {
            if (k + 1 >= argc) {
                std::cerr << a << " needs a value\n";
                std::exit(2);
            }
            return argv[++k];
        };
        if (a == "--quick") quick = true;
        else if (a == "--large") large = true;
        else if (a == "--threads") threads = parseList(next());
        else if (a == "--steps") stepsOverride = std::stoi(next());
        else if (a == "--sizes") {
            for (int v : parseList(next())) sizesOverride.push_back(static_cast<std::size_t>(v));
        }
        else if (a == "--csv") csvPath = next();
        else if (a == "--only") only = next();
        else if (a == "--no-fork") fork = false;
        else if (a == "--stored-lists") gStoredLists = true;
        else if (a == "--isa") {
            // The same path numbers in both: 0 generic, 1 AVX2, 2 AVX-512.
            const std::string isa = next();
            const int path = isa == "generic" ? 0 : isa == "avx2" ? 1 : isa == "avx512" ? 2 : -1;
            if (path < 0) {
                std::cerr << "--isa: expected generic, avx2 or avx512, not '" << isa << "'\n";
                return 2;
            }
            // The dense pair sums and UMANS' contact filter have no AVX2 build: generic below
            // AVX-512. The health layer's end of step has no AVX-512 build: AVX2 from AVX2 up.
            const int wide = path == 2 ? 1 : 0;
            const int health = path >= 1 ? 1 : 0;
            if (!ch::SocialForcesAvoidance::setPairLoopPath(path) || !ch::NeighbourLists::setGatherPath(path) ||
                !ch::setCrowdFieldPath(path) || !ch::pairs::setPath(wide) || !ch::setNearEntriesPath(wide) ||
                !ch::HealthLayer::setEndStepPath(health) || !ch::setNavigationSamplePath(wide)) {
                std::cerr << "--isa " << isa << ": this CPU does not run it\n";
                return 2;
            }
        }
        else if (a == "--umans") umansOption = next();
        else if (a == "--crowdhealth") crowdhealthOption = next();
        else if (a == "--umans-reps") umansReps = std::stoi(next());
        else if (a == "--umans-time") umansTime = std::stod(next());
        else if (a == "--process-reps") processReps = std::stoi(next());
        else if (a == "--write-umans-scene") {
            // The side-by-side scene as a file, to profile or run by hand; nothing else is run.
            const std::string file = next();
            writeUmansScenario(file, 10000, umansTime > 0 ? umansTime : 10.0);
            std::printf("wrote %s\n", file.c_str());
            return 0;
        }
        else if (a == "--help" || a == "-h") {
            usage();
            return 0;
        } else {
            std::cerr << "unknown option " << a << "\n";
            usage();
            return 2;
        }
    }
    if (threads.empty()) threads = {1};

    std::vector<std::size_t> sizes = quick ? std::vector<std::size_t>{1000, 10000}
                                           : std::vector<std::size_t>{1000, 10000, 100000};
    if (large && !quick) sizes.push_back(1000000);
    if (!sizesOverride.empty()) sizes = sizesOverride;
    auto stepsFor = [&](std::size_t n, int& warm, int& steps) {
        if (quick) { warm = 2; steps = 5; }
        else if (n <= 1000) { warm = 10; steps = 41; }
        else if (n <= 10000) { warm = 5; steps = 21; }
        else if (n <= 100000) { warm = 3; steps = 11; }
        else { warm = 2; steps = 5; }
        if (stepsOverride > 0) steps = stepsOverride;
    };
    auto wanted = [&](const std::string& name) { return only.empty() || name.find(only) != std::string::npos; };

    std::vector<Result> results;
    auto report = [&](const Result& r) {
        if (!r.ok) {
            std::printf("  (case failed)\n");
            return;
        }
        results.push_back(r);
        if (std::strcmp(r.kind, "output") == 0) {
            std::printf("%-16s %8.0f %3.0f  %9.3f ms/frame (min %8.3f)  %9.3g MB/frame  VmHWM %7.1f MiB\n", r.scene,
                        r.n, r.threads, r.msMedian, r.msMin, r.extra1, r.hwmMiB);
        } else if (std::strcmp(r.kind, "navigation") == 0) {
            std::printf("%-16s %8.0f %3.0f  grid %7.1f ms + 10 fields %7.1f ms = %7.1f ms (best; median %7.1f)  "
                        "sample (direction+distance) %6.1f ns/query  VmHWM %7.1f MiB  %016llx\n",
                        r.scene, r.n, r.threads, r.extra3, r.extra1, r.msMin, r.msMedian, r.extra2, r.hwmMiB,
                        static_cast<unsigned long long>(r.hash));
        } else if (std::strcmp(r.kind, "neighbours") == 0) {
            std::printf("%-16s %8.0f %3.0f  build %8.3f ms  query %7.1f ns/agent (%5.1f hits)  VmHWM %7.1f MiB\n",
                        r.scene, r.n, r.threads, r.extra1, r.extra2, r.pairsPerAgent, r.hwmMiB);
        } else {
            std::printf("%-16s %8.0f %3.0f  %9.3f  %9.3f  %12.3g  %8.1f  %7.3f  %5.0f%%  %016llx\n", r.scene, r.n,
                        r.threads, r.msMedian, r.msMin, r.agentStepsPerSec, r.hwmMiB, r.limitMs,
                        r.limitMs > 0 ? 100.0 * r.limitMs / r.msMedian : 0.0, static_cast<unsigned long long>(r.hash));
        }
        std::fflush(stdout);
    };

    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) < 0) load[0] = -1;
    std::printf("load average at start: %.2f %.2f %.2f on %d cores (other work on the machine skews timings)\n",
                load[0], load[1], load[2], omp_get_num_procs());
    static const char* const kIsa[] = {"generic", "avx2", "avx512"};
    std::printf("hand-vectorised loops: social forces' pair loop %s, neighbour-list gather %s, SPH and contact pair "
                "sums %s, UMANS' contact filter %s, crowd field's scatter and safety cells %s, health layer's end of step %s, "
                "navigation's sampling %s (--isa)\n",
                kIsa[ch::SocialForcesAvoidance::pairLoopPath()], kIsa[ch::NeighbourLists::gatherPath()],
                kIsa[2 * ch::pairs::path()], kIsa[2 * ch::nearEntriesPath()], kIsa[ch::crowdFieldPath()],
                kIsa[ch::HealthLayer::endStepPath()], kIsa[2 * ch::navigationSamplePath()]);
    std::printf("neighbour lists: %s\n", gStoredLists ? "stored at every step (--stored-lists)"
                                                      : "gathered agent by agent where no component reads them stored");
    std::printf("%-16s %8s %3s  %9s  %9s  %12s  %8s  %7s  %6s  %s\n", "scene", "agents", "thr", "ms/step", "min ms",
                "agent-step/s", "HWM MiB", "limit", "of lim", "state hash");
    if (wanted("dense"))
        for (std::size_t n : sizes)
            for (int t : threads) {
                Case c{"dense-sph", n, t, 0, 0};
                stepsFor(n, c.warmup, c.steps);
                report(inChild([&] { return runSimCase(c); }, fork));
            }
    if (wanted("order"))
        // Agent order: the dense crowd in lattice order without re-ordering ("dense-sph-unordered"),
        // and listed in random order, re-ordered in grid order every Simulation::kReorderInterval
        // steps (the default) or never ("-unordered").
        for (std::size_t n : sizes)
            for (const char* kind : {"dense-sph-unordered", "dense-sph-shuffled", "dense-sph-shuffled-unordered"}) {
                if (n < 100000) continue;
                Case c{kind, n, 1, 0, 0};
                stepsFor(n, c.warmup, c.steps);
                report(inChild([&] { return runSimCase(c); }, fork));
            }
    if (wanted("social"))
        for (int t : threads) {
            Case c{"social-forces", 10000, t, 0, 0};
            stepsFor(10000, c.warmup, c.steps);
            report(inChild([&] { return runSimCase(c); }, fork));
        }
    // Navigation's share of a step: the same hall without navigation, along distance fields to
    // the same goals, and leaving by the quickest of its two exits (--only hall: all three).
    for (const char* kind : {"sf-hall", "sf-hall-nav", "sf-hall-quickest"})
        if (wanted("social") || wanted(kind))
            for (int t : threads) {
                Case c{kind, 10000, t, 0, 0};
                stepsFor(10000, c.warmup, c.steps);
                report(inChild([&] { return runSimCase(c); }, fork));
            }
    if (wanted("neigh"))
        for (std::size_t n : sizes)
            for (double radius : {1.0, 5.0}) {
                if (radius > 2 && n > 100000) continue;
                Case c{"neighbours", n, 1, 0, 0};
                stepsFor(n, c.warmup, c.steps);
                report(inChild([&] { return runNeighbourCase(c, radius); }, fork));
            }

    if (wanted("navigation")) {
        std::printf("\nnavigation: walkable grid + 10 distance fields, one thread (cells = grid cells)\n");
        report(inChild([&] { return runNavigationCase(quick ? 1 : 3); }, fork));
    }

    if (wanted("output")) {
        // One frame of the largest crowd of the run (100k agents; --quick: 10k).
        const std::size_t n = sizes[std::min<std::size_t>(2, sizes.size() - 1)];
        const int reps = quick ? 3 : 10;
        std::printf("\noutput cost per coarse step (dense crowd after one step, 1 thread; mean ms per frame "
                    "including the flush, MB per frame)\n");
        for (const char* what :
             {"metrics row", "  density h=1", "  crowd field", "safety record", "bin frame", "bin+v frame", "txt frame"})
            report(inChild([&] { return runOutputCase(what, n, reps); }, fork));
    }

    if (wanted("umans")) {
        std::printf("\nvs-umans: UMANS 1.x and crowdhealth side by side, whole processes, one thread, interleaved; "
                    "cpu = user + system seconds of the process, ratio = UMANS / ours\n");
        const std::string umans = findUmans(umansOption);
        if (umans.empty()) {
            std::printf("vs-umans: skipped, UMANS not found (build it with ../shared/reference/umans/build-umans.sh, "
                        "or give --umans PATH)\n");
        } else {
            const Result r = runUmansCase(umans, findCrowdHealth(crowdhealthOption), 10000,
                                          umansTime > 0 ? umansTime : quick ? 1.0 : 10.0,
                                          umansReps > 0 ? umansReps : quick ? 1 : 3);
            if (r.ok) {
                results.push_back(r);
                std::printf("vs-umans       %8.0f %3.0f  UMANS %7.1f ms/step cpu, ours %7.1f ms/step cpu (min %.1f): "
                            "median ratio %.2fx cpu, %.2fx wall\n",
                            r.n, r.threads, r.extra1, r.msMedian, r.msMin, r.extra2, r.extra3);
            }
        }
        std::fflush(stdout);
    }

    if (wanted("process")) {
        std::printf("\nprocess: the program as users run it (metrics, safety recorder, verdict, summary; no "
                    "trajectories) against the bare step, CPU ms per fine step, one thread; fixed = the program "
                    "stopped at 0.1 s (loading, first records, outputs, one coarse step); marginal = (whole - fixed) "
                    "/ the steps between; safety, metric = the whole run's safety grid and metrics rows, wall ms per "
                    "fine step, as its --timing gives them\n");
        runProcessCases(findCrowdHealth(crowdhealthOption), 10000, processReps > 0 ? processReps : quick ? 1 : 3, quick,
                        fork);
        std::fflush(stdout);
    }

    // Phase breakdown (mean ms per step over the timed steps).
    std::printf("\nphase breakdown (mean ms per step)\n%-16s %8s %3s", "scene", "agents", "thr");
    for (std::size_t p = 0; p < Simulation::kPhases; ++p)
        std::printf(" %11s", Simulation::phaseName(static_cast<Simulation::Phase>(p)));
    std::printf(" %11s\n", "other");
    for (const Result& r : results) {
        if (std::strcmp(r.kind, "step") != 0) continue;
        std::printf("%-16s %8.0f %3.0f", r.scene, r.n, r.threads);
        for (double ms : r.phaseMs) std::printf(" %11.3f", ms);
        std::printf(" %11.3f\n", r.otherMs);
    }
    std::printf("other = the step's time outside the phases above (mean step - their sum): the health layer's "
                "endStep (crush, injuries, falls, heading change), state swaps, the schedule\n");
    // Navigation's share of a 10k step (issue 20): what a hall with navigation spends in the
    // "preferred" and "removal" phases (directions, arrivals, exit choices, leaving) beyond the
    // same hall without it, with the same threads.
    auto navigationPhases = [](const Result& r) {
        return r.phaseMs[static_cast<std::size_t>(Simulation::Phase::Preferred)] +
               r.phaseMs[static_cast<std::size_t>(Simulation::Phase::Removal)];
    };
    for (const Result& r : results) {
        if (std::strcmp(r.kind, "step") != 0 || std::strncmp(r.scene, "sf-hall-", 8) != 0) continue;
        for (const Result& bare : results)
            if (std::strcmp(bare.kind, "step") == 0 && std::strcmp(bare.scene, "sf-hall") == 0 &&
                bare.threads == r.threads && r.msMedian > 0) {
                const double nav = navigationPhases(r) - navigationPhases(bare);
                std::printf("navigation of %-16s %3.0f thr: %.3f ms per step, %.1f %% of its median step "
                            "(preferred + removal beyond sf-hall's)\n",
                            r.scene, r.threads, nav, 100.0 * nav / r.msMedian);
            }
    }
    std::printf("\nlimit = tight SPH kernel loop (density + pressure force) over precomputed neighbour lists "
                "for the same agents and threads; pairs/agent = ordered pairs within h per agent\n");
    for (const Result& r : results)
        if (r.limitMs > 0)
            std::printf("%-16s %8.0f %3.0f  pairs/agent %5.1f  kernel %8.3g pairs/s  limit %8.3f ms\n", r.scene, r.n,
                        r.threads, r.pairsPerAgent, r.extra1, r.limitMs);

    if (!csvPath.empty()) {
        std::ofstream csv(csvPath);
        csv << "kind,scene,agents,threads,ms_median,ms_min,ms_max,agent_steps_per_s,vmhwm_mib,vmrss_mib";
        for (std::size_t p = 0; p < Simulation::kPhases; ++p)
            csv << ",ms_" << Simulation::phaseName(static_cast<Simulation::Phase>(p));
        csv << ",ms_other,limit_ms,pairs_per_agent,extra1,extra2,state_hash\n";
        for (const Result& r : results) {
            csv << r.kind << ',' << r.scene << ',' << r.n << ',' << r.threads << ',' << r.msMedian << ',' << r.msMin
                << ',' << r.msMax << ',' << r.agentStepsPerSec << ',' << r.hwmMiB << ',' << r.rssMiB;
            for (double ms : r.phaseMs) csv << ',' << ms;
            csv << ',' << r.otherMs;
            char hash[20];
            std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(r.hash));
            csv << ',' << r.limitMs << ',' << r.pairsPerAgent << ',' << r.extra1 << ',' << r.extra2 << ',' << hash
                << '\n';
        }
        std::printf("\nwrote %s\n", csvPath.c_str());
    }
    return 0;
}
