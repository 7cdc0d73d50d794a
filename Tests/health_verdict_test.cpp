// CrowdHealth tests — the safety verdict, the crowd measures on a grid and the heat map
// (Library/include/crowdhealth/safety.h): a sparse crowd walking freely is safe, the base-case
// door is at least dangerous.
#define BOOST_TEST_MODULE health_verdict
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/output.h"
#include "crowdhealth/safety.h"
#include "crowdhealth/xml.h"

#include <cmath>
#include <sstream>

using namespace ch;
using namespace ch::test;

namespace {
/// A scenario run to its end, recording the safety measures every coarse step as the program does.
struct VerdictRun {
    Simulation sim;
    SafetyRecorder safety;
    Verdict verdict;
    explicit VerdictRun(const ScenarioSpec& spec) : sim(spec), safety(spec.safety) {
        safety.record(sim);
        while (!sim.finished()) {
            sim.stepCoarse();
            safety.record(sim);
        }
        verdict = safety.verdict(sim);
    }
};

/// A scenario of the repository (path below its top level), which must load.
ScenarioSpec loadRepositoryScenario(const std::string& relative) {
    Diagnostics diags;
    auto spec = loadScenario(std::string(CH_SOURCE_DIR) + "/" + relative, diags);
    std::ostringstream msg;
    diags.print(msg);
    BOOST_REQUIRE_MESSAGE(spec.has_value(), msg.str());
    return *spec;
}
}  // namespace

BOOST_AUTO_TEST_CASE(grid_density_and_pressure_follow_helbing_2007) {
    // A uniform block on a 0.5 m lattice (4 persons/m²) all walking at the same velocity: the
    // local density in the middle is close to 4, the crowd pressure 0 (no velocity variance).
    AgentStore a;
    for (int x = 0; x < 20; ++x)
        for (int y = 0; y < 20; ++y) {
            AgentSpec s = agent(x * 20 + y, {0.25 + 0.5 * x, 0.25 + 0.5 * y}, {100, 0});
            a.add(s, 0);
            a.vel.back() = Vec2(1.0, 0.0);
        }
    CrowdField f = crowdField(a, 1.0, 0.7);
    const int ix = 5 - f.ix0, iy = 5 - f.iy0;  // the cell [5, 6) x [5, 6), centre (5.5, 5.5)
    const double mid = f.density[static_cast<std::size_t>(iy * f.nx + ix)];
    BOOST_TEST(std::abs(mid - 4.0) < 0.05, "density " << mid);
    BOOST_TEST(f.maxPressure() < 1e-20);
    // Alternate velocities ±1 m/s along x: variance 1 (m/s)², pressure ≈ density.
    for (std::size_t i = 0; i < a.size(); ++i) a.vel[i] = Vec2(i % 2 ? 1.0 : -1.0, 0.0);
    f = crowdField(a, 1.0, 0.7);
    const double p = f.pressure[static_cast<std::size_t>(iy * f.nx + ix)];
    BOOST_TEST(std::abs(p - 4.0) < 0.2, "pressure " << p);
    BOOST_TEST(f.people[static_cast<std::size_t>(iy * f.nx + ix)] == 4);
}

BOOST_AUTO_TEST_CASE(sparse_free_walking_is_safe) {
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 12; ++k) agents.push_back(agent(k, {0, 3.0 * k}, {60, 3.0 * k}, 0.25, 1.3, 1.6));
    PolicySpec p = policy(0, OptimisationMethod::Gradient,
                          {component("GoalReachingForce", {{"range", 0.0}}), component("ContactForces", {{"range", 1.0}})},
                          0.5, {}, StepTiming::Fine, 0.0);
    ScenarioSpec s = scenario(agents, {p}, 0.1, 20);
    s.deltaTimeFine = 0.02;
    const VerdictRun run(s);
    const Verdict& v = run.verdict;
    BOOST_TEST(v.level == "safe");
    BOOST_TEST(v.reasons.empty());
    BOOST_TEST(verdictJson(v) == "{\"level\": \"safe\", \"reasons\": []}");
    const std::string heat = run.safety.heatmapCsv();
    BOOST_TEST(heat.rfind("x,y,max_density,max_contact_accel,seconds_above_density_threshold,"
                          "seconds_above_crush_threshold\n", 0) == 0);
    BOOST_TEST(std::count(heat.begin(), heat.end(), '\n') > 100);
}

BOOST_AUTO_TEST_CASE(base_case_door_is_at_least_dangerous) {
    ScenarioSpec spec = loadRepositoryScenario("Examples/doorway/base-case.xml");
    BOOST_REQUIRE(spec.policies.at(0).health.has_value());  // the base case carries the layer
    spec.endTime = 25;  // the queue at the door has formed long before
    const VerdictRun run(spec);
    const Verdict& v = run.verdict;
    BOOST_TEST_MESSAGE(verdictText(v));
    BOOST_TEST(verdictRank(v.level) >= 2, "verdict " << v.level);
    BOOST_REQUIRE(!v.reasons.empty());
    const VerdictReason& top = v.reasons.front();
    BOOST_TEST(top.level == v.level);
    BOOST_TEST(top.people > 0u);
    BOOST_TEST(top.duration >= 1.0);
    BOOST_TEST(top.firstTime >= 0.0);
    BOOST_TEST(top.firstTime < 25.0);
    BOOST_REQUIRE(top.hasWhere);
    // Where: at the door (x = 20 m, y in [9.6, 10.4]): the cells lie at the right of the room.
    BOOST_TEST(top.xmax > 18.0);
    BOOST_TEST(top.x > 12.0);
    BOOST_TEST(std::abs(top.y - 10.0) < 3.0);
    BOOST_TEST(top.xmin <= top.x);
    BOOST_TEST(top.x <= top.xmax);
    // summary.json carries it.
    RunInfo info;
    const std::string json = summaryJson(run.sim, info, MetricsPeaks{}, &v);
    BOOST_TEST(json.find("\"verdict\": {\"level\": \"" + v.level + "\", \"reasons\": [") != std::string::npos);
    BOOST_TEST(json.find("\"where\": {\"x\": ") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(injuries_make_it_critical) {
    // Two agents pressed into each other with a tiny injury dose: critical, with the crush place.
    std::vector<AgentSpec> agents = {agent(0, {0, 0}, {6, 0}, 0.3), agent(1, {1.5, 0}, {-5, 0}, 0.3)};
    PolicySpec p = policy(0, OptimisationMethod::Gradient,
                          {component("GoalReachingForce", {{"range", 0.0}}), component("ContactForces", {{"range", 1.0}})},
                          0.5, {}, StepTiming::Fine, 0.0);
    CrowdHealthSpec h;
    h.params = ParamSet(crowdHealthTable());
    h.params.set("crushThreshold", 10.0);
    h.params.set("injuryDose", 0.5);
    p.health = h;
    ScenarioSpec s = scenario(agents, {p}, 0.1, 4);
    s.deltaTimeFine = 0.02;
    const VerdictRun run(s);
    const Verdict& v = run.verdict;
    BOOST_TEST(v.level == "critical");
    BOOST_REQUIRE(!v.reasons.empty());
    BOOST_TEST(v.reasons.front().measure == "injured");
    BOOST_TEST(v.reasons.front().people == 2u);
    BOOST_TEST(v.reasons.front().hasWhere);
    BOOST_TEST(std::abs(v.reasons.front().x - 0.75) < 0.5);
}

BOOST_AUTO_TEST_CASE(safety_thresholds_from_xml_decide_the_verdict) {
    // Four agents in lanes 3 m apart: safe by the default thresholds; with <Safety> lowering the
    // density levels to 0.05 / 0.1 / 50 persons/m² the same run is "dangerous", by the file's
    // threshold, and the text no longer cites Still for it.
    ScenarioSpec spec = loadRepositoryScenario("Tests/data/health/safety.xml");
    const SafetyThresholds& t = spec.safety;
    BOOST_TEST(t.cellSize == 2.0);
    BOOST_TEST(t.gaussianRadius == 1.0);
    BOOST_TEST(t.densityCaution == 0.05);
    BOOST_TEST(t.densityDangerous == 0.1);
    BOOST_TEST(t.densityCritical == 50.0);
    BOOST_TEST(t.crowdPressureCritical == 0.5);
    BOOST_TEST(t.minDuration == 0.5);
    BOOST_TEST(t.doseDangerousFraction == 0.25);

    const VerdictRun strict(spec);
    BOOST_TEST_MESSAGE(verdictText(strict.verdict));
    BOOST_TEST(strict.verdict.level == "dangerous");
    BOOST_REQUIRE(!strict.verdict.reasons.empty());
    const VerdictReason& r = strict.verdict.reasons.front();
    BOOST_TEST(r.measure == "density");
    BOOST_TEST(r.threshold == 0.1);
    BOOST_TEST(r.people == 4u);
    BOOST_TEST(r.text.find("threshold set in <Safety>") != std::string::npos, r.text);
    BOOST_TEST(r.text.find("Still") == std::string::npos, r.text);
    // heatmap.csv follows the 2 m grid: cell centres at odd metres.
    std::istringstream heat(strict.safety.heatmapCsv());
    std::string header, firstRow;
    std::getline(heat, header);
    std::getline(heat, firstRow);
    const double x = std::stod(firstRow.substr(0, firstRow.find(',')));
    BOOST_TEST(std::fmod(std::abs(x), 2.0) == 1.0, "first heat-map row " << firstRow);

    spec.safety = SafetyThresholds{};
    const VerdictRun relaxed(spec);
    BOOST_TEST(relaxed.verdict.level == "safe", verdictText(relaxed.verdict));
}
