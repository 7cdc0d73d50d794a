// Social groups (Agent@group, AgentGrid@group_size) and the SocialGroups force (Moussaïd et al.
// 2010, Policies/SocialGroups.h): a group of three crossing a counter-flow stays together, a group
// waits for its slowest member, results are the same on 1 and 2 threads, and bad group settings are
// errors at their line. Each behaviour is checked against the same scene without the force, so the
// test fails if the force does nothing.
#define BOOST_TEST_MODULE social_groups
#include <boost/test/unit_test.hpp>

#include "scenario_files.h"

#include "crowdhealth/core/simulation.h"

#include <cmath>
#include <map>
#include <sstream>

using namespace ch;
using ch::test::load;

namespace {

/// A scenario: a 40 m corridor 4 m wide, social forces + goal force (+ SocialGroups when `groups`),
/// the given <Agents> body.
std::string corridor(bool groups, const std::string& agents, double endTime = 40) {
    std::ostringstream s;
    s << R"(<Simulation delta_time="0.1" end_time=")" << endTime << R"(" seed="1">
  <World type="Infinite">
    <Obstacles>
      <Obstacle><Point x="-5" y="-2" /><Point x="45" y="-2" /></Obstacle>
      <Obstacle><Point x="-5" y="2" /><Point x="45" y="2" /></Obstacle>
    </Obstacles>
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
      <costfunction name="SocialForcesAvoidance" range="5" />
      <costfunction name="GoalReachingForce" />)"
      << (groups ? "\n      <costfunction name=\"SocialGroups\" />" : "") << R"(
    </Policy>
  </Policies>
  <Agents>
)" << agents << R"(
  </Agents>
</Simulation>
)";
    return s.str();
}

std::string agent(double x, double y, double gx, double speed, const std::string& group = "") {
    std::ostringstream s;
    s << "    <Agent rad=\"0.25\" pref_speed=\"" << speed << "\" max_speed=\"" << speed * 1.3 << "\""
      << (group.empty() ? "" : " group=\"" + group + "\"") << "><pos x=\"" << x << "\" y=\"" << y << "\" /><goal x=\""
      << gx << "\" y=\"" << y << "\" /><Policy id=\"0\" /></Agent>\n";
    return s.str();
}

/// Largest distance of any member of group 0 from the group's centre, over the run after `from` s,
/// and the members' final x.
struct GroupTrace {
    double maxSpread = 0;
    std::map<AgentId, double> finalX;
};
GroupTrace trace(const ScenarioSpec& spec, const std::vector<AgentId>& members, double from, int threads = 1) {
    Simulation sim(spec);
    sim.setThreads(threads);
    GroupTrace t;
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& A = sim.agents();
        Vec2 c(0, 0);
        std::vector<Vec2> p;
        for (std::size_t i = 0; i < A.size(); ++i)
            for (AgentId m : members)
                if (A.id[i] == m) p.push_back(A.pos[i]);
        if (p.size() != members.size()) break;  // someone arrived
        for (const Vec2& q : p) c += q;
        c /= static_cast<double>(p.size());
        if (sim.time() >= from)
            for (const Vec2& q : p) t.maxSpread = std::max(t.maxSpread, (q - c).norm());
        for (std::size_t i = 0; i < A.size(); ++i) t.finalX[A.id[i]] = A.pos[i].x();
    }
    return t;
}

ScenarioSpec loaded(const std::string& name, const std::string& xml) {
    const auto l = load(name, xml);
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    return *l.spec;
}

/// A group of three walking east against 20 people walking west in the same corridor.
std::string counterFlow() {
    std::string a = agent(0, 0, 40, 1.3, "family") + agent(0, 0.7, 40, 1.3, "family") + agent(0.6, -0.6, 40, 1.3, "family");
    for (int k = 0; k < 20; ++k) a += agent(14 + 1.0 * (k / 5), -1.4 + 0.7 * (k % 5), -5, 1.3);
    return a;
}

}  // namespace

BOOST_AUTO_TEST_CASE(loader_indexes_groups_in_order_of_first_member) {
    const ScenarioSpec s = loaded("order.xml", corridor(true, agent(0, 0, 10, 1, "b") + agent(0, 1, 10, 1) + agent(1, 0, 10, 1, "a") +
                                                                agent(1, 1, 10, 1, "b") + agent(2, 0, 10, 1, "a")));
    BOOST_TEST(s.groups == (std::vector<std::string>{"b", "a"}), "groups by first member");
    const std::vector<int> expected = {0, -1, 1, 0, 1};
    for (std::size_t i = 0; i < expected.size(); ++i) BOOST_TEST(s.agents[i].groupIndex == expected[i], "agent " << i);
}

BOOST_AUTO_TEST_CASE(agent_grid_groups_consecutive_agents) {
    // 7 agents in groups of 3: {0,1,2} {3,4,5}, and agent 6 left over walks alone.
    const ScenarioSpec s = loaded("grid.xml", corridor(true, R"(    <AgentGrid x="0" y="-1" columns="7" rows="1" spacing="0.6" group_size="3"><goal x="30" y="0" /><Policy id="0" /></AgentGrid>)"));
    BOOST_TEST(s.groups.size() == 2u);
    const std::vector<int> expected = {0, 0, 0, 1, 1, 1, -1};
    for (std::size_t i = 0; i < expected.size(); ++i) BOOST_TEST(s.agents[i].groupIndex == expected[i], "agent " << i);
    // Named after the grid (its number in the file) and the group; the members share the name.
    const std::vector<std::string> names = {"AgentGrid0.0", "AgentGrid0.0", "AgentGrid0.0", "AgentGrid0.1",
                                            "AgentGrid0.1", "AgentGrid0.1", ""};
    for (std::size_t i = 0; i < names.size(); ++i) BOOST_TEST(s.agents[i].group == names[i], "agent " << i);
    BOOST_TEST(s.groups == (std::vector<std::string>{"AgentGrid0.0", "AgentGrid0.1"}));
}

BOOST_AUTO_TEST_CASE(group_settings_out_of_range_are_errors_at_their_line) {
    auto messages = [](const std::string& name, const std::string& agents) { return load(name, corridor(true, agents)).messages; };
    const std::string one = messages("one.xml", R"(    <AgentGrid x="0" y="0" columns="4" rows="1" group_size="1"><goal x="9" y="0" /><Policy id="0" /></AgentGrid>)");
    BOOST_TEST(one.find("one.xml:16: error: AgentGrid@group_size: 1 is not a group") != std::string::npos, one);
    const std::string big = messages("big.xml", R"(    <AgentGrid x="0" y="0" columns="4" rows="1" group_size="21"><goal x="9" y="0" /><Policy id="0" /></AgentGrid>)");
    BOOST_TEST(big.find("big.xml:16: error:") != std::string::npos, big);
    BOOST_TEST(big.find("group_size") != std::string::npos, big);
    std::string eleven;
    for (int k = 0; k < 21; ++k) eleven += agent(0.6 * (k % 11), 0.6 * (k / 11), 30, 1, "party");
    const std::string party = messages("party.xml", eleven);
    BOOST_TEST(party.find("party.xml:36: error: group 'party' has more than 20 members") != std::string::npos, party);
    const std::string alone = messages("alone.xml", agent(0, 0, 9, 1, "solo") + agent(0, 1, 9, 1, "pair") + agent(1, 1, 9, 1, "pair"));
    BOOST_TEST(alone.find("alone.xml:16: warning: group 'solo' has one member") != std::string::npos, alone);
    BOOST_TEST(alone.find("'pair'") == std::string::npos, alone);
    const std::string empty = messages("empty.xml", agent(0, 0, 9, 1, "x").replace(agent(0, 0, 9, 1, "x").find("group=\"x\""), 9, "group=\"\""));
    BOOST_TEST(empty.find("empty.xml:16: error: Agent@group: empty group name") != std::string::npos, empty);
    const std::string bad = messages("param.xml", agent(0, 0, 9, 1));
    BOOST_TEST(bad.find("error") == std::string::npos, bad);
    // A parameter of the force out of its range.
    std::string xml = corridor(true, agent(0, 0, 9, 1, "p") + agent(0, 1, 9, 1, "p"));
    xml.replace(xml.find("name=\"SocialGroups\""), 20, "name=\"SocialGroups\" field_of_view=\"200\"");
    const std::string fov = load("fov.xml", xml).messages;
    BOOST_TEST(fov.find("fov.xml:12: error: SocialGroups@field_of_view") != std::string::npos, fov);
}

BOOST_AUTO_TEST_CASE(a_group_of_three_crosses_a_counter_flow_together) {
    const ScenarioSpec with = loaded("cf-groups.xml", corridor(true, counterFlow()));
    const ScenarioSpec without = loaded("cf-alone.xml", corridor(false, counterFlow()));
    const GroupTrace g = trace(with, {0, 1, 2}, 0);
    const GroupTrace a = trace(without, {0, 1, 2}, 0);
    BOOST_TEST_MESSAGE("spread with SocialGroups " << g.maxSpread << " m, without " << a.maxSpread << " m");
    // Three members at 0.5 m per member after the first: coherence acts beyond 1 m from the centre.
    BOOST_TEST(g.maxSpread < 1.6);
    BOOST_TEST(a.maxSpread > g.maxSpread + 0.5, "the counter-flow must split a group that has no group force");
    BOOST_TEST(g.finalX.at(0) > 25.0, "the group still makes progress");
}

BOOST_AUTO_TEST_CASE(a_group_waits_for_its_slowest_member) {
    // Two walk at 1.3 m/s, one at 0.5 m/s. Alone, they are 16 m apart after 20 s.
    const std::string agents = agent(0, 0, 40, 1.3, "g") + agent(0, 0.8, 40, 1.3, "g") + agent(0, -0.8, 40, 0.5, "g");
    const GroupTrace g = trace(loaded("wait.xml", corridor(true, agents, 20)), {0, 1, 2}, 0);
    const GroupTrace a = trace(loaded("nowait.xml", corridor(false, agents, 20)), {0, 1, 2}, 0);
    BOOST_TEST_MESSAGE("spread " << g.maxSpread << " m (alone " << a.maxSpread << " m); x " << g.finalX.at(0) << " "
                                 << g.finalX.at(1) << " " << g.finalX.at(2));
    BOOST_TEST(a.finalX.at(0) - a.finalX.at(2) > 12.0);
    BOOST_TEST(g.maxSpread < 1.6);
    BOOST_TEST(g.finalX.at(0) - g.finalX.at(2) < 2.0, "the fast members stay with the slow one");
    BOOST_TEST(g.finalX.at(2) > 7.0, "the slow member keeps walking (about 0.5 m/s)");
}

BOOST_AUTO_TEST_CASE(same_result_on_one_and_two_threads) {
    const ScenarioSpec s = loaded("threads.xml", corridor(true, counterFlow()));
    const GroupTrace one = trace(s, {0, 1, 2}, 0, 1);
    const GroupTrace two = trace(s, {0, 1, 2}, 0, 2);
    BOOST_TEST(one.maxSpread == two.maxSpread);
    for (const auto& [id, x] : one.finalX) BOOST_TEST(two.finalX.at(id) == x, "agent " << id);
}

BOOST_AUTO_TEST_CASE(members_too_close_repel_each_other) {
    // Only the goal force and SocialGroups (personal_space 0.4 m, spacing 1 m; no contact forces):
    // two members start overlapping (0.3 m apart, radii 0.25 m) and walk east side by side. The
    // repulsion parts them to at least r_i + r_k + personal_space = 0.9 m, and coherence keeps
    // them within 2 m (1 m each from the centre). Nothing else would part them: the goal force
    // acts along x only.
    std::string xml = corridor(true, agent(0, 0, 40, 1.0, "pair") + agent(0, 0.3, 40, 1.0, "pair"), 4);
    xml.replace(xml.find(R"(      <costfunction name="SocialForcesAvoidance" range="5" />)"), 62, "");
    xml.replace(xml.find(R"(ContactForceScale="62.5")"), 24, R"(ContactForceScale="0")");
    xml.replace(xml.find(R"(name="SocialGroups")"), 20, R"(name="SocialGroups" personal_space="0.4" spacing="1")");
    const ScenarioSpec s = loaded("repel.xml", xml);
    Simulation sim(s);
    while (!sim.finished()) sim.stepCoarse();
    const AgentStore& A = sim.agents();
    BOOST_TEST_REQUIRE(A.size() == 2u);
    const double d = (A.pos[0] - A.pos[1]).norm();
    BOOST_TEST_MESSAGE("members " << d << " m apart");
    BOOST_TEST(d >= 0.9, "members still " << d << " m apart");
    BOOST_TEST(d < 2.05, "beyond the coherence distance: " << d << " m");
}
