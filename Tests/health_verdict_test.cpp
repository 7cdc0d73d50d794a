// CrowdHealth tests — the safety verdict, the crowd measures on a grid and the heat map
// (Library/include/crowdhealth/health/safety.h): a sparse crowd walking freely is safe, the base-case
// door is at least dangerous.
#define BOOST_TEST_MODULE health_verdict
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/io/output.h"
#include "crowdhealth/health/safety.h"
#include "crowdhealth/io/xml.h"

#include <algorithm>
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

/// Two agents walking into each other for 4 s (goal force + contact, fine steps of 0.02 s), with
/// a crush threshold of 10 N (every contact adds dose) and the given injury dose (N s).
ScenarioSpec pushingPair(double injuryDose) {
    std::vector<AgentSpec> agents = {agent(0, {0, 0}, {6, 0}, 0.3), agent(1, {1.5, 0}, {-5, 0}, 0.3)};
    PolicySpec p = policy(0, OptimisationMethod::Gradient,
                          {component("GoalReachingForce", {{"range", 0.0}}), component("ContactForces", {{"range", 1.0}})},
                          0.5, {}, StepTiming::Fine, 0.0);
    CrowdHealthSpec h;
    h.params = ParamSet(crowdHealthTable());
    h.params.set("crushThreshold", 10.0);
    h.params.set("injuryDose", injuryDose);
    p.health = h;
    ScenarioSpec s = scenario(agents, {p}, 0.1, 4);
    s.deltaTimeFine = 0.02;
    return s;
}

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

namespace {
/// A 20 x 20 lattice of agents, `spacing` apart from (spacing/2, spacing/2), standing still.
AgentStore lattice(double spacing) {
    AgentStore a;
    for (int x = 0; x < 20; ++x)
        for (int y = 0; y < 20; ++y)
            a.add(agent(x * 20 + y, {spacing * (0.5 + x), spacing * (0.5 + y)}, {100, 0}), 0);
    return a;
}

/// The verdict of a recorder fed with recordCrowd() (no health records: an empty simulation).
Verdict crowdVerdict(const SafetyRecorder& r) {
    const Simulation empty(scenario({}, {policy(0, OptimisationMethod::Gradient,
                                                {component("GoalReachingForce", {{"range", 0.0}})})}));
    return r.verdict(empty);
}

/// Feeds `r` the lattice every 0.1 s from t0 for `seconds`, the velocity of agent i at step k
/// given by velocity(i, k). Returns the time reached.
template <class F>
double feed(SafetyRecorder& r, AgentStore& a, double t0, double seconds, F velocity) {
    const int steps = static_cast<int>(std::lround(seconds / 0.1));
    double t = t0;
    for (int k = 0; k < steps; ++k) {
        t = t0 + 0.1 * (k + 1);
        for (std::size_t i = 0; i < a.size(); ++i) a.vel[i] = velocity(i, k);
        r.recordCrowd(a, t);
    }
    return t;
}
}  // namespace

BOOST_AUTO_TEST_CASE(grid_density_and_local_velocity_follow_helbing_2007) {
    // A uniform block on a 0.5 m lattice (4 persons/m²) walking at 1 m/s along x: the local
    // density in the middle is close to 4 and the local velocity (1, 0).
    AgentStore a = lattice(0.5);
    for (Vec2& v : a.vel) v = Vec2(1.0, 0.0);
    CrowdField f = crowdField(a, 1.0, 0.7);
    const std::size_t mid = f.find(5, 5);  // the cell [5, 6) x [5, 6), centre (5.5, 5.5)
    BOOST_REQUIRE(mid < f.size());
    BOOST_TEST(std::abs(f.density[mid] - 4.0) < 0.05, "density " << f.density[mid]);
    BOOST_TEST((f.velocity[mid] - Vec2(1.0, 0.0)).norm() < 1e-12);
    BOOST_TEST(f.people[mid] == 4);
    // Alternate ±1 m/s along x from column to column: the Gaussian-weighted mean is close to 0.
    for (std::size_t i = 0; i < a.size(); ++i) a.vel[i] = Vec2((i / 20) % 2 ? 1.0 : -1.0, 0.0);
    f = crowdField(a, 1.0, 0.7);
    BOOST_TEST(f.velocity[mid].norm() < 0.1, "local velocity " << f.velocity[mid].transpose());
    // Far from every agent the local velocity is undefined.
    BOOST_TEST(f.weighted[mid] == 1);
}

BOOST_AUTO_TEST_CASE(crowd_pressure_is_the_variance_in_time_of_the_local_velocity) {
    // Helbing et al. 2007: P = rho * <|V(r,t) - U(r)|^2>_t. Columns walking in opposite
    // directions, steadily, vary in space but not in time: no pressure (the instantaneous
    // velocity variance, ~1 (m/s)^2 here, would give ~4 /s^2).
    AgentStore a = lattice(0.5);
    SafetyThresholds th;  // 5 s window
    SafetyRecorder steady(th);
    feed(steady, a, 0.0, 20.0, [](std::size_t i, int) { return Vec2((i / 20) % 2 ? 1.0 : -1.0, 0.0); });
    BOOST_TEST(steady.maxPressure() < 1e-9, "steady counter-flow " << steady.maxPressure());
    BOOST_TEST(verdictRank(crowdVerdict(steady).level) >= 1);  // the density is a reason, pressure is not
    for (const VerdictReason& r : crowdVerdict(steady).reasons) BOOST_TEST(r.measure != "crowd_pressure");

    // The whole block surging back and forth, +-1 m/s every 0.1 s: V(r,t) = +-1, variance 1, P ~ rho.
    SafetyRecorder surging(th);
    const auto surge = [](std::size_t, int k) { return Vec2(k % 2 ? 1.0 : -1.0, 0.0); };
    double t = feed(surging, a, 0.0, 1.0, surge);
    // One fifth of a window in, the time average has seen little of it (exponential window).
    const double early = surging.maxPressure();
    t = feed(surging, a, t, 29.0, surge);
    const double late = surging.maxPressure();
    BOOST_TEST(late > 3.6, "pressure after 6 windows " << late);
    BOOST_TEST(late < 4.4, "pressure after 6 windows " << late);
    BOOST_TEST(early < 0.35 * late, "pressure after 1 s " << early << " vs " << late);
    const Verdict v = crowdVerdict(surging);
    const auto pressure = std::find_if(v.reasons.begin(), v.reasons.end(),
                                       [](const VerdictReason& r) { return r.measure == "crowd_pressure"; });
    BOOST_REQUIRE(pressure != v.reasons.end());
    BOOST_TEST(pressure->firstTime < 1.0);  // 0.02 /s^2 is passed within the first second
    BOOST_TEST(pressure->duration > 28.0);

    // A longer window averages more slowly: after 1 s, less of the variance is seen.
    th.pressureWindow = 20.0;
    SafetyRecorder slow(th);
    feed(slow, a, 0.0, 1.0, surge);
    BOOST_TEST(slow.maxPressure() < 0.5 * early, "20 s window " << slow.maxPressure() << " vs 5 s " << early);
}

BOOST_AUTO_TEST_CASE(crowd_pressure_counts_only_in_dense_crowds) {
    // People passing the same place in different directions at low density (here a sparse
    // 2 m lattice, 0.25 persons/m^2, whose velocity flips every 0.1 s) also make the local
    // velocity vary in time: the pressure passes 0.02 /s^2, yet it is no reason in the verdict,
    // which counts pressure only above density_caution (Helbing et al. saw turbulence at 7-9 /m^2).
    AgentStore a = lattice(2.0);
    SafetyRecorder r{SafetyThresholds{}};
    feed(r, a, 0.0, 20.0, [](std::size_t, int k) { return Vec2(0.0, k % 2 ? 1.3 : -1.3); });
    BOOST_TEST(r.maxPressure() > 0.02);
    BOOST_TEST(crowdVerdict(r).level == "safe");
}

BOOST_AUTO_TEST_CASE(each_density_level_starts_at_its_threshold) {
    // Standing lattices whose interior density lies between two levels, held 3 s: the verdict is
    // the level below each density (the defaults: 2.17 caution, 4 dangerous, 6 critical). A level
    // tested at twice or half its threshold would move one of these.
    const struct { double density; const char* level; } cases[] = {
        {1.8, "safe"}, {3.0, "caution"}, {5.0, "dangerous"}, {7.0, "critical"}};
    for (const auto& c : cases) {
        BOOST_TEST_CONTEXT("density " << c.density) {
            AgentStore a = lattice(1.0 / std::sqrt(c.density));
            SafetyRecorder r{SafetyThresholds{}};
            feed(r, a, 0.0, 3.0, [](std::size_t, int) { return Vec2(0, 0); });
            const Verdict v = crowdVerdict(r);
            BOOST_TEST(v.level == c.level);
            if (v.level != std::string("safe")) {
                BOOST_REQUIRE(!v.reasons.empty());
                BOOST_TEST(v.reasons.front().measure == "density");
                BOOST_TEST(std::abs(v.reasons.front().duration - 2.9) < 1e-9);  // 29 records after the first
            }
        }
    }
}

BOOST_AUTO_TEST_CASE(a_condition_counts_once_it_held_the_minimum_duration) {
    // Density 5 (dangerous) for 0.7 s is no reason; for 1.4 s it is (min_duration 1 s).
    AgentStore a = lattice(1.0 / std::sqrt(5.0));
    SafetyRecorder brief{SafetyThresholds{}}, held{SafetyThresholds{}};
    feed(brief, a, 0.0, 0.8, [](std::size_t, int) { return Vec2(0, 0); });
    feed(held, a, 0.0, 1.5, [](std::size_t, int) { return Vec2(0, 0); });
    BOOST_TEST(crowdVerdict(brief).level == "safe");
    BOOST_TEST(crowdVerdict(held).level == "dangerous");
}

BOOST_AUTO_TEST_CASE(crowd_pressure_counts_above_its_threshold_only) {
    // A block at 4 persons/m^2 surging back and forth at +-a m/s: P tends to rho * a^2. At 1.5x
    // the default 0.02 /s^2 it is a reason, at 0.65x it is not.
    AgentStore a = lattice(0.5);
    auto pressureReason = [&](double target) {
        const double amplitude = std::sqrt(target / 4.0);
        SafetyRecorder r{SafetyThresholds{}};
        feed(r, a, 0.0, 40.0, [&](std::size_t, int k) { return Vec2(k % 2 ? amplitude : -amplitude, 0.0); });
        BOOST_TEST(std::abs(r.maxPressure() - target) < 0.1 * target, "pressure " << r.maxPressure());
        for (const VerdictReason& reason : crowdVerdict(r).reasons)
            if (reason.measure == "crowd_pressure") return true;
        return false;
    };
    BOOST_TEST(pressureReason(1.5 * 0.02));
    BOOST_TEST(!pressureReason(0.65 * 0.02));
}

BOOST_AUTO_TEST_CASE(crush_dose_is_dangerous_from_half_the_injury_dose) {
    // Two agents pushing into each other (crush threshold 10 N, so every contact adds dose). The
    // verdict is 'dangerous' (crush_dose) when the larger dose reaches half the injury dose
    // (dose_dangerous_fraction 0.5), 'caution' (crush_force) below that.
    auto runWith = [](double injuryDose) { return std::make_unique<VerdictRun>(pushingPair(injuryDose)); };
    double dose = 0;
    {
        const auto probe = runWith(1e12);
        for (const HealthRecord& r : probe->sim.health().records()) dose = std::max(dose, r.dose);
        BOOST_TEST(probe->verdict.level == "caution");
    }
    BOOST_REQUIRE(dose > 0);
    const auto over = runWith(dose / 0.7);   // 70 % of the injury dose
    const auto under = runWith(dose / 0.4);  // 40 %
    BOOST_TEST(over->verdict.level == "dangerous");
    BOOST_REQUIRE(!over->verdict.reasons.empty());
    BOOST_TEST(over->verdict.reasons.front().measure == "crush_dose");
    BOOST_TEST(under->verdict.level == "caution");
    BOOST_REQUIRE(!under->verdict.reasons.empty());
    BOOST_TEST(under->verdict.reasons.front().measure == "crush_force");
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
    BOOST_TEST(verdictJson(v) == "{\"level\":\"safe\",\"reasons\":[]}");
    const std::string heat = run.safety.heatmapCsv();
    BOOST_TEST(heat.rfind("x,y,max_density,max_contact_accel,seconds_above_density_threshold,"
                          "seconds_above_crush_threshold,worst_los\n", 0) == 0);
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
    const Json parsed = Json::parse(json);
    BOOST_TEST(parsed["verdict"]["level"].get<std::string>() == v.level);
    BOOST_REQUIRE(parsed["verdict"]["reasons"].size() == v.reasons.size());
    BOOST_TEST(parsed["verdict"]["reasons"][0]["where"]["x"].get<double>() == std::stod(formatNumber(top.x, 6)));
}

BOOST_AUTO_TEST_CASE(injuries_make_it_critical) {
    // Two agents pressed into each other with a tiny injury dose: critical, with the crush place.
    const VerdictRun run(pushingPair(0.5));
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
