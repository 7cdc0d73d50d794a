// Falls and helping (the CrowdHealth layer's `falls` and `helping`, docs/crowd-health.md): a person
// pressed hard enough falls, lies still as a larger body that the others walk round, and gets up
// later; a member of its group comes, stands beside it, and both leave together once it is up; the
// verdict names the fall with its time and place; results are the same on 1 and 2 threads; bad
// settings are errors at their line. Each behaviour is checked against the same scene without the
// setting, so the test fails when the setting does nothing.
#define BOOST_TEST_MODULE falls_help
#include <boost/test/unit_test.hpp>

#include "scenario_files.h"

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/health/safety.h"

#include <cmath>
#include <map>
#include <sstream>

using namespace ch;
using ch::test::load;

namespace {

/// A 40 m corridor 4 m wide (y in [-2, 2]). Policy 0: social forces + goal force, UMANS' contact,
/// with <CrowdHealth> `walkers`. Policy 1: the same steps, with <CrowdHealth> `casualty` (low crush
/// thresholds, so that its agents fall at the first contact).
std::string corridor(const std::string& walkers, const std::string& casualty, const std::string& agents,
                     double endTime = 40) {
    std::ostringstream s;
    const char* steps = R"(
      <costfunction name="SocialForcesAvoidance" range="5" />
      <costfunction name="GoalReachingForce" />)";
    s << R"(<Simulation delta_time="0.1" end_time=")" << endTime << R"(" seed="3">
  <World type="Infinite">
    <Obstacles>
      <Obstacle><Point x="-5" y="-2" /><Point x="45" y="-2" /></Obstacle>
      <Obstacle><Point x="-5" y="2" /><Point x="45" y="2" /></Obstacle>
    </Obstacles>
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">)"
      << steps << "\n      <CrowdHealth " << walkers << " />" << R"(
    </Policy>
    <Policy id="1" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">)"
      << steps << "\n      <CrowdHealth " << casualty << " />" << R"(
    </Policy>
  </Policies>
  <Agents>
)" << agents << R"(
  </Agents>
</Simulation>
)";
    return s.str();
}

std::string agent(double x, double y, double gx, double gy, double speed, int policy, const std::string& group = "") {
    std::ostringstream s;
    s << "    <Agent rad=\"0.25\" pref_speed=\"" << speed << "\" max_speed=\"" << speed * 1.3 << "\""
      << (group.empty() ? "" : " group=\"" + group + "\"") << "><pos x=\"" << x << "\" y=\"" << y << "\" /><goal x=\""
      << gx << "\" y=\"" << gy << "\" /><Policy id=\"" << policy << "\" /></Agent>\n";
    return s.str();
}

ScenarioSpec loaded(const std::string& name, const std::string& xml) {
    const auto l = load(name, xml);
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    return *l.spec;
}

const HealthRecord* recordOf(const Simulation& sim, AgentId id) {
    for (const HealthRecord& r : sim.health().records())
        if (r.id == id) return &r;
    return nullptr;
}

bool find(const AgentStore& a, AgentId id, std::size_t& i) {
    for (i = 0; i < a.size(); ++i)
        if (a.id[i] == id) return true;
    return false;
}

// The casualty (agent 0, policy 1) starts 0.1 m into the north wall: the wall's contact force
// (about 500 N) gives it its fall dose in the first step. Agent 1 (policy 0, its group) starts 2 m
// behind, in the middle of the corridor, where nothing touches it.
const char* kCasualty = R"(falls="true" crushThreshold="100" injuryDose="1" fallDose="2" getUpTime="30")";
std::string familyScene(const std::string& walkers) {
    return corridor(walkers, kCasualty,
                    agent(5, 1.85, 40, 1.6, 1.2, 1, "family") + agent(3, 0, 40, 0, 1.2, 0, "family"));
}

struct HelpTrace {
    double fellAt = NAN, gotUpAt = NAN;
    double stillSeconds = 0;      ///< seconds the helper stood (< 0.1 m/s) beside the casualty while it was down
    double maxGapUp = 0;          ///< largest helper-casualty distance after the casualty got up
    double helperSpeedUp = 0, casualtySpeedUp = 0;  ///< their mean speeds then (m/s)
    double helperBack = 0;        ///< seconds the helper walked back (west) then
    double helperX = 0, casualtyX = 0;  ///< final x (or at arrival)
    double helpTime = 0;
    int helpers = 0;
    // The casualty's own help record (it fell and was helped, it helped nobody), and how many
    // people the helper had (none).
    double casualtyHelpTime = -1, casualtyHelpDose = -1;
    AgentId casualtyHelped = -2;
    int helperHelpers = -1;
    std::size_t fallenCount = 0, helperCount = 0, helpedCount = 0;  ///< the layer's counts at the end
};

HelpTrace runFamily(const std::string& walkers) {
    Simulation sim(loaded("family.xml", familyScene(walkers)));
    HelpTrace t;
    int samples = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& a = sim.agents();
        std::size_t c = 0, h = 0;
        if (!find(a, 0, c) || !find(a, 1, h)) break;
        const HealthRecord& rc = *recordOf(sim, 0);
        const double gotUpAt = sim.health().careOf(rc).gotUpAt;
        const double gap = (a.pos[c] - a.pos[h]).norm();
        if (rc.fallen && a.vel[h].norm() < 0.1 && gap < 1.5) t.stillSeconds += sim.deltaTime();
        if (gotUpAt == gotUpAt && sim.time() > gotUpAt + 3) {
            t.maxGapUp = std::max(t.maxGapUp, gap);
            t.helperSpeedUp += a.vel[h].norm();
            t.casualtySpeedUp += a.vel[c].norm();
            if (a.vel[h].x() < -0.05) t.helperBack += sim.deltaTime();
            ++samples;
        }
        t.helperX = a.pos[h].x();
        t.casualtyX = a.pos[c].x();
    }
    if (samples > 0) {
        t.helperSpeedUp /= samples;
        t.casualtySpeedUp /= samples;
    }
    const CareRecord& rc = sim.health().careOf(*recordOf(sim, 0));
    t.fellAt = rc.fellAt;
    t.gotUpAt = rc.gotUpAt;
    t.helpers = rc.helpers;
    t.helpTime = sim.health().careOf(*recordOf(sim, 1)).helpTime;
    t.casualtyHelpTime = rc.helpTime;
    t.casualtyHelpDose = rc.helpDose;
    t.casualtyHelped = rc.firstHelped;
    t.helperHelpers = sim.health().careOf(*recordOf(sim, 1)).helpers;
    t.fallenCount = sim.health().fallenCount();
    t.helperCount = sim.health().helperCount();
    t.helpedCount = sim.health().helpedCount();
    return t;
}

}  // namespace

BOOST_AUTO_TEST_CASE(a_family_member_stops_beside_the_fallen_person_and_both_leave_later) {
    const HelpTrace help = runFamily(R"(helping="true" helpTime="5")");
    const HelpTrace alone = runFamily(R"(helping="false")");
    BOOST_TEST_MESSAGE("with help: fell " << help.fellAt << " s, up " << help.gotUpAt << " s, helper still "
                                          << help.stillSeconds << " s, gap after " << help.maxGapUp << " m, x "
                                          << help.helperX << " / " << help.casualtyX);
    BOOST_TEST_MESSAGE("without: up " << alone.gotUpAt << " s, x " << alone.helperX << " / " << alone.casualtyX);
    BOOST_TEST(help.fellAt < 0.5);
    BOOST_TEST(help.helpers == 1);
    // The helper comes (2 m at 1.2 m/s) and stands beside it; it gets up 5 s (helpTime) after that.
    BOOST_TEST(help.stillSeconds > 3.0, "the helper stands beside the person on the floor");
    BOOST_TEST(help.gotUpAt > 5.0);
    BOOST_TEST(help.gotUpAt < 10.0);
    BOOST_TEST(alone.gotUpAt == 30.0 + alone.fellAt, boost::test_tools::tolerance(0.11));
    // Both leave: the injured one walks at half speed and the helper stays with it.
    BOOST_TEST(help.casualtyX > 15.0, "the person helped up walks on");
    BOOST_TEST(help.maxGapUp < 2.5, "the helper walks with it (escortDistance 1.5 m)");
    BOOST_TEST_MESSAGE("speeds while leaving: helper " << help.helperSpeedUp << ", helped " << help.casualtySpeedUp << " m/s");
    BOOST_TEST_MESSAGE("helper walked back " << help.helperBack << " s");
    BOOST_TEST(std::abs(help.helperSpeedUp - help.casualtySpeedUp) < 0.1, "at the pace of the person it helps");
    BOOST_TEST(help.helperBack < 0.5, "walking with it, not to and fro");
    BOOST_TEST(help.helpTime > 30.0, "helping lasts from the fall to the end of the run");
    // Help is counted for the helper alone: the person on the floor helped nobody, nobody helped
    // the helper.
    BOOST_TEST(help.casualtyHelpTime == 0.0);
    BOOST_TEST(help.casualtyHelpDose == 0.0);
    BOOST_TEST(help.casualtyHelped == -1);
    BOOST_TEST(help.helperHelpers == 0);
    BOOST_TEST(help.fallenCount == 1u);
    BOOST_TEST(help.helperCount == 1u);
    BOOST_TEST(help.helpedCount == 1u);
    BOOST_TEST(alone.helperCount == 0u);
    BOOST_TEST(alone.helpedCount == 0u);
    // Without help the other member walks away at its own speed.
    BOOST_TEST(alone.stillSeconds < 0.5);
    BOOST_TEST(alone.helperX - alone.casualtyX > 20.0);
}

BOOST_AUTO_TEST_CASE(a_fallen_body_is_an_obstacle_the_others_walk_round) {
    // Agents 0 and 1 (policy 1) start overlapping in the middle of the corridor at x = 12 and fall
    // at once; 12 walkers (policy 0) come from the west and must pass them.
    std::string agents = agent(12, -0.15, 12, -0.15, 1.0, 1) + agent(12, 0.15, 12, 0.15, 1.0, 1);
    for (int k = 0; k < 12; ++k) agents += agent(0 - 1.0 * (k / 4), -1.2 + 0.8 * (k % 4), 40, -1.2 + 0.8 * (k % 4), 1.2, 0);
    const std::string casualty = R"(falls="true" crushThreshold="100" injuryDose="1" fallDose="2" getUpTime="1000" fallenRadius="0.6")";
    Simulation sim(loaded("bodies.xml", corridor("", casualty, agents, 45)));
    double worst = 1e9;  // smallest gap between a walker's edge and a body's edge
    Vec2 body0(0, 0);
    double bodyMoved = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& a = sim.agents();
        std::size_t b0 = 0, b1 = 0;
        BOOST_TEST_REQUIRE(find(a, 0, b0));
        BOOST_TEST_REQUIRE(find(a, 1, b1));
        if (sim.time() < 2) {
            body0 = a.pos[b0];
            continue;
        }
        bodyMoved = std::max(bodyMoved, (a.pos[b0] - body0).norm());
        // ... and has no velocity, which walkers' models and the outputs read.
        BOOST_TEST_REQUIRE(a.vel[b0].norm() == 0.0);
        BOOST_TEST_REQUIRE(a.vel[b1].norm() == 0.0);
        BOOST_TEST_REQUIRE(a.radius[b0] == 0.6);  // grown to the body on the floor within 1 s
        for (std::size_t i = 0; i < a.size(); ++i) {
            if (a.id[i] < 2) continue;
            for (std::size_t b : {b0, b1}) worst = std::min(worst, (a.pos[i] - a.pos[b]).norm() - a.radius[i] - a.radius[b]);
        }
    }
    std::size_t past = 0;
    for (std::size_t i = 0; i < sim.agents().size(); ++i) past += sim.agents().id[i] >= 2 && sim.agents().pos[i].x() > 20;
    BOOST_TEST_MESSAGE("closest walker edge to a body's edge " << worst << " m; body moved " << bodyMoved << " m; "
                                                            << past << " walkers arrived");
    BOOST_TEST(sim.health().fallenCount() == 2u);
    BOOST_TEST(bodyMoved == 0.0, "a body on the floor lies still");
    // Walkers press against the body as against anyone in a crowd (about 13 cm at most here, pushed
    // by those behind), but no walker's centre ever enters the body.
    BOOST_TEST(worst > -0.25, "nobody walks through a body");
    BOOST_TEST(past == 12u, "everybody gets past");

    // The verdict names the falls: critical, with the first fall's time and place.
    SafetyRecorder safety;
    safety.record(sim);
    const Verdict v = safety.verdict(sim);
    BOOST_TEST(v.level == "critical");
    const auto it = std::find_if(v.reasons.begin(), v.reasons.end(), [](const VerdictReason& r) { return r.measure == "fallen"; });
    BOOST_TEST_REQUIRE((it != v.reasons.end()));
    BOOST_TEST(it->people == 2u);
    BOOST_TEST(it->firstTime < 0.5);
    BOOST_TEST(it->hasWhere);
    BOOST_TEST(std::abs(it->x - 12.0) < 0.5);
    BOOST_TEST(it->text.find("at (12") != std::string::npos, it->text);
}

BOOST_AUTO_TEST_CASE(a_body_stops_a_walker_that_only_has_contact_forces) {
    // Policy 0 without avoidance (goal force and UMANS' contact): the walker walks straight at the
    // body and is held by contact alone; the neighbour range must cover the body on the floor.
    std::string xml = corridor("", R"(falls="true" crushThreshold="100" injuryDose="1" fallDose="2" getUpTime="1000" fallenRadius="0.6")",
                               agent(12, -0.15, 12, -0.15, 1.0, 1) + agent(12, 0.15, 12, 0.15, 1.0, 1) + agent(2, 0, 40, 0, 1.2, 0), 20);
    const std::string avoidance = R"(<costfunction name="SocialForcesAvoidance" range="5" />)";
    xml.erase(xml.find(avoidance), avoidance.size());
    Simulation sim(loaded("contact.xml", xml));
    double worst = 1e9;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& a = sim.agents();
        std::size_t w = 0, b = 0;
        BOOST_TEST_REQUIRE(find(a, 2, w));
        for (AgentId id : {0, 1})
            if (find(a, id, b)) worst = std::min(worst, (a.pos[w] - a.pos[b]).norm() - a.radius[w] - a.radius[b]);
    }
    BOOST_TEST_MESSAGE("contact only: closest edge gap " << worst << " m");
    // About 11 cm at the first impact (1.2 m/s against a stiffness of 62.5 1/s^2); with a neighbour
    // range that misses the body's extra radius the walker gets 43 cm in.
    BOOST_TEST(worst > -0.15);
}

BOOST_AUTO_TEST_CASE(without_falls_the_same_pressure_only_injures) {
    // The body scene with falls off: the two are injured but nobody falls or is pinned.
    const std::string casualty = R"(crushThreshold="100" injuryDose="1" fallDose="2")";
    Simulation sim(loaded("nofall.xml", corridor("", casualty, agent(12, -0.15, 12, -0.15, 1.0, 1) + agent(12, 0.15, 12, 0.15, 1.0, 1), 5)));
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(sim.health().injuredCount() == 2u);
    BOOST_TEST(sim.health().fallenCount() == 0u);
    BOOST_TEST(sim.health().fallEvents().empty());
}

BOOST_AUTO_TEST_CASE(a_stranger_helps_only_with_its_probability) {
    // No group: agent 1 is a stranger 2 m away. helpStranger 1 → it helps; 0 → it walks on.
    // The casualty's own policy helps too, with a larger radius: the stranger's own helpRadius counts.
    auto run = [](const std::string& walkers) {
        const std::string casualty = std::string(kCasualty) + R"( helping="true" helpRadius="5")";
        Simulation sim(loaded("stranger.xml", corridor(walkers, casualty, agent(5, 1.85, 40, 1.6, 1.2, 1) + agent(3, 0, 40, 0, 1.2, 0), 20)));
        while (!sim.finished()) sim.stepCoarse();
        return std::pair(sim.health().careOf(*recordOf(sim, 0)).helpers, sim.health().careOf(*recordOf(sim, 1)).helpTime);
    };
    const auto yes = run(R"(helping="true" helpStranger="1" helpRadius="3")");
    const auto no = run(R"(helping="true" helpStranger="0" helpRadius="3")");
    const auto far = run(R"(helping="true" helpStranger="1" helpRadius="1")");
    BOOST_TEST(yes.first == 1);
    BOOST_TEST(yes.second > 10.0);
    BOOST_TEST(no.first == 0);
    BOOST_TEST(far.first == 0, "a stranger beyond helpRadius does not notice");
}

BOOST_AUTO_TEST_CASE(falls_and_help_are_the_same_on_one_and_two_threads) {
    // 60 people in groups of three press through a 1 m door; falls at a low dose, strangers help
    // with probability 0.5. health.csv must be byte-identical on 1 and 2 threads, and the scene
    // must produce falls and help (else the comparison proves nothing).
    std::ostringstream a;
    for (int k = 0; k < 60; ++k)
        a << "    <Agent rad=\"0.25\" pref_speed=\"1.5\" max_speed=\"2\" group=\"g" << k / 3 << "\"><pos x=\""
          << 2 + 0.7 * (k % 10) << "\" y=\"" << -1.75 + 0.7 * (k / 10) << "\" /><goal x=\"30\" y=\"0\" /><Policy id=\"0\" /></Agent>\n";
    const std::string xml = R"(<Simulation delta_time="0.1" end_time="40" seed="5">
  <World type="Infinite">
    <Obstacles>
      <Obstacle><Point x="0" y="-2" /><Point x="10" y="-2" /></Obstacle>
      <Obstacle><Point x="0" y="2" /><Point x="10" y="2" /></Obstacle>
      <Obstacle><Point x="0" y="-2" /><Point x="0" y="2" /></Obstacle>
      <Obstacle><Point x="10" y="-2" /><Point x="10" y="-0.5" /></Obstacle>
      <Obstacle><Point x="10" y="0.5" /><Point x="10" y="2" /></Obstacle>
    </Obstacles>
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
      <costfunction name="SocialForcesAvoidance" range="5" />
      <costfunction name="GoalReachingForce" />
      <costfunction name="SocialGroups" />
      <CrowdHealth crushThreshold="300" injuryDose="150" falls="true" fallDose="300" getUpTime="8" fallenRadius="0.45"
                   helping="true" helpGroup="0.7" helpStranger="0.5" helpTime="3" />
    </Policy>
  </Policies>
  <Agents>
)" + a.str() + R"(  </Agents>
</Simulation>
)";
    const ScenarioSpec spec = loaded("threads.xml", xml);
    auto run = [&](int threads) {
        Simulation sim(spec);
        sim.setThreads(threads);
        while (!sim.finished()) sim.stepCoarse();
        return std::tuple(healthCsv(sim.health()), sim.health().fallenCount(), sim.health().helperCount());
    };
    const auto [one, fallen, helpers] = run(1);
    const auto [two, fallen2, helpers2] = run(2);
    BOOST_TEST_MESSAGE(fallen << " fell, " << helpers << " helped");
    BOOST_TEST(fallen > 0u);
    BOOST_TEST(helpers > 0u);
    BOOST_TEST((one == two));
}

BOOST_AUTO_TEST_CASE(bad_settings_are_errors_at_their_line) {
    const auto bad = load("bad.xml", corridor(R"(helping="true" helpGroup="1.5")", R"(falls="true" fallenRadius="3")",
                                              agent(0, 0, 10, 0, 1, 0)));
    BOOST_TEST(!bad.spec.has_value());
    BOOST_TEST(bad.messages.find("bad.xml:12: error") != std::string::npos, bad.messages);
    BOOST_TEST(bad.messages.find("helpGroup") != std::string::npos, bad.messages);
    BOOST_TEST(bad.messages.find("bad.xml:17: error") != std::string::npos, bad.messages);
    BOOST_TEST(bad.messages.find("fallenRadius") != std::string::npos, bad.messages);

    std::string ramp = corridor(R"(helping="true")", kCasualty, agent(0, 0, 10, 0, 1, 0));
    ramp.replace(ramp.find("  <Agents>"), 0,
                 "  <Schedule>\n    <Ramp policy=\"1\" component=\"CrowdHealth\" parameter=\"fallenRadius\" from=\"0.5\" to=\"1\" start=\"0\" end=\"5\" />\n  </Schedule>\n");
    const auto r = load("ramp.xml", ramp);
    BOOST_TEST(!r.spec.has_value());
    BOOST_TEST(r.messages.find("cannot be ramped") != std::string::npos, r.messages);
}
