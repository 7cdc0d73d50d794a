// Symmetry breaking (Simulation@symmetry_breaking, ScenarioSpec::symmetryBreaking): exactly
// symmetric scenarios deadlock in double precision; a seeded displacement of at most ε per fine
// step (default 1e-6 m) of every agent that is held up (slower than half its preferred speed)
// undoes that, is far below anything measured, is the same with any thread count, and is
// switched off by 0.
#define BOOST_TEST_MODULE symmetry_breaking
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/io/xml.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

using namespace ch;
namespace fs = std::filesystem;

namespace {

const fs::path kExamples = fs::path(CH_SHARED_DIR) / "umans-examples";

ScenarioSpec loadExample(const std::string& name) {
    Diagnostics diags;
    const std::optional<ScenarioSpec> spec = loadScenario((kExamples / name).string(), diags);
    BOOST_TEST_REQUIRE(spec.has_value(), name << " does not load");
    return *spec;
}

std::size_t arrivedCount(const test::RunResult& r) { return r.arrival.size(); }

/// A scenario file with the given <Simulation> attributes, written to a fresh temporary folder.
fs::path writeScenario(const std::string& name, const std::string& simulationAttributes) {
    const fs::path dir = fs::temp_directory_path() / ("ch-symmetry-" + name);
    fs::create_directories(dir);
    const fs::path file = dir / "s.xml";
    std::ofstream(file) << "<Simulation delta_time=\"0.1\" end_time=\"1\" " << simulationAttributes
                        << "><World type=\"Infinite\"/>"
                           "<Policies><Policy id=\"0\" OptimizationMethod=\"global\"><costfunction name=\"ORCA\"/>"
                           "</Policy></Policies>"
                           "<Agents><Agent rad=\"0.3\"><pos x=\"0\" y=\"0\"/><goal x=\"5\" y=\"0\"/><Policy id=\"0\"/>"
                           "</Agent></Agents></Simulation>";
    return file;
}

}  // namespace

BOOST_AUTO_TEST_CASE(perfect_crossing_deadlocks_without_and_resolves_with_symmetry_breaking) {
    // UMANS' Circle50-ORCA: 50 agents on a circle walk to the antipodes. Exactly symmetric, the ORCA
    // crowd forms a ring around the centre that only rotates: nobody arrives in 100 s. UMANS' single
    // precision breaks it after 78 s; the default 1e-6 m per step breaks it here too.
    ScenarioSpec spec = loadExample("Circle50-ORCA.xml");
    BOOST_TEST(spec.symmetryBreaking == 1e-6);  // the default when the file does not say
    // The ring breaks at a random time: first arrivals at 98-113 s over seeds 0-3 (both with the
    // draws of issue 20's cheaper jitter and with the earlier ones), so 100 s is not enough for
    // every seed; 150 s is, and without the perturbation the ring still turns for ever.
    spec.endTime = 150;
    const test::RunResult on = test::run(spec);
    spec.symmetryBreaking = 0;
    const test::RunResult off = test::run(spec);
    BOOST_TEST(arrivedCount(off) == 0u);
    BOOST_TEST(arrivedCount(on) > 0u);
}

BOOST_AUTO_TEST_CASE(right_angle_crossing_deadlocks_without_and_resolves_with_symmetry_breaking) {
    // UMANS' 1to1-90Degrees: two agents reach the crossing point together, mirror images of each
    // other about the diagonal. Exactly mirrored, Karamouzas and PLEdestrians agents touch and stand
    // there for ever; UMANS' rounding lets them pass after 12 s and 17 s, as does the default here.
    for (const char* name : {"1to1-90Degrees-Karamouzas.xml", "1to1-90Degrees-PLEdestrians.xml"}) {
        BOOST_TEST_CONTEXT(name) {
            ScenarioSpec spec = loadExample(name);
            const test::RunResult on = test::run(spec);
            spec.symmetryBreaking = 0;
            const test::RunResult off = test::run(spec);
            BOOST_TEST(arrivedCount(off) == 0u);
            BOOST_TEST(arrivedCount(on) == 2u);
            for (const auto& [id, t] : on.arrival) BOOST_TEST(t < 25.0, "agent " << id << " arrived at " << t << " s");
        }
    }
}

BOOST_AUTO_TEST_CASE(same_bits_with_one_and_two_threads) {
    // The draws are keyed by (seed, agent id, step): no shared sequential state. A symmetric
    // crowd that the perturbation actually changes (Circle25 with Moussaid's vision heuristics).
    ScenarioSpec spec = loadExample("Circle25-Moussaid.xml");
    spec.endTime = 20;
    Simulation one(spec), two(spec);
    // The thread count is OpenMP's setting of the calling thread: set it right before each run.
    one.setThreads(1);
    while (!one.finished()) one.stepCoarse();
    two.setThreads(2);
    while (!two.finished()) two.stepCoarse();
    one.setThreads(1);
    BOOST_TEST_REQUIRE(one.agents().size() == two.agents().size());
    for (std::size_t i = 0; i < one.agents().size(); ++i) {
        BOOST_TEST(one.agents().id[i] == two.agents().id[i]);
        BOOST_TEST(one.agents().pos[i].x() == two.agents().pos[i].x());  // bit-identical
        BOOST_TEST(one.agents().pos[i].y() == two.agents().pos[i].y());
    }
    // ... and it did something: without it the run differs.
    spec.symmetryBreaking = 0;
    Simulation plain(spec);
    plain.setThreads(1);
    while (!plain.finished()) plain.stepCoarse();
    double largest = 0;
    for (std::size_t i = 0; i < plain.agents().size(); ++i)
        largest = std::max(largest, (plain.agents().pos[i] - one.agents().pos[i]).norm());
    BOOST_TEST(largest > 0);
}

BOOST_AUTO_TEST_CASE(a_lone_walker_moves_at_most_epsilon_per_step_and_not_at_its_goal) {
    // A lone agent starting from rest and walking in a straight line: while it is slower than half
    // its preferred speed it is perturbed, so its position after n fine steps differs from the
    // unperturbed one by more than 0 and at most n·ε (each step adds a displacement in a disc of
    // radius ε; the model itself, a pure goal force, does not amplify it sideways). Once it walks
    // freely, and at its goal, it is left alone.
    auto a = test::agent(7, {0, 0}, {3, 0});
    auto spec = test::scenario({a}, {test::policy(0, OptimisationMethod::Gradient, {test::component("GoalReachingForce")}, 0.5)},
                               0.1, 10);
    const double eps = 1e-6;
    spec.symmetryBreaking = eps;
    Simulation with(spec);
    spec.symmetryBreaking = 0;
    Simulation without(spec);
    int steps = 0;
    double largest = 0;
    while (!with.finished() && !with.agents().atGoal(0)) {
        with.stepCoarse();
        without.stepCoarse();
        ++steps;
        const double d = (with.agents().pos[0] - without.agents().pos[0]).norm();
        largest = std::max(largest, d);
        BOOST_TEST(d <= steps * eps * 1.000001);
    }
    BOOST_TEST(largest > 0);
    BOOST_TEST_REQUIRE(with.agents().atGoal(0));
    // At the goal (no preferred velocity): no displacement at all from the perturbation.
    with.stepCoarse();  // the first step at the goal sets its preferred velocity to zero
    const Vec2 at = with.agents().pos[0];
    const Vec2 vel = with.agents().vel[0];
    with.stepCoarse();
    BOOST_TEST((with.agents().pos[0] - (at + vel * 0.1)).norm() < 1e-15);
}

BOOST_AUTO_TEST_CASE(the_attribute_sets_it_and_zero_switches_it_off) {
    Diagnostics diags;
    auto dflt = loadScenario(writeScenario("default", "").string(), diags);
    BOOST_TEST_REQUIRE(dflt.has_value());
    BOOST_TEST(dflt->symmetryBreaking == ScenarioSpec::kDefaultSymmetryBreaking);
    auto off = loadScenario(writeScenario("off", "symmetry_breaking=\"0\"").string(), diags);
    BOOST_TEST_REQUIRE(off.has_value());
    BOOST_TEST(off->symmetryBreaking == 0.0);
    auto set = loadScenario(writeScenario("set", "symmetry_breaking=\"2e-6\"").string(), diags);
    BOOST_TEST_REQUIRE(set.has_value());
    BOOST_TEST(set->symmetryBreaking == 2e-6);
    for (const char* bad : {"-1e-6", "0.5", "nan"}) {
        Diagnostics d;
        BOOST_TEST(!loadScenario(writeScenario("bad", std::string("symmetry_breaking=\"") + bad + "\"").string(), d),
                   bad << " should be rejected");
        std::ostringstream text;
        d.print(text);
        BOOST_TEST(text.str().find("symmetry_breaking") != std::string::npos, text.str());
    }
}
