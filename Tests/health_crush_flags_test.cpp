// CrowdHealth tests — HealthLayer::crushFlags (Library/include/crowdhealth/health/health.h): the
// byte per record that the safety recorder reads instead of each agent's record is, for every
// active agent at every step, the record's own test `lastForce > params(policy).crushThreshold`,
// through removals and the re-orderings that move the records; it is withheld (nullptr) before
// the first step and while a threshold differs from the one the last step used.
#define BOOST_TEST_MODULE health_crush_flags
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/health/health.h"
#include "crowdhealth/health/safety.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/io/xml.h"

#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using namespace ch;
using namespace ch::test;

namespace {

/// Simulated seconds of the runs: by 20 s the crowd in front of the exit has agents above and
/// below their threshold and has let people out (60 s took 50 s in Release, 120 s under the
/// sanitizers, for no more coverage).
constexpr double kEnd = 20;

/// Counts the active agents whose byte disagrees with their record's test; adds to `above` those
/// above their threshold.
std::size_t disagreements(const Simulation& sim, const unsigned char* flags, std::size_t& above) {
    const HealthLayer& h = sim.health();
    const AgentStore& a = sim.agents();
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const HealthRecord& r = h.recordOf(a, i);
        const bool want = r.lastForce > h.params(r.policy).crushThreshold;
        if (want) ++above;
        if ((flags[static_cast<std::size_t>(a.record[i])] != 0) != want) ++wrong;
    }
    return wrong;
}

/// Examples/future-work/injuries.xml, run to kEnd: a crush in front of the exit (agents above the
/// threshold, injured, leaving through it).
ScenarioSpec injuries() {
    Diagnostics diags;
    auto spec = loadScenario(std::string(CH_SOURCE_DIR) + "/Examples/future-work/injuries.xml", diags);
    BOOST_REQUIRE(spec.has_value());
    spec->endTime = kEnd;
    return *spec;
}

}  // namespace

BOOST_AUTO_TEST_CASE(crush_flags_are_the_records_test_for_every_agent_at_every_step) {
    // Re-ordered every few steps (records permuted by follow()).
    Simulation sim(injuries());
    sim.setReorderInterval(3);
    BOOST_TEST(sim.health().crushFlags() == nullptr);  // no step yet: lastForce is not a step's
    const std::size_t start = sim.agents().size();
    std::size_t steps = 0, wrong = 0, above = 0, stepsWithSomeAbove = 0, stepsWithSomeBelow = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        const unsigned char* flags = sim.health().crushFlags();
        BOOST_REQUIRE(flags != nullptr);
        std::size_t aboveNow = 0;
        wrong += disagreements(sim, flags, aboveNow);
        above += aboveNow;
        if (aboveNow > 0) ++stepsWithSomeAbove;
        if (aboveNow < sim.agents().size()) ++stepsWithSomeBelow;
        ++steps;
    }
    BOOST_TEST(wrong == 0u);
    // The case has what the flags must follow: agents above and below, some gone through the door.
    BOOST_TEST(steps > 100u);
    BOOST_TEST(stepsWithSomeAbove > 10u, "agent-steps above: " << above);
    BOOST_TEST(stepsWithSomeBelow > 10u);
    BOOST_TEST(sim.agents().size() < start);
}

BOOST_AUTO_TEST_CASE(crush_flags_are_withheld_while_a_threshold_differs_from_the_last_steps) {
    Simulation sim(injuries());
    for (int k = 0; k < 50; ++k) sim.stepCoarse();
    BOOST_REQUIRE(sim.health().crushFlags() != nullptr);
    HealthParams& hp = sim.health().params(0);
    const double threshold = hp.crushThreshold;
    hp.crushThreshold = threshold * 0.5;  // as a ramp would between two steps
    BOOST_TEST(sim.health().crushFlags() == nullptr);
    hp.crushThreshold = threshold;
    BOOST_TEST(sim.health().crushFlags() != nullptr);  // back to the value the step used
    hp.crushThreshold = threshold * 0.5;
    sim.stepCoarse();  // the step uses the new value: the flags hold again, with it
    const unsigned char* flags = sim.health().crushFlags();
    BOOST_REQUIRE(flags != nullptr);
    std::size_t above = 0;
    BOOST_TEST(disagreements(sim, flags, above) == 0u);
}

BOOST_AUTO_TEST_CASE(safety_recorder_counts_the_same_crush_with_the_flags_as_with_the_records) {
    // Two recorders of the same run: one reads the flags; before the other records, every
    // threshold is raised by one ulp (the flags are withheld: it reads the records), then set
    // back before the next step. A force within that ulp of a threshold would differ; none does.
    // Each cell's seconds_above_crush_threshold is the time between records summed over the
    // records at which someone in the cell was above their threshold (the test's own count).
    const ScenarioSpec spec = injuries();
    Simulation sim(spec);
    SafetyRecorder flags(spec.safety), records(spec.safety);
    const std::size_t policies = sim.policies().size();
    std::size_t withheld = 0;
    std::map<std::pair<int, int>, double> crushSeconds;  // (x, y) → seconds
    double previous = std::numeric_limits<double>::quiet_NaN();
    const double c = spec.safety.cellSize;
    while (true) {
        std::set<std::pair<int, int>> crushed;
        const HealthLayer& h = sim.health();
        for (std::size_t i = 0; i < sim.agents().size(); ++i) {
            const HealthRecord& r = h.recordOf(sim.agents(), i);
            const Vec2 p = sim.agents().pos[i];
            if (r.lastForce > h.params(r.policy).crushThreshold)
                crushed.emplace(static_cast<int>(std::floor(p.x() / c)), static_cast<int>(std::floor(p.y() / c)));
        }
        for (const auto& cell : crushed) crushSeconds[cell] += previous == previous ? sim.time() - previous : 0.0;
        previous = sim.time();
        flags.record(sim);
        std::vector<double> kept(policies);
        for (std::size_t p = 0; p < policies; ++p) {
            double& th = sim.health().params(p).crushThreshold;
            kept[p] = th;
            th = std::nextafter(th, 1e300);
        }
        if (sim.health().crushFlags() == nullptr) ++withheld;
        records.record(sim);
        for (std::size_t p = 0; p < policies; ++p) sim.health().params(p).crushThreshold = kept[p];
        if (sim.finished()) break;
        sim.stepCoarse();
    }
    BOOST_TEST(withheld > 150u);  // every coarse step of the 20 s
    const std::string heat = flags.heatmapCsv();
    BOOST_TEST(heat == records.heatmapCsv());
    // The case has crush cells: some seconds_above_crush_threshold (6th column) is not 0.
    std::istringstream in(heat);
    std::string line;
    std::getline(in, line);
    std::size_t crushCells = 0, wrong = 0;
    while (std::getline(in, line)) {
        std::istringstream row(line);
        std::string x, y, cell;
        std::getline(row, x, ',');
        std::getline(row, y, ',');
        for (int k = 2; k < 6; ++k) std::getline(row, cell, ',');
        if (!cell.empty() && std::stod(cell) > 0) ++crushCells;
        const auto it = crushSeconds.find({static_cast<int>(std::floor(std::stod(x) / c)),
                                           static_cast<int>(std::floor(std::stod(y) / c))});
        std::string want;
        appendNumber(want, it == crushSeconds.end() ? 0.0 : it->second);
        wrong += cell != want;
    }
    BOOST_TEST(crushCells > 5u);
    BOOST_TEST(wrong == 0u);
}
