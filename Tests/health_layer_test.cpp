// CrowdHealth tests — the CrowdHealth layer and schedules (Library/include/crowdhealth/health/health.h,
// scenario.h RampSpec): ramps hit their exact values, panic raises the preferred speed, contagion
// spreads along a line at the configured rate, the dose grows only above the threshold, injury
// lowers the speeds.
#define BOOST_TEST_MODULE health_layer
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/health/health.h"
#include "crowdhealth/io/output.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string_view>

using namespace ch;
using namespace ch::test;

namespace {

CrowdHealthSpec layer(const std::map<std::string, double>& values) {
    CrowdHealthSpec h;
    h.params = ParamSet(crowdHealthTable());
    for (const auto& [k, v] : values) h.params.set(k, v);
    return h;
}

/// One fine step per coarse step (dt = 0.02 s), goal force (+ contact forces when asked).
ScenarioSpec fineScenario(std::vector<AgentSpec> agents, bool contact, std::optional<CrowdHealthSpec> health,
                          double endTime = 10) {
    std::vector<ComponentSpec> comps = {component("GoalReachingForce", {{"range", 0.0}})};
    if (contact) comps.push_back(component("ContactForces", {{"range", 1.0}}));
    PolicySpec p = policy(0, OptimisationMethod::Gradient, comps, 0.5, {}, StepTiming::Fine, 0.0);
    p.health = std::move(health);
    ScenarioSpec s = scenario(std::move(agents), {p}, 0.02, endTime);
    s.deltaTimeFine = 0.02;
    return s;
}

const HealthRecord& recordOfId(const Simulation& sim, AgentId id) {
    for (const HealthRecord& r : sim.health().records())
        if (r.id == id) return r;
    throw std::runtime_error("no record");
}

}  // namespace

BOOST_AUTO_TEST_CASE(ramp_is_exact_at_both_ends_and_linear_between) {
    ScenarioSpec s = fineScenario({agent(0, {0, 0}, {100, 0})}, false, std::nullopt, 5);
    s.deltaTime = 0.1;  // 5 fine steps per coarse step
    RampSpec r;
    r.component = "GoalReachingForce";
    r.parameter = "strength";
    r.policyId = 0;
    r.from = 0.5;
    r.to = 2.5;
    r.start = 1.0;
    r.end = 3.0;
    s.ramps.push_back(r);
    RampSpec speed;
    speed.target = RampSpec::Target::Agents;
    speed.parameter = "pref_speed";
    speed.from = 1.0;
    speed.to = 1.8;
    speed.start = 2.0;
    speed.end = 4.0;
    s.ramps.push_back(speed);

    Simulation sim(s);
    BOOST_REQUIRE(sim.scheduleColumns().size() == 2u);
    BOOST_TEST(sim.scheduleColumns()[0] == "GoalReachingForce.strength");
    BOOST_TEST(sim.scheduleColumns()[1] == "agents.pref_speed");
    Component* goal = sim.policies()[0].findComponent("GoalReachingForce");
    BOOST_REQUIRE(goal != nullptr);
    BOOST_TEST(goal->parameter("strength") == 0.5);  // the first ramp holds `from` before its start
    bool sawStart = false, sawEnd = false, sawMiddle = false;
    while (!sim.finished()) {
        sim.stepCoarse();
        const double t = sim.time();
        const double v = goal->parameter("strength");
        if (std::abs(t - 1.0) < 1e-9) { BOOST_TEST(v == 0.5); sawStart = true; }
        else if (std::abs(t - 3.0) < 1e-9) { BOOST_TEST(v == 2.5); sawEnd = true; }
        else if (t < 1.0) BOOST_TEST(v == 0.5);
        else if (t > 3.0) BOOST_TEST(v == 2.5);
        else {
            BOOST_TEST(std::abs(v - (0.5 + (t - 1.0))) < 1e-12, "t = " << t << ": " << v);
            if (std::abs(t - 2.0) < 1e-9) { BOOST_TEST(std::abs(v - 1.5) < 1e-12); sawMiddle = true; }
        }
        const double ps = sim.agents().basePrefSpeed.at(0);
        const double want = t < 2.0 ? 1.0 : t > 4.0 ? 1.8 : 1.0 + 0.4 * (t - 2.0);
        BOOST_TEST(std::abs(ps - want) < 1e-12, "t = " << t << ": pref_speed " << ps);
        BOOST_TEST(std::abs(sim.scheduleValues()[1] - want) < 1e-12);
    }
    BOOST_TEST(sawStart);
    BOOST_TEST(sawEnd);
    BOOST_TEST(sawMiddle);
    BOOST_TEST(std::abs(sim.agents().basePrefSpeed.at(0) - 1.8) < 1e-15);
}

BOOST_AUTO_TEST_CASE(ramped_values_are_extra_metrics_columns) {
    ScenarioSpec s = fineScenario({agent(0, {0, 0}, {100, 0})}, false, std::nullopt, 2);
    RampSpec r;
    r.component = "GoalReachingForce";
    r.parameter = "strength";
    r.from = 1;
    r.to = 2;
    r.start = 0;
    r.end = 1;
    s.ramps.push_back(r);
    Simulation sim(s);
    MetricsRecorder m(0.5);
    m.sample(sim);
    while (!sim.finished()) {
        sim.stepCoarse();
        m.maybeSample(sim);
    }
    const std::string csv = m.csv();
    BOOST_TEST(csv.substr(0, csv.find('\n')) == std::string(kMetricsHeader) + ",GoalReachingForce.strength");
    BOOST_TEST(csv.find("\n0.5,") != std::string::npos);
    // The row of t = 0.5 s ends with the ramp's value 1.5, the row of t = 2 s with 2.
    const auto row = [&](const std::string& t) {
        const auto at = csv.find("\n" + t + ",");
        return csv.substr(at + 1, csv.find('\n', at + 1) - at - 1);
    };
    BOOST_TEST(row("0.5").substr(row("0.5").rfind(',') + 1) == "1.5");
    BOOST_TEST(row("2").substr(row("2").rfind(',') + 1) == "2");
}

BOOST_AUTO_TEST_CASE(panic_raises_preferred_speed_as_configured) {
    // Scheduled panic 0.5, panic speed 3 m/s: v_pref = 1 + 0.5 (3 - 1) = 2 m/s.
    auto run = [](std::map<std::string, double> values) {
        values.emplace("panicDecay", 0.0);
        values.emplace("contagionRate", 0.0);
        ScenarioSpec s = fineScenario({agent(0, {0, 0}, {100, 0}, 0.25, 1.0, 5.0)}, false, layer(values), 1);
        Simulation sim(s);
        sim.stepCoarse();
        return std::make_pair(sim.agents().prefSpeed.at(0), sim.agents().prefVel.at(0).norm());
    };
    const auto on = run({{"panic", 0.5}, {"panicSpeed", 3.0}});
    BOOST_TEST(std::abs(on.first - 2.0) < 1e-12);
    BOOST_TEST(std::abs(on.second - 2.0) < 1e-12);
    const auto off = run({{"panic", 0.5}, {"panicSpeed", 3.0}, {"panicSpeedEffect", 0.0}});
    BOOST_TEST(off.first == 1.0);
    const auto calm = run({{"panic", 0.0}, {"panicSpeed", 3.0}});
    BOOST_TEST(calm.first == 1.0);
    // A panic speed below the agent's own never slows it down.
    const auto slow = run({{"panic", 1.0}, {"panicSpeed", 0.5}});
    BOOST_TEST(slow.first == 1.0);

    // A panic event: the agent within its radius jumps to its strength at its time.
    ScenarioSpec s = fineScenario({agent(0, {0, 0}, {100, 0}, 0.25, 1.0, 5.0), agent(1, {0, 5}, {100, 5}, 0.25, 1.0, 5.0)},
                                  false, layer({{"panicDecay", 0.0}, {"contagionRate", 0.0}, {"panicSpeed", 2.0}}), 2);
    PanicEventSpec e;
    e.time = 0.5;
    e.position = Vec2(0.5, 0);
    e.radius = 2;
    e.strength = 0.8;
    s.panicEvents.push_back(e);
    Simulation sim(s);
    while (sim.time() < 0.5 - 1e-9) {
        sim.stepCoarse();
        BOOST_TEST(sim.agents().prefSpeed.at(0) == 1.0);
    }
    sim.stepCoarse();  // the step that starts at 0.5 s
    BOOST_TEST(recordOfId(sim, 0).panic == 0.8);
    BOOST_TEST(std::abs(sim.agents().prefSpeed.at(0) - 1.8) < 1e-12);
    BOOST_TEST(sim.agents().prefSpeed.at(1) == 1.0);  // outside the radius
    BOOST_TEST(recordOfId(sim, 1).panic == 0.0);
}

BOOST_AUTO_TEST_CASE(contagion_spreads_along_a_line_at_the_configured_rate) {
    auto panicsAfter = [](double rate, int steps) {
        std::vector<AgentSpec> line;
        for (int k = 0; k < 6; ++k) {
            AgentSpec a = agent(k, {0.8 * k, 0}, {0, 0}, 0.3);
            a.goal.reset();  // stands still
            line.push_back(a);
        }
        ScenarioSpec s = fineScenario(line, false,
                                      layer({{"panicDecay", 0.0}, {"contagionRate", rate}, {"contagionRadius", 1.0},
                                             {"contagionThreshold", 0.1}}),
                                      100);
        PanicEventSpec e;
        e.position = Vec2(0, 0);
        e.radius = 0.1;
        e.strength = 1.0;
        s.panicEvents.push_back(e);
        Simulation sim(s);
        for (int k = 0; k < steps; ++k) sim.stepCoarse();
        std::vector<double> p;
        for (int k = 0; k < 6; ++k) p.push_back(recordOfId(sim, k).panic);
        return p;
    };
    const double rate = 2.0, dt = 0.02;
    const int steps = 50;  // 1 s
    const std::vector<double> p = panicsAfter(rate, steps);
    BOOST_TEST(p[0] == 1.0);
    // Agent 1 follows dP/dt = rate (1 - P) from the step after the event (explicit Euler).
    const double expected1 = 1.0 - std::pow(1.0 - rate * dt, steps - 1);
    BOOST_TEST(std::abs(p[1] - expected1) < 1e-12, "P1 = " << p[1] << ", expected " << expected1);
    // Further along the line it arrives later, and only through the neighbours (0.8 m apart,
    // radius 1 m): each agent has less than the one before.
    for (int k = 1; k < 5; ++k) BOOST_TEST(p[k] > p[k + 1], "P" << k << " = " << p[k] << ", P" << k + 1 << " = " << p[k + 1]);
    BOOST_TEST(p[2] > 0.0);
    // Agent 2 starts once agent 1 passes the threshold: the first step with P1 >= 0.1.
    const std::vector<double> early = panicsAfter(rate, 4);
    BOOST_TEST(early[2] == 0.0);
    BOOST_TEST(early[1] > 0.0);
    // Twice the rate, faster spread.
    const std::vector<double> fast = panicsAfter(2 * rate, steps);
    for (int k = 1; k < 6; ++k) BOOST_TEST(fast[k] > p[k]);
    // No contagion at rate 0.
    const std::vector<double> none = panicsAfter(0.0, steps);
    for (int k = 1; k < 6; ++k) BOOST_TEST(none[k] == 0.0);
}

namespace {
/// Two agents walking into each other: contact forces rise and fall.
ScenarioSpec collision(const std::map<std::string, double>& health) {
    std::vector<AgentSpec> a = {agent(0, {0, 0}, {6, 0}, 0.3, 1.4, 1.8), agent(1, {1.5, 0.05}, {-5, 0.05}, 0.3, 1.4, 1.8)};
    return fineScenario(a, true, layer(health), 4);
}
}  // namespace

BOOST_AUTO_TEST_CASE(dose_grows_only_above_the_threshold) {
    // First find the peak force of this collision with a threshold no contact reaches.
    double peak = 0;
    {
        Simulation sim(collision({{"crushThreshold", 1e6}}));
        while (!sim.finished()) sim.stepCoarse();
        const HealthRecord& r = recordOfId(sim, 0);
        peak = r.peakForce;
        BOOST_TEST(r.dose == 0.0);
        BOOST_TEST(r.timeAboveThreshold == 0.0);
    }
    BOOST_REQUIRE(peak > 0);
    const double threshold = 0.5 * peak;
    Simulation sim(collision({{"crushThreshold", threshold}, {"injuryDose", 1e9}}));
    const double dt = sim.deltaTimeFine();
    int above = 0, belowButInContact = 0;
    double previousDose = 0, previousTime = 0;
    while (!sim.finished()) {
        sim.stepCoarse();  // one fine step
        const HealthRecord& r = recordOfId(sim, 0);
        const double force = r.lastForce;
        BOOST_TEST(std::abs(force - 80.0 * sim.agents().mass.at(0) * sim.agents().contactAccel.at(0).norm()) < 1e-9);
        if (force > threshold) {
            ++above;
            BOOST_TEST(std::abs(r.dose - (previousDose + force * dt)) < 1e-9);
            BOOST_TEST(std::abs(r.timeAboveThreshold - (previousTime + dt)) < 1e-12);
        } else {
            if (force > 0) ++belowButInContact;
            BOOST_TEST(r.dose == previousDose);
            BOOST_TEST(r.timeAboveThreshold == previousTime);
        }
        previousDose = r.dose;
        previousTime = r.timeAboveThreshold;
    }
    BOOST_TEST(above > 0);
    BOOST_TEST(belowButInContact > 0);
    BOOST_TEST(std::abs(recordOfId(sim, 0).peakForce - peak) < 1e-9);
}

BOOST_AUTO_TEST_CASE(injury_lowers_speed) {
    auto run = [](bool effect) {
        Simulation sim(collision({{"crushThreshold", 0.0}, {"injuryDose", 1.0}, {"injuredSpeedFactor", 0.5},
                                  {"injuredMaxSpeedFactor", 0.25}, {"injuryEffect", effect ? 1.0 : 0.0}}));
        double injuredAt = -1;
        while (!sim.finished() && injuredAt < 0) {
            sim.stepCoarse();
            if (recordOfId(sim, 0).injured()) injuredAt = sim.time();
        }
        BOOST_REQUIRE(injuredAt > 0);
        BOOST_TEST(recordOfId(sim, 0).injuredAt == injuredAt);
        BOOST_TEST(recordOfId(sim, 0).dose >= 1.0);
        sim.stepCoarse();  // the speeds in effect are set at the start of the next step
        return std::make_pair(sim.agents().prefSpeed.at(0), sim.agents().maxSpeed.at(0));
    };
    const auto hurt = run(true);
    BOOST_TEST(std::abs(hurt.first - 0.7) < 1e-12);
    BOOST_TEST(std::abs(hurt.second - 0.45) < 1e-12);
    const auto unaffected = run(false);  // still injured (recorded), no effect on motion
    BOOST_TEST(unaffected.first == 1.4);
    BOOST_TEST(unaffected.second == 1.8);

    // Without a <CrowdHealth> element the injury is recorded but changes nothing.
    ScenarioSpec s = collision({});
    s.policies[0].health.reset();
    Simulation sim(s);
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(sim.health().injuredCount() == 0u);  // default thresholds: 4500 N, 135 kN s
}

BOOST_AUTO_TEST_CASE(injury_slows_the_agents_actual_motion) {
    // The two agents of collision() push past each other (they are 5 cm off axis); agent 0 is
    // injured in the contact and then walks on alone to (16, 0). Its speed once clear of the
    // other is the injured preferred speed (0.5 x 1.4), capped by the injured maximum, not
    // 1.4: the layer changes how the agent moves, not only the numbers it records.
    auto speedsAfter = [](bool effect) {
        ScenarioSpec s = collision({{"crushThreshold", 0.0}, {"injuryDose", 1.0}, {"injuredSpeedFactor", 0.5},
                                    {"injuredMaxSpeedFactor", 0.6}, {"injuryEffect", effect ? 1.0 : 0.0}});
        s.agents[0].goal = Vec2(16, 0);
        s.endTime = 10;
        Simulation sim(s);
        std::vector<double> speeds;  // agent 0's speed, once it is clear of agent 1 and injured
        while (!sim.finished()) {
            sim.stepCoarse();
            const AgentStore& a = sim.agents();
            std::size_t i0 = a.size(), i1 = a.size();
            for (std::size_t i = 0; i < a.size(); ++i) (a.id[i] == 0 ? i0 : i1) = i;
            BOOST_REQUIRE(i0 < a.size());
            const bool clear = i1 == a.size() || (a.pos[i0] - a.pos[i1]).norm() > 3.0;
            if (clear && recordOfId(sim, 0).injured() && a.pos[i0].x() < 14) speeds.push_back(a.vel[i0].norm());
        }
        return speeds;
    };
    const std::vector<double> hurt = speedsAfter(true);
    const std::vector<double> unaffected = speedsAfter(false);
    BOOST_REQUIRE(hurt.size() > 50u);       // it was injured and walked on for over a second
    BOOST_REQUIRE(unaffected.size() > 50u);
    // After the relaxation (tau = 0.5 s) towards the injured preferred speed: the last second.
    for (std::size_t k = hurt.size() - 50; k < hurt.size(); ++k) BOOST_TEST(std::abs(hurt[k] - 0.7) < 0.02, hurt[k]);
    for (double v : hurt) BOOST_TEST(v <= 0.6 * 1.8 + 1e-12);  // never above the injured maximum speed
    for (std::size_t k = unaffected.size() - 50; k < unaffected.size(); ++k)
        BOOST_TEST(std::abs(unaffected[k] - 1.4) < 0.02, unaffected[k]);
}

BOOST_AUTO_TEST_CASE(layer_is_thread_count_independent) {
    auto run = [](int threads) {
        std::vector<AgentSpec> agents;
        for (int k = 0; k < 30; ++k) agents.push_back(agent(k, {0.7 * (k % 6), 0.7 * (k / 6)}, {20, 2}, 0.3, 1.2, 2.0));
        ScenarioSpec s = fineScenario(agents, true,
                                      layer({{"erratic", 1.0}, {"herding", 1.0}, {"panic", 0.3}, {"contagionRate", 1.0}}), 3);
        Simulation sim(s);
        sim.setThreads(threads);
        while (!sim.finished()) sim.stepCoarse();
        return healthCsv(sim.health());
    };
    BOOST_TEST(run(1) == run(2));
}

BOOST_AUTO_TEST_CASE(both_builds_of_the_end_of_step_give_the_same_bits) {
    // endStep's per-agent part is compiled for any x86-64 (0) and with AVX2 (1), chosen when the
    // program starts (crowdhealth-bench --isa switches it). Erratic, panicking walkers in contact
    // turn at every step, so each record's heading change sums many angles of simd::angleOf: every
    // record's bits must be the same from both builds, on one thread and on two.
    auto run = [](int threads) {
        std::vector<AgentSpec> agents;
        for (int k = 0; k < 30; ++k) agents.push_back(agent(k, {0.7 * (k % 6), 0.7 * (k / 6)}, {20, 2}, 0.3, 1.2, 2.0));
        ScenarioSpec s = fineScenario(agents, true, layer({{"erratic", 1.0}, {"panic", 0.3}, {"contagionRate", 1.0}}), 3);
        Simulation sim(s);
        sim.setThreads(threads);
        while (!sim.finished()) sim.stepCoarse();
        std::vector<std::uint64_t> bits;
        for (const HealthRecord& r : sim.health().records())
            for (const double v : {r.headingChange, r.movingTime, r.lastHeading.x(), r.lastHeading.y(), r.peakForce,
                                   r.lastForce, r.dose, r.panic, static_cast<double>(r.id)}) {
                std::uint64_t b;
                std::memcpy(&b, &v, sizeof b);
                bits.push_back(b);
            }
        return std::pair{bits, sim.health().records()};
    };
    const int before = HealthLayer::endStepPath();
    BOOST_TEST(!HealthLayer::setEndStepPath(2));  // no such build
    BOOST_TEST(!HealthLayer::setEndStepPath(-1));
    BOOST_TEST(HealthLayer::endStepPath() == before);
    BOOST_REQUIRE(HealthLayer::setEndStepPath(0));
    const auto [generic, records] = run(1);
    std::size_t turned = 0;
    for (const HealthRecord& r : records) turned += r.headingChange > 0.1;
    BOOST_TEST(turned >= 20u);  // the angles are there to compare
    BOOST_TEST((run(2).first == generic));
    if (!HealthLayer::setEndStepPath(1)) {
        BOOST_TEST_MESSAGE("this CPU has no AVX2: only the generic build ran");
    } else {
        BOOST_TEST(HealthLayer::endStepPath() == 1);
        BOOST_TEST((run(1).first == generic));
        BOOST_TEST((run(2).first == generic));
    }
    HealthLayer::setEndStepPath(before);
}

BOOST_AUTO_TEST_CASE(health_csv_in_pieces_is_the_whole_text) {
    // The streamed health.csv (the program writes it piece by piece) is the text of healthCsv(),
    // in pieces of about 1 MiB: 40,000 agents (~1.2 MB) give at least two.
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 40000; ++k) agents.push_back(agent(k, {0.7 * (k % 200), 0.7 * (k / 200)}, {200, 2}));
    ScenarioSpec s = fineScenario(agents, true, layer({}), 1);
    Simulation sim(s);
    sim.setThreads(1);
    sim.stepCoarse();
    const std::string whole = healthCsv(sim.health());
    std::string joined;
    std::size_t pieces = 0, largest = 0;
    healthCsv(sim.health(), [&](std::string_view piece) {
        ++pieces;
        largest = std::max(largest, piece.size());
        BOOST_TEST((!piece.empty() && piece.back() == '\n'));  // whole rows only
        joined += piece;
    });
    BOOST_TEST(whole.size() > 1000000u);
    BOOST_TEST((joined == whole));
    BOOST_TEST(pieces >= 2u);
    BOOST_TEST(largest <= (1u << 20) + 1000u);  // a piece ends with the row that fills a MiB
    BOOST_TEST(std::count(whole.begin(), whole.end(), '\n') == 40001);
}

BOOST_AUTO_TEST_CASE(heading_change_is_the_mean_turn_rate_while_moving) {
    // Agents whose velocity turns by a fixed angle every step, some left, some right, from a
    // hair to almost a U-turn; one below the heading speed (0.1 m/s) all along. Seven agents: one
    // block of the layer's four lanes and a partial one. The record's mean is Σ|turn| over the
    // seconds it moved with a heading before: the turn per step over dt.
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 7; ++k) agents.push_back(agent(k, {2.0 * k, 0}, {2.0 * k, 50}));
    Simulation sim(fineScenario(agents, false, layer({}), 1));
    AgentStore a = sim.agents();  // a copy whose velocities this test sets
    HealthLayer& h = sim.health();
    const double turn[7] = {1e-7, -0.05, 0.3, -1.2, 2.0, -3.1, 0.4};
    const double speed[7] = {1.0, 1.3, 0.8, 1.0, 2.0, 1.1, 0.05};
    const double dt = 0.1;
    const int steps = 40;
    for (int s = 0; s < steps; ++s) {
        for (std::size_t i = 0; i < a.size(); ++i) {
            const double angle = 0.7 * static_cast<double>(i) + s * turn[i];
            a.vel[i] = speed[i] * Vec2(std::cos(angle), std::sin(angle));
        }
        h.endStep(a, (s + 1) * dt, dt);
    }
    for (std::size_t i = 0; i < a.size(); ++i) {
        const HealthRecord& r = h.recordOf(a, i);
        if (speed[i] < 0.1) {
            BOOST_TEST(r.movingTime == 0.0);
            BOOST_TEST(r.meanAbsHeadingChange() == 0.0);
            continue;
        }
        BOOST_TEST(std::abs(r.movingTime - (steps - 1) * dt) < 1e-12);  // no turn at the first step
        const double want = std::abs(turn[i]) / dt;
        BOOST_TEST(std::abs(r.meanAbsHeadingChange() - want) <= 1e-9 * want + 1e-13, "agent " << i << ": " << r.meanAbsHeadingChange() << " rad/s, want " << want);
    }
}

BOOST_AUTO_TEST_CASE(crush_summary_counts_whoever_is_above_on_any_thread) {
    // endStep's per-agent part runs on the team, each thread over its blocks of agents; the
    // crowd-level crush summary is then taken in agent order, and only when some thread saw an
    // agent above its threshold. Twelve agents (three blocks of the layer's four lanes), one of
    // them pressed (80 kg · 1 · 100 m/s² = 8000 N > 4500 N): the first, one in the middle block or
    // the last, on one thread and on two.
    for (const std::size_t pressed : {std::size_t{0}, std::size_t{6}, std::size_t{11}}) {
        for (const int threads : {1, 2}) {
            omp_set_num_threads(threads);
            std::vector<AgentSpec> agents;
            for (int k = 0; k < 12; ++k) agents.push_back(agent(k, {2.0 * k, 1.0}, {2.0 * k, 50}));
            Simulation sim(fineScenario(agents, false, layer({}), 1));
            AgentStore a = sim.agents();
            HealthLayer& h = sim.health();
            const double dt = 0.1;
            for (int s = 0; s < 3; ++s) {
                for (std::size_t i = 0; i < a.size(); ++i) a.contactAccel[i] = Vec2(i == pressed ? 100.0 : 1.0, 0.0);
                h.endStep(a, (s + 1) * dt, dt);
            }
            const CrushSummary& c = h.crush();
            BOOST_TEST(c.samples == 3u, "pressed " << pressed << ", " << threads << " threads");
            BOOST_TEST(std::abs(c.seconds - 3 * dt) < 1e-12);
            BOOST_TEST(c.xmin == 2.0 * static_cast<double>(pressed));
            BOOST_TEST(c.xmax == 2.0 * static_cast<double>(pressed));
            BOOST_TEST(std::abs(c.firstTime - 0.0) < 1e-12);
        }
    }
    omp_set_num_threads(2);
}
