// Venues (docs/navigation.md): agents walk round corners and wall ends along their paths, exit
// choice rules choose as defined, closing an exit re-routes everyone heading there, checkpoints
// respect capacity and dwell time, sources place agents clear of walls and others, the result does
// not depend on the thread count, and bad venue input gets file:line errors.
#define BOOST_TEST_MODULE navigation_venue
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"
#include "crowdhealth/navigation/navigation.h"
#include "scenario_files.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>

using namespace ch;
namespace fs = std::filesystem;
using test::Loaded;
using test::load;
using test::scratch;

namespace {

/// Social forces as UMANS' SocialForces.xml, with UMANS' contact.
const char* kPolicy = R"(
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
      <costfunction name="SocialForcesAvoidance" range="5"/>
      <costfunction name="GoalReachingForce"/>
    </Policy>
  </Policies>)";

/// A wall segment as a two-point obstacle.
std::string wall(double x0, double y0, double x1, double y1) {
    std::ostringstream o;
    o << "<Obstacle><Point x=\"" << x0 << "\" y=\"" << y0 << "\"/><Point x=\"" << x1 << "\" y=\"" << y1 << "\"/></Obstacle>\n";
    return o.str();
}

std::string simulation(const std::string& world, const std::string& agents, double end = 120,
                       const std::string& extra = "") {
    return "<Simulation delta_time=\"0.1\" end_time=\"" + std::to_string(end) + "\">\n" + world + kPolicy +
           "\n<Agents>\n" + agents + "</Agents>\n" + extra + "</Simulation>\n";
}

/// A row of agents on a journey.
std::string agentsAt(const std::vector<Vec2>& places, const std::string& journey, double radius = 0.25) {
    std::ostringstream o;
    for (const Vec2& p : places)
        o << "<Agent rad=\"" << radius << "\" pref_speed=\"1.3\" max_speed=\"1.6\" journey=\"" << journey
          << "\"><pos x=\"" << p.x() << "\" y=\"" << p.y() << "\"/><Policy id=\"0\"/></Agent>\n";
    return o.str();
}

struct Outcome {
    std::map<AgentId, std::string> exitOf;   ///< exit each agent left by
    std::map<AgentId, double> timeOf;
    double maxPenetration = 0;               ///< m, deepest wall overlap seen
    std::size_t left = 0;                    ///< agents still in the world at the end
    std::vector<Navigation::Service> services;
    std::vector<std::vector<Vec2>> frames;   ///< positions after every coarse step (in id order)
};

Outcome runScenario(const ScenarioSpec& spec, int threads = 1) {
    Simulation sim(spec);
    sim.setThreads(threads);
    Outcome o;
    while (!sim.finished()) {
        sim.stepCoarse();
        o.maxPenetration = std::max(o.maxPenetration, sim.maxWallPenetration());
        std::map<AgentId, Vec2> byId;
        for (std::size_t i = 0; i < sim.agents().size(); ++i) byId[sim.agents().id[i]] = sim.agents().pos[i];
        std::vector<Vec2> frame;
        for (const auto& [id, p] : byId) frame.push_back(p);
        o.frames.push_back(std::move(frame));
    }
    for (const Evacuation& e : sim.evacuations()) {
        o.exitOf[e.id] = e.exit >= 0 ? spec.venue.targets[static_cast<std::size_t>(e.exit)].name : "";
        o.timeOf[e.id] = e.time;
    }
    o.left = sim.agents().size() + sim.pending();
    if (sim.navigation()) o.services = sim.navigation()->services();
    return o;
}

// ---- scenes --------------------------------------------------------------------------------

/// An L-shaped corridor 2 m wide (RiMEA test 6's shape): east along y ∈ [0, 2] to x = 10, then
/// north along x ∈ [8, 10] to y = 12, where the exit spans the corridor.
std::string lCorridor(bool navigation, int agents) {
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"11\" ymin=\"-1\" ymax=\"13\">\n";
    if (navigation) world += "<Navigation/>\n";
    world += wall(0, 0, 10, 0) + wall(10, 0, 10, 12) + wall(0, 2, 8, 2) + wall(8, 2, 8, 12) + wall(0, 0, 0, 2);
    world += "<Exit id=\"top\" xmin=\"8\" xmax=\"10\" ymin=\"11.5\" ymax=\"12\"/>\n";
    world += "<Journey id=\"out\" leave_by=\"top\"/>\n</World>\n";
    std::vector<Vec2> places;
    for (int k = 0; k < agents; ++k) places.push_back(Vec2(0.6 + 0.8 * (k / 2), 0.55 + 0.9 * (k % 2)));
    return simulation(world, agentsAt(places, "out"));
}

/// A square room 20 m × 20 m with a 1.2 m exit in the middle of each wall.
std::string fourExits(const std::string& exitSet, const std::string& agents, const std::string& schedule = "",
                      double end = 150) {
    std::string world = "<World type=\"Planar\" xmin=\"-2\" xmax=\"22\" ymin=\"-2\" ymax=\"22\">\n<Navigation/>\n";
    // Each wall in two pieces leaving a 1.2 m door at its middle.
    world += wall(0, 0, 9.4, 0) + wall(10.6, 0, 20, 0) + wall(0, 20, 9.4, 20) + wall(10.6, 20, 20, 20);
    world += wall(0, 0, 0, 9.4) + wall(0, 10.6, 0, 20) + wall(20, 0, 20, 9.4) + wall(20, 10.6, 20, 20);
    world += "<Exit id=\"south\" xmin=\"9.4\" xmax=\"10.6\" ymin=\"-1\" ymax=\"-0.3\"/>\n";
    world += "<Exit id=\"north\" xmin=\"9.4\" xmax=\"10.6\" ymin=\"20.3\" ymax=\"21\"/>\n";
    world += "<Exit id=\"west\" xmin=\"-1\" xmax=\"-0.3\" ymin=\"9.4\" ymax=\"10.6\"/>\n";
    world += "<Exit id=\"east\" xmin=\"20.3\" xmax=\"21\" ymin=\"9.4\" ymax=\"10.6\"/>\n";
    world += exitSet + "\n<Journey id=\"out\" leave_by=\"all\"/>\n</World>\n";
    return simulation(world, agents, end, schedule.empty() ? "" : "<Schedule>" + schedule + "</Schedule>\n");
}

std::vector<Vec2> grid(double x0, double y0, int nx, int ny, double step) {
    std::vector<Vec2> out;
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) out.push_back(Vec2(x0 + step * i, y0 + step * j));
    return out;
}

}  // namespace

// ---- paths round corners ----------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(crowd_walks_round_the_corner_of_an_l_corridor) {
    const Loaded l = load("l.xml", lCorridor(true, 16));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.exitOf.size() == 16u);
    BOOST_TEST(o.left == 0u);
    // No wall penetration beyond contact: a disc may be pressed into a wall by a few centimetres.
    BOOST_TEST(o.maxPenetration < 0.05);
    for (const auto& [id, t] : o.timeOf) BOOST_TEST(t < 60.0);
}

BOOST_AUTO_TEST_CASE(without_navigation_the_same_crowd_walks_into_the_inner_wall) {
    // The control: straight at the exit, nobody reaches it (the inner wall is in the way).
    const Loaded l = load("l-straight.xml", lCorridor(false, 6));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    ScenarioSpec spec = *l.spec;
    spec.endTime = 40;
    const Outcome o = runScenario(spec);
    BOOST_TEST(o.exitOf.empty());
}

BOOST_AUTO_TEST_CASE(navigation_columns_are_kept_only_with_navigation) {
    // Without a venue the store keeps no navigation columns (53 bytes per agent); with one, they
    // follow the agents through arrivals, removals at the exits and re-orderings.
    auto columnSizes = [](const AgentStore& a) {
        return std::vector<std::size_t>{a.journey.size(), a.stage.size(),  a.target.size(),   a.navDistance.size(),
                                         a.navDir.size(),  a.holdUntil.size(), a.navFlags.size(), a.nextChoice.size()};
    };
    std::ostringstream plain;
    for (int k = 0; k < 12; ++k)
        plain << "<Agent rad=\"0.25\" remove_at_goal=\"true\"><pos x=\"" << k << "\" y=\"0\"/><goal x=\"" << k
              << "\" y=\"3\"/><Policy id=\"0\"/></Agent>\n";
    const Loaded l = load("no-venue.xml", simulation("<World type=\"Infinite\"/>\n", plain.str(), 20));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    Simulation sim(*l.spec);
    sim.setReorderInterval(1);
    BOOST_TEST(!sim.agents().navigationColumns);
    while (!sim.finished()) {
        sim.stepCoarse();
        for (const std::size_t n : columnSizes(sim.agents())) BOOST_TEST_REQUIRE(n == 0u);
    }
    BOOST_TEST(sim.evacuations().size() == 12u);

    const Loaded v = load("venue-columns.xml", fourExits(R"(<ExitSet id="all" choice="nearest" exits="south north west east"/>)",
                                                         agentsAt(grid(4, 4, 6, 6, 2.0), "out"), "", 30));
    BOOST_REQUIRE_MESSAGE(v.spec, v.messages);
    Simulation venue(*v.spec);
    venue.setReorderInterval(1);
    BOOST_TEST(venue.agents().navigationColumns);
    while (!venue.finished()) {
        venue.stepCoarse();
        for (const std::size_t n : columnSizes(venue.agents())) BOOST_TEST_REQUIRE(n == venue.agents().size());
    }
    BOOST_TEST(venue.evacuations().size() > 0u);
}

BOOST_AUTO_TEST_CASE(agents_walk_round_the_end_of_a_long_wall_to_a_goal_behind_it) {
    // Infinite world, a 16 m wall across the way; plain goals (no journey) navigate too.
    std::string world = "<World type=\"Infinite\">\n<Navigation/>\n" + wall(-8, 0, 8, 0) + "</World>\n";
    std::ostringstream agents;
    for (int k = 0; k < 6; ++k)
        agents << "<Agent rad=\"0.25\" remove_at_goal=\"true\" goal_radius=\"0.5\"><pos x=\"" << -2.5 + k << "\" y=\"-4\"/>"
               << "<goal x=\"0\" y=\"4\"/><Policy id=\"0\"/></Agent>\n";
    const Loaded l = load("wall.xml", simulation(world, agents.str(), 80));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.timeOf.size() == 6u);
    BOOST_TEST(o.maxPenetration < 0.05);
    // The way round (about 2 × √(8² + 4²) ≈ 17.9 m at 1.3 m/s) takes at least 13 s.
    for (const auto& [id, t] : o.timeOf) BOOST_TEST(t > 13.0);
}

BOOST_AUTO_TEST_CASE(every_agent_is_sampled_at_its_own_place_in_an_update) {
    // Navigation::update samples the fields in runs of agents (each position probed once for its
    // prefetch and its sample). Whatever the run boundaries and the thread count, every agent
    // must get the direction and the remaining distance of its own place: the values activation
    // computes for one agent alone. 37 agents (not a whole number of runs), on open floor and
    // beside the wall (the fields' general rules), some with a goal behind the wall and some in
    // front of it.
    std::string world = "<World type=\"Infinite\">\n<Navigation/>\n" + wall(-8, 0, 8, 0) + "</World>\n";
    std::ostringstream agents;
    for (int k = 0; k < 37; ++k)
        agents << "<Agent rad=\"0.25\"><pos x=\"" << -9.0 + 0.5 * k << "\" y=\"" << -0.3 - 0.11 * (k % 9) << "\"/>"
               << "<goal x=\"" << (k % 3 ? 0.0 : 6.0) << "\" y=\"" << (k % 2 ? 4.0 : -6.0) << "\"/><Policy id=\"0\"/></Agent>\n";
    const Loaded l = load("runs.xml", simulation(world, agents.str(), 10));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const ScenarioSpec& spec = *l.spec;
    const World w(spec.world, spec.obstacles);
    Navigation nav(spec, w);
    BOOST_REQUIRE(nav.grid() != nullptr);
    // `moved`: every agent as activated at its place 1 m north-east of its spec's place (sampled
    // one by one); `store`: activated at the spec's place, then moved there and updated.
    AgentStore store, moved;
    const Vec2 shift(0.7, 0.7);
    for (std::size_t i = 0; i < spec.agents.size(); ++i) {
        AgentSpec s = spec.agents[i];
        store.add(s, 0);
        nav.activated(store, i, s, 0.0);
        s.position += shift;
        moved.add(s, 0);
        nav.activated(moved, i, s, 0.0);
    }
    for (std::size_t i = 0; i < store.size(); ++i) store.pos[i] += shift;
    nav.update(store, 0.1, spec.seed);
    for (std::size_t i = 0; i < store.size(); ++i) {
        BOOST_TEST_REQUIRE(store.target[i] >= 0);
        BOOST_TEST(store.navDistance[i] == moved.navDistance[i], "agent " << i);
        BOOST_TEST((store.navDir[i] == moved.navDir[i]), "agent " << i);
        BOOST_TEST(std::abs(store.navDir[i].norm() - 1.0) < 1e-12, "agent " << i);
    }
}

// ---- exit choice ------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(nearest_takes_the_exit_with_the_shortest_path) {
    // Agents near the west and the east walls: each leaves by the exit on its side.
    std::vector<Vec2> places = grid(2, 5, 2, 5, 2.0);
    for (const Vec2& p : grid(16, 5, 2, 5, 2.0)) places.push_back(p);
    const Loaded l = load("nearest.xml", fourExits("<ExitSet id=\"all\" exits=\"south north west east\" choice=\"nearest\"/>",
                                                   agentsAt(places, "out")));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) BOOST_TEST(exit == (id < 10 ? "west" : "east"), "agent " << id);
}

BOOST_AUTO_TEST_CASE(fixed_takes_its_exit_from_anywhere) {
    const std::vector<Vec2> places = grid(3, 3, 4, 4, 4.0);
    const Loaded l = load("fixed.xml", fourExits("<ExitSet id=\"all\" exits=\"south north west east\" choice=\"fixed\" fixed=\"north\"/>",
                                                 agentsAt(places, "out")));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) BOOST_TEST(exit == "north");
}

BOOST_AUTO_TEST_CASE(weighted_draws_in_proportion_from_the_seed) {
    // 3 : 1 between west and east for 120 agents spread over the room.
    const std::vector<Vec2> places = grid(2, 2, 12, 10, 1.5);
    const std::string xml = fourExits(
        "<ExitSet id=\"all\" exits=\"west east\" choice=\"weighted\" weights=\"3 1\"/>", agentsAt(places, "out"), "", 400);
    const Loaded l = load("weighted.xml", xml);
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    int west = 0;
    for (const auto& [id, exit] : o.exitOf) west += exit == "west";
    // Binomial(120, 0.75): mean 90, sd 4.7; ± 3.5 sd.
    BOOST_TEST(west >= 74);
    BOOST_TEST(west <= 106);
    // The same seed draws the same exits; another seed draws others.
    const Outcome again = runScenario(*l.spec);
    BOOST_TEST((again.exitOf == o.exitOf));
    ScenarioSpec other = *l.spec;
    other.seed = 7;
    BOOST_TEST((runScenario(other).exitOf != o.exitOf));
}

BOOST_AUTO_TEST_CASE(quickest_spreads_a_crowd_over_a_farther_exit) {
    // 60 agents packed by the west exit: with nearest they all queue there; with quickest some
    // walk to the north or south exit and the room empties sooner.
    const std::vector<Vec2> places = grid(1, 6.5, 6, 10, 0.7);
    auto run = [&](const std::string& rule) {
        const Loaded l = load("quickest-" + rule + ".xml",
                              fourExits("<ExitSet id=\"all\" exits=\"west north south\" choice=\"" + rule + "\"/>",
                                        agentsAt(places, "out")));
        BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
        return runScenario(*l.spec);
    };
    const Outcome nearest = run("nearest"), quickest = run("quickest");
    BOOST_REQUIRE(nearest.exitOf.size() == places.size());
    BOOST_REQUIRE(quickest.exitOf.size() == places.size());
    int elsewhere = 0;
    for (const auto& [id, exit] : nearest.exitOf) BOOST_TEST(exit == "west");
    for (const auto& [id, exit] : quickest.exitOf) elsewhere += exit != "west";
    BOOST_TEST(elsewhere >= 10);
    BOOST_TEST(elsewhere <= 50);
    double lastNearest = 0, lastQuickest = 0, meanNearest = 0, meanQuickest = 0;
    for (const auto& [id, t] : nearest.timeOf) lastNearest = std::max(lastNearest, t), meanNearest += t / 60.0;
    for (const auto& [id, t] : quickest.timeOf) lastQuickest = std::max(lastQuickest, t), meanQuickest += t / 60.0;
    BOOST_TEST_MESSAGE("quickest: " << elsewhere << " of 60 elsewhere; last out " << lastQuickest << " s (nearest "
                                    << lastNearest << " s), mean " << meanQuickest << " s (" << meanNearest << " s)");
    // Quickest is each person's own estimate, not a plan for the crowd: the room empties sooner
    // (measured 24.4 s against 30.1 s), though the mean time out need not fall (13.5 s against 13.1 s).
    BOOST_TEST(lastQuickest < 0.9 * lastNearest);
}

BOOST_AUTO_TEST_CASE(quickest_choice_is_the_least_walking_time_plus_wait) {
    // The rule as docs/navigation.md defines it, checked for every choice made in 12 s: 144
    // people spread over the room choose among west, north and south every second, without
    // hysteresis. Before each step, for each person whose choice falls due, the expected exit is
    // worked out from the definition alone: the path length d_e to each exit along its field
    // (Navigation::distanceTo at the person's place), the people heading to e whose own remaining
    // path is shorter (n_e, from everyone's place and exit before the step), and
    //     cost_e = d_e / v + n_e / (q · w_e),
    // the cheapest exit (the first in the set's order on a tie; the current one kept when it is as
    // cheap). The exit the person heads for after the step must be that one.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> jitter(-0.3, 0.3);
    std::vector<Vec2> places;
    for (const Vec2& p : grid(1.5, 1.5, 12, 12, 1.5)) places.push_back(p + Vec2(jitter(rng), jitter(rng)));
    const Loaded l = load("quickest-rule.xml",
                          fourExits("<ExitSet id=\"all\" exits=\"west north south\" choice=\"quickest\" "
                                    "interval=\"1\" hysteresis=\"0\" flow_capacity=\"0.6\"/>",
                                    agentsAt(places, "out"), "", 12));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const ScenarioSpec& spec = *l.spec;
    const std::vector<int> exits = {spec.venue.targetIndex("west"), spec.venue.targetIndex("north"),
                                    spec.venue.targetIndex("south")};
    Simulation sim(spec);
    sim.stepCoarse();  // arrivals: everyone's first choice
    const Navigation& nav = *sim.navigation();
    std::size_t checked = 0, switched = 0, wrong = 0;
    while (!sim.finished()) {
        const AgentStore& a = sim.agents();
        const double t = sim.time();
        // Everyone's remaining path to the exit it heads for, before the step.
        std::vector<std::vector<double>> heading(spec.venue.targets.size());
        for (std::size_t j = 0; j < a.size(); ++j)
            if (a.target[j] >= 0) heading[static_cast<std::size_t>(a.target[j])].push_back(nav.distanceTo(a.target[j], a.pos[j]));
        std::map<AgentId, int> expected, before;
        for (std::size_t i = 0; i < a.size(); ++i) {
            if (t + 1e-9 < a.nextChoice[i]) continue;
            const double v = std::max(0.1, a.prefSpeed[i]);
            double best = std::numeric_limits<double>::infinity(), current = best;
            int bestExit = -1;
            for (const int e : exits) {
                const double d = nav.distanceTo(e, a.pos[i]);
                std::size_t ahead = 0;
                for (const double other : heading[static_cast<std::size_t>(e)]) ahead += other < d ? 1 : 0;
                const double cost = d / v + static_cast<double>(ahead) / (0.6 * nav.width(e));
                if (e == a.target[i]) current = cost;
                if (cost < best) best = cost, bestExit = e;
            }
            expected[a.id[i]] = best < current ? bestExit : a.target[i];
            before[a.id[i]] = a.target[i];
        }
        const double t0 = sim.time();
        sim.stepCoarse();
        BOOST_REQUIRE_CLOSE(sim.time() - t0, 0.1, 1e-6);  // one fine step: the check above covers it
        for (std::size_t i = 0; i < sim.agents().size(); ++i) {
            const auto it = expected.find(sim.agents().id[i]);
            if (it == expected.end()) continue;
            ++checked;
            switched += it->second != before[it->first];
            if (sim.agents().target[i] != it->second) ++wrong;
        }
    }
    BOOST_TEST_MESSAGE("quickest rule: " << checked << " choices checked, " << switched << " switches");
    BOOST_TEST(checked >= 1000u);
    BOOST_TEST(switched >= 20u);  // the choices are not all "stay"
    BOOST_TEST(wrong == 0u);
}

BOOST_AUTO_TEST_CASE(nearest_is_decided_once_and_again_only_when_an_exit_opens_or_closes) {
    // docs/navigation.md: a nearest choice is made when the agent reaches the exit stage and
    // again at every exit event, not re-decided as it walks (only quickest choices fall due every
    // interval). Driven by hand: an agent activated by the west wall heads west; moved beside the
    // east exit it keeps heading west through updates long past any interval; when north (not
    // one of its exits) closes, everyone re-chooses and it heads east.
    const Loaded l = load("nearest-once.xml", fourExits("<ExitSet id=\"all\" exits=\"west east\" choice=\"nearest\"/>",
                                                        agentsAt({Vec2(3, 10)}, "out"),
                                                        "<CloseExit exit=\"north\" time=\"8\"/>"));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const ScenarioSpec& spec = *l.spec;
    const World w(spec.world, spec.obstacles);
    Navigation nav(spec, w);
    AgentStore store;
    store.add(spec.agents[0], 0);
    nav.activated(store, 0, spec.agents[0], 0.0);
    const int west = spec.venue.targetIndex("west"), east = spec.venue.targetIndex("east");
    BOOST_TEST_REQUIRE(store.target[0] == west);
    store.pos[0] = Vec2(17, 10);
    for (double t = 0.1; t < 7.95; t += 0.1) {
        nav.update(store, t, spec.seed);
        BOOST_TEST_REQUIRE(store.target[0] == west, "t = " << t);
    }
    nav.update(store, 8.0, spec.seed);
    BOOST_TEST(store.target[0] == east);
}

BOOST_AUTO_TEST_CASE(closing_an_exit_reroutes_everyone_heading_there) {
    // Everyone near the north wall; north and east close at 3 s, before anyone gets there.
    const std::vector<Vec2> places = grid(5, 15, 6, 3, 2.0);
    const Loaded l = load("close.xml", fourExits("<ExitSet id=\"all\" exits=\"south north west east\" choice=\"nearest\"/>",
                                                 agentsAt(places, "out"),
                                                 "<CloseExit exit=\"north\" time=\"3\"/><CloseExit exit=\"east\" time=\"3\"/>", 200));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.left == 0u);  // nobody is left stuck
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) BOOST_TEST((exit == "west" || exit == "south"), "agent " << id << " left by " << exit);
}

namespace {
/// agentsAt's agents in social groups of `size` consecutive agents (groups "g0", "g1", …).
std::string inGroups(const std::string& agents, int size) {
    std::string out;
    std::size_t at = 0;
    for (int k = 0;; ++k) {
        const std::size_t next = agents.find("<Agent ", at);
        if (next == std::string::npos) break;
        out += agents.substr(at, next - at) + "<Agent group=\"g" + std::to_string(k / size) + "\" ";
        at = next + 7;
    }
    return out + agents.substr(at);
}

/// Per social group of the scenario, the exits its members left by from time `from` on.
std::map<std::string, std::set<std::string>> exitsByGroup(const ScenarioSpec& spec, const Outcome& o, double from = 0) {
    std::map<std::string, std::set<std::string>> out;
    for (const AgentSpec& a : spec.agents)
        if (a.groupIndex >= 0 && o.exitOf.count(a.id) && o.timeOf.at(a.id) >= from)
            out[spec.groups[static_cast<std::size_t>(a.groupIndex)]].insert(o.exitOf.at(a.id));
    return out;
}
}  // namespace

BOOST_AUTO_TEST_CASE(closing_an_exit_reroutes_social_groups_as_one_by_the_quickest_rule) {
    // As above, in pairs and choosing the quickest exit: a group's members choose after each
    // other, the first by the rule and the second taking its exit (navigation.h), so every pair
    // re-routes, and each leaves by one exit. Half of the crowd are groups, half walk alone.
    const std::vector<Vec2> places = grid(5, 15, 6, 3, 2.0);
    const std::vector<Vec2> pairs(places.begin(), places.begin() + 10), alone(places.begin() + 10, places.end());
    const Loaded l = load("close-groups.xml",
                          fourExits("<ExitSet id=\"all\" exits=\"south north west east\" choice=\"quickest\" interval=\"2\"/>",
                                    inGroups(agentsAt(pairs, "out"), 2) + agentsAt(alone, "out"),
                                    "<CloseExit exit=\"north\" time=\"3\"/><CloseExit exit=\"east\" time=\"3\"/>", 200));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    for (const int threads : {1, 2}) {
        const Outcome o = runScenario(*l.spec, threads);
        BOOST_TEST(o.left == 0u, threads << " threads: " << o.left << " left behind");
        BOOST_REQUIRE(o.exitOf.size() == places.size());
        for (const auto& [id, exit] : o.exitOf) BOOST_TEST((exit == "west" || exit == "south"), "agent " << id << " left by " << exit);
        const auto groups = exitsByGroup(*l.spec, o);
        BOOST_TEST(groups.size() == 5u);
        for (const auto& [g, exits] : groups) BOOST_TEST(exits.size() == 1u, "group " << g << " left by " << exits.size() << " exits");
    }
}

BOOST_AUTO_TEST_CASE(a_reopened_exit_is_taken_again) {
    // West closes at once and reopens at 2 s: the agents beside it leave by it after all.
    const std::vector<Vec2> places = grid(2, 8, 2, 2, 2.0);
    const Loaded l = load("reopen.xml", fourExits("<ExitSet id=\"all\" exits=\"west east\" choice=\"nearest\"/>",
                                                  agentsAt(places, "out"),
                                                  "<CloseExit exit=\"west\" time=\"0\"/><OpenExit exit=\"west\" time=\"2\"/>"));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) BOOST_TEST(exit == "west");
}

BOOST_AUTO_TEST_CASE(exit_events_listed_out_of_time_order_apply_in_time_order) {
    // The schedule lists east's closing (at 50 s) before west's (at once): west is closed from the
    // start, so the agents beside it walk to the east exit, which is still open when they get there.
    const std::vector<Vec2> places = grid(2, 8, 2, 2, 2.0);
    const Loaded l = load("order.xml", fourExits("<ExitSet id=\"all\" exits=\"west east\" choice=\"nearest\"/>",
                                                 agentsAt(places, "out"),
                                                 "<CloseExit exit=\"east\" time=\"50\"/><CloseExit exit=\"west\" time=\"0\"/>"));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) {
        BOOST_TEST(exit == "east", "agent " << id);
        BOOST_TEST(o.timeOf.at(id) < 50.0, "agent " << id);
    }
}

BOOST_AUTO_TEST_CASE(an_agent_leaves_by_any_open_exit_of_its_set_it_walks_through) {
    // A corridor with two exits drawn across it: "far" at its end, the one the set's fixed rule
    // sends everyone to, and "near" half way, which the walkers cross on their way. Any exit of
    // the set counts (docs/navigation.md): they leave by "near".
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"21\" ymin=\"-1\" ymax=\"4\">\n<Navigation/>\n";
    world += wall(0, 0, 20, 0) + wall(0, 3, 20, 3) + wall(0, 0, 0, 3);
    world += "<Exit id=\"near\" xmin=\"9.5\" xmax=\"10\" ymin=\"0\" ymax=\"3\"/>\n";
    world += "<Exit id=\"far\" xmin=\"19\" xmax=\"20\" ymin=\"0\" ymax=\"3\"/>\n";
    world += "<ExitSet id=\"both\" exits=\"near far\" choice=\"fixed\" fixed=\"far\"/>\n";
    world += "<Journey id=\"out\" leave_by=\"both\"/>\n</World>\n";
    const std::vector<Vec2> places = grid(1, 0.75, 3, 2, 1.5);
    const Loaded l = load("through.xml", simulation(world, agentsAt(places, "out"), 60));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_REQUIRE(o.exitOf.size() == places.size());
    for (const auto& [id, exit] : o.exitOf) BOOST_TEST(exit == "near", "agent " << id);
}

// ---- checkpoints ------------------------------------------------------------------------------

namespace {
std::string checkpointScene(int capacity, double dwell, int people) {
    // A corridor 3 m wide; a gate area at x ∈ [8, 9]; the exit at its east end.
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"21\" ymin=\"-1\" ymax=\"4\">\n<Navigation/>\n";
    world += wall(0, 0, 20, 0) + wall(0, 3, 20, 3) + wall(0, 0, 0, 3);
    world += "<Target id=\"gate\" xmin=\"8\" xmax=\"9\" ymin=\"1\" ymax=\"2\"/>\n";
    world += "<Exit id=\"end\" xmin=\"19\" xmax=\"20\" ymin=\"0\" ymax=\"3\"/>\n";
    world += "<Journey id=\"through\" leave_by=\"end\"><Waypoint target=\"gate\" dwell=\"" + std::to_string(dwell) +
             "\" capacity=\"" + std::to_string(capacity) + "\"/></Journey>\n</World>\n";
    return simulation(world, agentsAt(grid(0.7, 0.6, (people + 2) / 3, 3, 0.9), "through"), 200);
}

/// Largest number of services overlapping in time (a service ending at t and another starting at
/// t do not overlap).
int maxConcurrent(const std::vector<Navigation::Service>& s) {
    std::vector<std::pair<double, int>> events;
    for (const auto& v : s) {
        events.push_back({v.start, +1});
        events.push_back({v.end, -1});
    }
    std::sort(events.begin(), events.end());  // at equal times −1 sorts before +1
    int now = 0, most = 0;
    for (const auto& [t, d] : events) most = std::max(most, now += d);
    return most;
}
}  // namespace

BOOST_AUTO_TEST_CASE(checkpoint_serves_one_at_a_time_for_its_dwell) {
    const Loaded l = load("gate1.xml", checkpointScene(1, 2.0, 9));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.exitOf.size() == 9u);
    BOOST_REQUIRE(o.services.size() == 9u);
    for (const auto& v : o.services) {
        BOOST_TEST(v.end >= 0);
        BOOST_TEST(v.end - v.start >= 2.0 - 1e-9);
        BOOST_TEST(v.end - v.start <= 2.0 + 0.1 + 1e-9);  // released at the first step after the dwell
    }
    BOOST_TEST(maxConcurrent(o.services) == 1);
    // Served one after another: 9 people take at least 9 dwell times.
    double first = 1e9, last = 0;
    for (const auto& v : o.services) first = std::min(first, v.start), last = std::max(last, v.end);
    BOOST_TEST(last - first >= 18.0 - 1e-9);
}

BOOST_AUTO_TEST_CASE(checkpoint_with_two_places_serves_two_at_once) {
    const Loaded l = load("gate2.xml", checkpointScene(2, 3.0, 9));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.exitOf.size() == 9u);
    BOOST_REQUIRE(o.services.size() == 9u);
    BOOST_TEST(maxConcurrent(o.services) == 2);
    for (const auto& v : o.services) BOOST_TEST(v.end - v.start >= 3.0 - 1e-9);
}

BOOST_AUTO_TEST_CASE(a_journey_visits_its_waypoints_in_order) {
    // Two gates 9 m apart along a corridor, 1 s at each, then the exit: every agent is served at
    // the first gate, walks to the second (at least 9 m at most 1.6 m/s) and is served there.
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"21\" ymin=\"-1\" ymax=\"4\">\n<Navigation/>\n";
    world += wall(0, 0, 20, 0) + wall(0, 3, 20, 3) + wall(0, 0, 0, 3);
    world += "<Target id=\"first\" xmin=\"4\" xmax=\"5\" ymin=\"0.5\" ymax=\"2.5\"/>\n";
    world += "<Target id=\"second\" xmin=\"14\" xmax=\"15\" ymin=\"0.5\" ymax=\"2.5\"/>\n";
    world += "<Exit id=\"end\" xmin=\"19\" xmax=\"20\" ymin=\"0\" ymax=\"3\"/>\n";
    world += "<Journey id=\"gates\" leave_by=\"end\"><Waypoint target=\"first\" dwell=\"1\"/>"
             "<Waypoint target=\"second\" dwell=\"1\"/></Journey>\n</World>\n";
    const std::vector<Vec2> places = grid(0.7, 1.0, 2, 2, 1.0);
    const Loaded l = load("gates.xml", simulation(world, agentsAt(places, "gates"), 100));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.exitOf.size() == places.size());
    std::map<AgentId, std::map<int, Navigation::Service>> byAgent;
    for (const auto& v : o.services) byAgent[v.id][v.waypoint] = v;
    BOOST_REQUIRE(byAgent.size() == places.size());
    for (const auto& [id, served] : byAgent) {
        BOOST_REQUIRE_MESSAGE(served.size() == 2u, "agent " << id << " served " << served.size() << " times");
        const Navigation::Service& first = served.at(0);
        const Navigation::Service& second = served.at(1);
        BOOST_TEST(second.start - first.end >= 9.0 / 1.6 - 0.1, "agent " << id);
        BOOST_TEST(o.timeOf.at(id) > second.end, "agent " << id);
    }
}

// ---- sources ----------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(source_places_arrivals_at_its_rate_clear_of_walls_and_people) {
    // 2 persons/s for 10 s into a 4 m × 3 m area with a pillar in it; they walk to an exit.
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"31\" ymin=\"-1\" ymax=\"11\">\n<Navigation/>\n";
    world += wall(0, 0, 30, 0) + wall(0, 10, 30, 10) + wall(0, 0, 0, 10);
    world += "<Obstacle><Point x=\"2\" y=\"4\"/><Point x=\"3\" y=\"4\"/><Point x=\"3\" y=\"5\"/><Point x=\"2\" y=\"5\"/></Obstacle>\n";
    world += "<Exit id=\"out\" xmin=\"29\" xmax=\"30\" ymin=\"0\" ymax=\"10\"/>\n<Journey id=\"go\" leave_by=\"out\"/>\n</World>\n";
    const std::string agents = R"(<Source xmin="0.5" xmax="4.5" ymin="3" ymax="6" rate="2" start="1" end="11" journey="go">
        <Policy id="0"/><Draw attribute="rad" distribution="uniform" min="0.2" max="0.28"/>
        <Draw attribute="pref_speed" distribution="normal" mean="1.3" sd="0.2" min="0.8" max="1.8"/></Source>
)";
    const Loaded l = load("source.xml", simulation(world, agents, 80));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    BOOST_REQUIRE(l.spec->agents.size() == 20u);
    for (std::size_t k = 0; k < 20; ++k)
        BOOST_TEST(l.spec->agents[k].startTime == 1.0 + 0.5 * static_cast<double>(k), boost::test_tools::tolerance(1e-12));
    Simulation sim(*l.spec);
    std::set<AgentId> seen;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (!seen.insert(A.id[i]).second) continue;
            BOOST_TEST(A.radius[i] >= 0.2);
            BOOST_TEST(A.radius[i] <= 0.28);
            // Arrived at its time (the area has room for everyone at this rate).
            BOOST_TEST(sim.time() - l.spec->agents[static_cast<std::size_t>(A.id[i])].startTime < 0.1 + 1e-9);
        }
        BOOST_TEST(sim.maxWallPenetration() < 0.05);
    }
    BOOST_TEST(seen.size() == 20u);
    BOOST_TEST(sim.evacuations().size() == 20u);
}

BOOST_AUTO_TEST_CASE(a_crowded_source_waits_for_room_and_never_places_on_people_or_walls) {
    // 10 persons/s into a 3 m × 3 m area round a 1 m pillar, people slow to leave: arrivals must
    // wait for room. Every newcomer is checked at the fine step it appears.
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"31\" ymin=\"-1\" ymax=\"11\">\n<Navigation/>\n";
    world += wall(0, 0, 30, 0) + wall(0, 10, 30, 10) + wall(0, 0, 0, 10);
    world += "<Obstacle><Point x=\"1.5\" y=\"4.5\"/><Point x=\"2.5\" y=\"4.5\"/><Point x=\"2.5\" y=\"5.5\"/><Point x=\"1.5\" y=\"5.5\"/></Obstacle>\n";
    world += "<Exit id=\"out\" xmin=\"29\" xmax=\"30\" ymin=\"0\" ymax=\"10\"/>\n<Journey id=\"go\" leave_by=\"out\"/>\n</World>\n";
    const std::string agents = R"(<Source xmin="0.5" xmax="3.5" ymin="3.5" ymax="6.5" rate="10" count="40" journey="go"
        rad="0.25" pref_speed="0.4"><Policy id="0"/></Source>
)";
    const Loaded l = load("crowded-source.xml", simulation(world, agents, 200));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    ScenarioSpec spec = *l.spec;
    spec.deltaTimeFine = 0.1;
    Simulation sim(spec);
    std::set<AgentId> seen;
    int waited = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        waited += sim.waitingArrivals() > 0;
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (seen.count(A.id[i])) continue;
            seen.insert(A.id[i]);
            // One step after appearing: still where it was placed, give or take a step's walk.
            BOOST_TEST(!sim.world().insideObstacle(A.pos[i]));
            for (std::size_t j = 0; j < A.size(); ++j)
                if (j != i) BOOST_TEST((A.pos[i] - A.pos[j]).norm() >= A.radius[i] + A.radius[j] - 0.05, "agent " << A.id[i]);
        }
    }
    BOOST_TEST(waited > 0);  // the area was full at times
    BOOST_TEST(seen.size() == 40u);
    BOOST_TEST(sim.evacuations().size() == 40u);
}

// ---- determinism ------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(one_and_two_threads_give_the_same_bits) {
    const Loaded l = load("threads.xml", checkpointScene(1, 1.0, 9));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome a = runScenario(*l.spec, 1), b = runScenario(*l.spec, 2);
    BOOST_REQUIRE(a.frames.size() == b.frames.size());
    bool same = true;
    for (std::size_t f = 0; f < a.frames.size() && same; ++f) same = a.frames[f] == b.frames[f];
    BOOST_TEST(same);
    BOOST_TEST((a.timeOf == b.timeOf));
}

BOOST_AUTO_TEST_CASE(one_and_two_threads_give_the_same_bits_with_quickest_exits_groups_and_a_checkpoint) {
    // Every part of an update at once: 160 people choosing the quickest of four exits (groups of
    // three among them), 40 through a checkpoint first (pairs among them), 12 leaving by one exit,
    // and two exits closing at 20 s. The lists an update gathers on each thread (choosers, queues,
    // the serial part) must give what one thread gives, every step.
    const std::string world =
        "<World type=\"Planar\" xmin=\"-2\" xmax=\"22\" ymin=\"-2\" ymax=\"22\">\n<Navigation/>\n" + wall(0, 0, 9.4, 0) +
        wall(10.6, 0, 20, 0) + wall(0, 20, 9.4, 20) + wall(10.6, 20, 20, 20) + wall(0, 0, 0, 9.4) + wall(0, 10.6, 0, 20) +
        wall(20, 0, 20, 9.4) + wall(20, 10.6, 20, 20) +
        "<Exit id=\"south\" xmin=\"9.4\" xmax=\"10.6\" ymin=\"-1\" ymax=\"-0.3\"/>\n"
        "<Exit id=\"north\" xmin=\"9.4\" xmax=\"10.6\" ymin=\"20.3\" ymax=\"21\"/>\n"
        "<Exit id=\"west\" xmin=\"-1\" xmax=\"-0.3\" ymin=\"9.4\" ymax=\"10.6\"/>\n"
        "<Exit id=\"east\" xmin=\"20.3\" xmax=\"21\" ymin=\"9.4\" ymax=\"10.6\"/>\n"
        "<Target id=\"desk\" xmin=\"9\" xmax=\"11\" ymin=\"3\" ymax=\"5\"/>\n"
        "<ExitSet id=\"all\" exits=\"south north west east\" choice=\"quickest\" interval=\"2\"/>\n"
        "<ExitSet id=\"two\" exits=\"south west\" choice=\"nearest\"/>\n"
        "<Journey id=\"out\" leave_by=\"all\"/>\n"
        "<Journey id=\"via\" leave_by=\"all\"><Waypoint target=\"desk\" dwell=\"1\" capacity=\"4\"/></Journey>\n"
        "<Journey id=\"single\" leave_by=\"east\"/>\n</World>\n";
    const std::vector<Vec2> crowd = grid(1.5, 7, 20, 8, 0.9), desk = grid(1.5, 1.5, 20, 2, 0.9), east = grid(15, 15, 4, 3, 0.9);
    const std::vector<Vec2> crowdGroups(crowd.begin(), crowd.begin() + 90), crowdAlone(crowd.begin() + 90, crowd.end());
    const std::vector<Vec2> deskPairs(desk.begin(), desk.begin() + 20), deskAlone(desk.begin() + 20, desk.end());
    std::string deskPairsXml = inGroups(agentsAt(deskPairs, "via", 0.22), 2);
    for (std::size_t at = 0; (at = deskPairsXml.find("group=\"g", at)) != std::string::npos; at += 8)
        deskPairsXml.replace(at, 8, "group=\"d");  // other names than the crowd's groups
    const std::string agents = inGroups(agentsAt(crowdGroups, "out", 0.22), 3) + agentsAt(crowdAlone, "out", 0.22) +
                               deskPairsXml + agentsAt(deskAlone, "via", 0.22) + agentsAt(east, "single", 0.22);
    const Loaded l = load("threads-venue.xml",
                          simulation(world, agents, 60, "<Schedule><CloseExit exit=\"north\" time=\"20\"/><CloseExit exit=\"east\" time=\"20\"/></Schedule>\n"));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome a = runScenario(*l.spec, 1), b = runScenario(*l.spec, 2);
    BOOST_REQUIRE(a.frames.size() == b.frames.size());
    std::size_t firstDifferent = a.frames.size();
    for (std::size_t f = 0; f < a.frames.size() && firstDifferent == a.frames.size(); ++f)
        if (a.frames[f] != b.frames[f]) firstDifferent = f;
    BOOST_TEST(firstDifferent == a.frames.size(), "positions differ from coarse step " << firstDifferent);
    BOOST_TEST((a.timeOf == b.timeOf));
    BOOST_TEST((a.exitOf == b.exitOf));
    BOOST_REQUIRE(a.services.size() == b.services.size());
    for (std::size_t k = 0; k < a.services.size(); ++k) {
        BOOST_TEST(a.services[k].id == b.services[k].id);
        BOOST_TEST(a.services[k].start == b.services[k].start);
        BOOST_TEST(a.services[k].end == b.services[k].end);
    }
    // The scene does what it is for: services, a spread over the exits, and after the closing
    // each group by one exit (a member through north or east before 20 s is not followed).
    BOOST_TEST(a.services.size() >= 30u);
    std::map<std::string, int> used;
    for (const auto& [id, exit] : a.exitOf) ++used[exit];
    BOOST_TEST(used.size() >= 3u);
    BOOST_TEST(a.exitOf.size() >= 150u, a.exitOf.size() << " left");
    const auto groups = exitsByGroup(*l.spec, a, 20);
    BOOST_TEST(groups.size() >= 20u);
    for (const auto& [g, exits] : groups) BOOST_TEST(exits.size() == 1u, "group " << g << " left by " << exits.size() << " exits");
}

// ---- bad input --------------------------------------------------------------------------------

namespace {
/// The line of `needle` in `text` (1-based).
int lineOf(const std::string& text, const std::string& needle) {
    const std::size_t at = text.find(needle);
    BOOST_REQUIRE(at != std::string::npos);
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}
void expectError(const std::string& name, const std::string& xml, const std::string& needle, const std::string& words) {
    const Loaded l = load(name, xml);
    BOOST_TEST(!l.spec);
    const std::string where = l.path + ":" + std::to_string(lineOf(xml, needle)) + ": error: ";
    BOOST_TEST(l.messages.find(where) != std::string::npos, l.messages << "\nexpected: " << where);
    BOOST_TEST(l.messages.find(words) != std::string::npos, l.messages << "\nexpected: " << words);
}
}  // namespace

BOOST_AUTO_TEST_CASE(a_target_inside_a_wall_is_an_error_at_its_line) {
    std::string world = "<World type=\"Planar\" xmin=\"0\" xmax=\"10\" ymin=\"0\" ymax=\"10\">\n<Navigation/>\n"
                        "<Obstacle><Point x=\"4\" y=\"4\"/><Point x=\"6\" y=\"4\"/><Point x=\"6\" y=\"6\"/><Point x=\"4\" y=\"6\"/></Obstacle>\n"
                        "<Target id=\"buried\" x=\"5\" y=\"5\" radius=\"0.3\"/>\n"
                        "<Journey id=\"j\"><Waypoint target=\"buried\"/></Journey>\n</World>\n";
    expectError("buried.xml", simulation(world, agentsAt({Vec2(1, 1)}, "j")), "<Target id=\"buried\"", "touches no walkable floor");
}

BOOST_AUTO_TEST_CASE(an_unreachable_target_is_an_error_at_the_agent) {
    // A closed room around the target.
    std::string world = "<World type=\"Planar\" xmin=\"0\" xmax=\"20\" ymin=\"0\" ymax=\"10\">\n<Navigation/>\n" +
                        wall(10, 2, 16, 2) + wall(16, 2, 16, 8) + wall(16, 8, 10, 8) + wall(10, 8, 10, 2) +
                        "<Target id=\"inside\" x=\"13\" y=\"5\"/>\n<Journey id=\"j\"><Waypoint target=\"inside\"/></Journey>\n</World>\n";
    const std::string xml = simulation(world, agentsAt({Vec2(2, 5)}, "j"));
    expectError("closed.xml", xml, "<Agent ", "cannot reach target 'inside'");
}

BOOST_AUTO_TEST_CASE(an_exit_set_naming_an_unknown_exit_is_an_error_with_a_suggestion) {
    const std::string xml = fourExits("<ExitSet id=\"all\" exits=\"south nroth\" choice=\"nearest\"/>", agentsAt({Vec2(5, 5)}, "out"));
    expectError("unknown.xml", xml, "<ExitSet", "exit 'nroth' does not exist (did you mean 'north'?)");
}

BOOST_AUTO_TEST_CASE(other_venue_mistakes_are_errors_at_their_lines) {
    expectError("journey.xml", fourExits("<ExitSet id=\"all\" exits=\"south\"/>", agentsAt({Vec2(5, 5)}, "nowhere")),
                "journey=\"nowhere\"", "journey 'nowhere' does not exist");
    expectError("close.xml",
                fourExits("<ExitSet id=\"all\" exits=\"south\"/>", agentsAt({Vec2(5, 5)}, "out"), "<CloseExit exit=\"gate\" time=\"1\"/>"),
                "<CloseExit", "exit 'gate' does not exist");
    expectError("weights.xml", fourExits("<ExitSet id=\"all\" exits=\"south north\" choice=\"weighted\" weights=\"1\"/>",
                                         agentsAt({Vec2(5, 5)}, "out")),
                "<ExitSet", "1 weights for 2 exits");
    expectError("dup.xml", fourExits("<ExitSet id=\"all\" exits=\"south\"/><Exit id=\"south\" x=\"1\" y=\"1\"/>",
                                     agentsAt({Vec2(5, 5)}, "out")),
                "<Exit id=\"south\" x=", "duplicate target name 'south'");
}

BOOST_AUTO_TEST_CASE(a_grid_or_a_source_too_large_for_the_machine_is_an_error_before_anything_is_built) {
    // 2 km × 2 km at 1 cm: 4e10 cells, far beyond any machine's memory.
    std::string world = "<World type=\"Planar\" xmin=\"-1000\" xmax=\"1000\" ymin=\"-1000\" ymax=\"1000\">\n"
                        "<Navigation cell_size=\"0.01\"/>\n<Exit id=\"e\" x=\"5\" y=\"5\"/>\n"
                        "<Journey id=\"j\" leave_by=\"e\"/>\n</World>\n";
    expectError("huge.xml", simulation(world, agentsAt({Vec2(1, 1)}, "j")), "<Navigation", "give a larger cell_size");
    // A source of a million persons per second for a day.
    std::string small = "<World type=\"Planar\" xmin=\"0\" xmax=\"10\" ymin=\"0\" ymax=\"10\">\n"
                        "<Exit id=\"e\" x=\"5\" y=\"5\"/>\n<Journey id=\"j\" leave_by=\"e\"/>\n</World>\n";
    expectError("flood.xml",
                simulation(small, "<Source xmin=\"1\" xmax=\"2\" ymin=\"1\" ymax=\"2\" rate=\"1000000\" end=\"86400\" journey=\"j\">"
                                  "<Policy id=\"0\"/></Source>\n"),
                "<Source", "more than 1e+07 agents");
}

BOOST_AUTO_TEST_CASE(source_arrivals_follow_a_rate_table) {
    // 1 P/s from 0 s, none from 5 s, 2 P/s from 10 s, until 15 s: 5 + 10 arrivals.
    SourceSpec s;
    s.start = 0;
    s.end = 15;
    s.table = {{0, 1}, {5, 0}, {10, 2}};
    const std::vector<double> t = sourceArrivals(s, 1000);
    BOOST_REQUIRE(t.size() == 15u);
    for (int k = 0; k < 5; ++k) BOOST_TEST(t[static_cast<std::size_t>(k)] == k, boost::test_tools::tolerance(1e-12));
    for (int k = 0; k < 10; ++k) BOOST_TEST(t[static_cast<std::size_t>(5 + k)] == 10 + 0.5 * k, boost::test_tools::tolerance(1e-12));
    // A count stops it early; a later start skips the first piece's arrivals before it.
    s.count = 7;
    BOOST_TEST(sourceArrivals(s, 1000).size() == 7u);
    s.count = -1;
    s.start = 3;
    const std::vector<double> late = sourceArrivals(s, 1000);
    BOOST_REQUIRE(late.size() == 12u);
    BOOST_TEST(late.front() == 3.0, boost::test_tools::tolerance(1e-12));
    // A fractional rate carries over pieces: 0.5 P/s for 3 s (1.5 persons), then 0.5 P/s again.
    SourceSpec h;
    h.end = 6;
    h.table = {{0, 0.5}, {3, 0.5}};
    const std::vector<double> half = sourceArrivals(h, 1000);
    BOOST_REQUIRE(half.size() == 3u);
    BOOST_TEST(half[1] == 2.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(half[2] == 4.0, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(premovement_keeps_an_agent_standing_then_it_walks) {
    // No venue at all: premovement alone (RiMEA test 5) — the agent stands 3 s, then walks.
    const std::string xml = simulation("<World type=\"Infinite\"/>\n",
                                       "<Agent premovement=\"3\"><pos x=\"0\" y=\"0\"/><goal x=\"10\" y=\"0\"/><Policy id=\"0\"/></Agent>\n"
                                       "<Agent><pos x=\"0\" y=\"5\"/><goal x=\"10\" y=\"5\"/><Policy id=\"0\"/></Agent>\n",
                                       6);
    const Loaded l = load("premovement.xml", xml);
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    Simulation sim(*l.spec);
    while (sim.time() < 3.0 - 1e-9) {
        sim.stepCoarse();
        BOOST_TEST(sim.agents().pos[0] == Vec2(0, 0));
    }
    BOOST_TEST(sim.agents().pos[1].x() > 2.0);  // the other one left at once
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(sim.agents().pos[0].x() > 2.0);
}

BOOST_AUTO_TEST_CASE(measurement_lines_and_areas_load_and_their_mistakes_are_errors_at_their_lines) {
    const std::string world = "<World type=\"Planar\" xmin=\"0\" xmax=\"10\" ymin=\"0\" ymax=\"10\"/>\n";
    const std::string agents = "<Agent><pos x=\"1\" y=\"1\"/><goal x=\"9\" y=\"9\"/><Policy id=\"0\"/></Agent>\n";
    const Loaded good = load("measure.xml", simulation(world, agents, 10,
                                                       "<Measurement interval=\"2\"><Line id=\"door\" x1=\"0\" y1=\"5\" x2=\"10\" y2=\"5\"/>"
                                                       "<Area id=\"hall\" xmin=\"1\" xmax=\"4\" ymin=\"1\" ymax=\"3\"/>"
                                                       "<Area id=\"tri\"><Point x=\"5\" y=\"5\"/><Point x=\"8\" y=\"5\"/><Point x=\"5\" y=\"8\"/></Area>"
                                                       "</Measurement>\n"));
    BOOST_REQUIRE_MESSAGE(good.spec, good.messages);
    const MeasurementSpec& m = good.spec->measurement;
    BOOST_TEST(m.interval == 2.0);
    BOOST_REQUIRE(m.lines.size() == 1u);
    BOOST_TEST((m.lines[0].b == Vec2(10, 5)));
    BOOST_REQUIRE(m.areas.size() == 2u);
    BOOST_TEST(m.areas[1].polygon.size() == 3u);
    expectError("m1.xml", simulation(world, agents, 10, "<Measurement>\n<Line id=\"dot\" x1=\"1\" y1=\"1\" x2=\"1\" y2=\"1\"/></Measurement>\n"),
                "<Line id=\"dot\"", "its two ends are the same point");
    expectError("m2.xml",
                simulation(world, agents, 10,
                           "<Measurement>\n<Line id=\"a\" x1=\"1\" y1=\"1\" x2=\"2\" y2=\"1\"/>\n<Area id=\"a\" xmin=\"1\" xmax=\"2\" ymin=\"1\" ymax=\"2\"/></Measurement>\n"),
                "<Area id=\"a\"", "duplicate measurement name 'a'");
    expectError("m3.xml", simulation(world, agents, 10, "<Measurement>\n<Area id=\"b\"/></Measurement>\n"), "<Area id=\"b\"",
                "Area: needs an area");
}

BOOST_AUTO_TEST_CASE(an_exit_drawn_flush_across_a_door_in_its_wall_is_reachable) {
    // The exit rectangle spans the door and the wall on both sides (x 4 … 6 over a door at
    // 4.4 … 5.6, y −0.3 … 0.3): its floor lies on both sides of the wall; the loader took one cell
    // of it (behind the wall) for the whole and refused the journey; the people inside reach it.
    std::string world = "<World type=\"Planar\" xmin=\"-1\" xmax=\"11\" ymin=\"-3\" ymax=\"11\">\n<Navigation/>\n" +
                        wall(0, 0, 4.4, 0) + wall(5.6, 0, 10, 0) + wall(0, 10, 10, 10) + wall(0, 0, 0, 10) + wall(10, 0, 10, 10) +
                        "<Exit id=\"door\" xmin=\"4\" xmax=\"6\" ymin=\"-0.3\" ymax=\"0.3\"/>\n<Journey id=\"out\" leave_by=\"door\"/>\n</World>\n";
    const Loaded l = load("flush.xml", simulation(world, agentsAt(grid(2, 5, 4, 2, 2.0), "out"), 60));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.exitOf.size() == 8u);
}

BOOST_AUTO_TEST_CASE(an_agent_placed_inside_an_obstacle_is_an_error_with_navigation) {
    std::string world = "<World type=\"Planar\" xmin=\"0\" xmax=\"20\" ymin=\"0\" ymax=\"10\">\n<Navigation/>\n"
                        "<Obstacle><Point x=\"4\" y=\"4\"/><Point x=\"6\" y=\"4\"/><Point x=\"6\" y=\"6\"/><Point x=\"4\" y=\"6\"/></Obstacle>\n"
                        "<Exit id=\"e\" xmin=\"19\" xmax=\"20\" ymin=\"0\" ymax=\"10\"/>\n<Journey id=\"j\" leave_by=\"e\"/>\n</World>\n";
    const std::string xml = simulation(world, "<AgentGrid x=\"1\" y=\"1\" columns=\"8\" rows=\"8\" spacing=\"1\" journey=\"j\"><Policy id=\"0\"/></AgentGrid>\n");
    expectError("inside.xml", xml, "<AgentGrid", "starts inside an obstacle");
}

BOOST_AUTO_TEST_CASE(an_infinite_worlds_grid_reaches_every_plain_goal_and_start) {
    // The only wall spans x = 10; the start and the goal lie 20 m either side of it, beyond the
    // wall's bounds plus the 5 m margin: the grid must still hold them (navigationBounds).
    // A second person, on a journey, starts as far out and leaves by an exit 20 m beyond the wall.
    const std::string world = "<World type=\"Infinite\">\n<Navigation/>\n" + wall(10, -3, 10, 3) +
                              "<Exit id=\"far\" x=\"30\" y=\"4\" radius=\"0.5\"/>\n<Journey id=\"j\" leave_by=\"far\"/>\n</World>\n";
    const std::string agents = "<Agent rad=\"0.25\" remove_at_goal=\"true\" goal_radius=\"0.5\"><pos x=\"-10\" y=\"0\"/>"
                               "<goal x=\"30\" y=\"0\"/><Policy id=\"0\"/></Agent>\n"
                               "<Agent rad=\"0.25\" journey=\"j\"><pos x=\"-10\" y=\"4\"/><Policy id=\"0\"/></Agent>\n";
    const Loaded l = load("far.xml", simulation(world, agents, 60));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const Outcome o = runScenario(*l.spec);
    BOOST_TEST(o.timeOf.size() == 2u);
}
