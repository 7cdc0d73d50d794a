// Social groups drawn by a <Source> (group_size_min, group_size_max, group_share; docs/navigation.md,
// "Sources", and docs/crowd-health.md, "Social groups"): sizes drawn within the bounds, `count` and
// `end` cutting the last group, the share of people in groups, members arriving in one step beside
// their first member (also when the area is full and arrivals wait), the same results on 1 and 2
// threads and on a second run, errors at their line, and groups that walk together with the
// SocialGroups force (and drift apart without it).
#define BOOST_TEST_MODULE source_groups
#include <boost/test/unit_test.hpp>

#include "scenario_files.h"

#include "crowdhealth/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

using namespace ch;
using test::Loaded;
using test::load;

namespace {

/// A 40 m × 20 m walled hall with one 4 m exit in the east wall; a <Source id="door"> with the given
/// attributes fills the west part (x 1..11); social forces and the goal force, plus SocialGroups
/// when `groups`.
std::string hall(const std::string& sourceAttrs, bool groups = true, std::uint64_t seed = 1, double endTime = 60,
                 const std::string& extraAgents = "", const std::string& area = R"(xmin="1" xmax="11" ymin="1" ymax="19")") {
    std::ostringstream s;
    s << "<Simulation delta_time=\"0.1\" end_time=\"" << endTime << "\" seed=\"" << seed << "\">\n"
      << R"(<World type="Planar" xmin="-1" xmax="42" ymin="-1" ymax="21">
<Navigation cell_size="0.25" clearance="0.4" />
<Obstacles>
<Obstacle><Point x="0" y="0" /><Point x="40" y="0" /></Obstacle>
<Obstacle><Point x="0" y="20" /><Point x="40" y="20" /></Obstacle>
<Obstacle><Point x="0" y="0" /><Point x="0" y="20" /></Obstacle>
<Obstacle><Point x="40" y="0" /><Point x="40" y="8" /></Obstacle>
<Obstacle><Point x="40" y="12" /><Point x="40" y="20" /></Obstacle>
</Obstacles>
<Exit id="out" xmin="40.3" xmax="41" ymin="8" ymax="12" />
<Journey id="j" leave_by="out" />
</World>
<Policies>
<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
<costfunction name="SocialForcesAvoidance" range="5" R="0.1" />
<costfunction name="GoalReachingForce" />)"
      << (groups ? "\n<costfunction name=\"SocialGroups\" />" : "") << R"(
</Policy>
</Policies>
<Agents>
)" << extraAgents
      << "<Source id=\"door\" " << area << " journey=\"j\" " << sourceAttrs << R"(>
<Policy id="0" />
<Draw attribute="pref_speed" distribution="normal" mean="1.34" sd="0.26" min="0.8" max="1.8" />
</Source>
</Agents>
</Simulation>
)";
    return s.str();
}

ScenarioSpec loaded(const std::string& name, const std::string& xml) {
    const Loaded l = load(name, xml);
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    return *l.spec;
}

/// The groups of a loaded scenario's source agents, in order: member indices into spec.agents
/// (agents alone are groups of one, with no name).
std::vector<std::vector<std::size_t>> units(const ScenarioSpec& s) {
    std::vector<std::vector<std::size_t>> out;
    for (std::size_t k = 0; k < s.agents.size(); ++k) {
        if (s.agents[k].source < 0) continue;
        if (s.agents[k].groupIndex >= 0 && !out.empty() && s.agents[out.back().back()].groupIndex == s.agents[k].groupIndex)
            out.back().push_back(k);
        else
            out.push_back({k});
    }
    return out;
}

/// What a run shows of each agent: the coarse step it appeared after and where it was placed.
struct Arrival {
    int step = -1;
    Vec2 at{0, 0};
    double radius = 0;
};
struct Run {
    std::map<AgentId, Arrival> arrivals;
    std::vector<std::pair<AgentId, Vec2>> final;  ///< every agent present at the end
    std::vector<AgentId> removedIds;
};
Run run(const ScenarioSpec& spec, int threads = 1, double until = -1) {
    Simulation sim(spec);
    sim.setThreads(threads);
    if (until > 0) sim.setEndTime(until);
    Run r;
    int step = 0;
    for (;;) {
        const AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) r.arrivals.emplace(A.id[i], Arrival{step, Vec2(0, 0)});
        if (sim.finished()) break;
        sim.stepCoarse();
        ++step;
    }
    // Where each was placed: the simulation writes the chosen place into its copy of the spec.
    for (const AgentSpec& a : sim.spec().agents)
        if (r.arrivals.count(a.id)) {
            r.arrivals[a.id].at = a.position;
            r.arrivals[a.id].radius = a.radius;
        }
    const AgentStore& A = sim.agents();
    for (std::size_t i = 0; i < A.size(); ++i) r.final.push_back({A.id[i], A.pos[i]});
    for (const auto& e : sim.removed()) r.removedIds.push_back(e.id);
    return r;
}

/// Line of the first `what` in `xml`.
int lineOf(const std::string& xml, const std::string& what) {
    const std::size_t at = xml.find(what);
    BOOST_TEST_REQUIRE(at != std::string::npos);
    return 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

}  // namespace

BOOST_AUTO_TEST_CASE(groups_are_drawn_with_sizes_within_the_bounds) {
    const ScenarioSpec s = loaded("sizes.xml", hall(R"(rate="2" count="300" group_size_min="2" group_size_max="5")"));
    BOOST_TEST_REQUIRE(s.agents.size() == 300u, "count is kept");
    const auto u = units(s);
    std::map<std::size_t, int> bySize;
    double members = 0;
    for (std::size_t g = 0; g < u.size(); ++g) {
        const AgentSpec& first = s.agents[u[g].front()];
        if (g + 1 < u.size()) {
            BOOST_TEST(u[g].size() >= 2u, "group " << g << " has " << u[g].size() << " members");
            BOOST_TEST(u[g].size() <= 5u, "group " << g << " has " << u[g].size() << " members");
        }
        ++bySize[u[g].size()];
        members += static_cast<double>(u[g].size());
        if (u[g].size() >= 2) {
            BOOST_TEST(first.group == "door/g" + std::to_string(g + 1), "named after the source: " << first.group);
            BOOST_TEST(s.groups[static_cast<std::size_t>(first.groupIndex)] == first.group);
        }
        for (std::size_t m : u[g]) {
            BOOST_TEST(s.agents[m].startTime == first.startTime, "members arrive at the first one's time");
            BOOST_TEST(s.agents[m].group == first.group);
        }
    }
    // Every size in [2, 5] is drawn, about equally often (about 86 groups: 21 each).
    for (std::size_t n = 2; n <= 5; ++n) BOOST_TEST(bySize[n] >= 10, "groups of " << n << ": " << bySize[n]);
    const double mean = members / static_cast<double>(u.size());
    BOOST_TEST(std::abs(mean - 3.5) < 0.35, "mean group size " << mean);
    BOOST_TEST(s.groups.size() == u.size() - (u.back().size() < 2 ? 1 : 0));
    // Arrivals keep the source's rate on average: the last group's time is near 300/2 s less its size.
    BOOST_TEST(s.agents.back().startTime <= 150.0);
    BOOST_TEST(s.agents.back().startTime >= 145.0);
    // A source without sizes: everyone alone, times as before.
    const ScenarioSpec alone = loaded("alone.xml", hall(R"(rate="2" count="10")"));
    for (std::size_t k = 0; k < alone.agents.size(); ++k) {
        BOOST_TEST(alone.agents[k].group.empty());
        BOOST_TEST(alone.agents[k].startTime == 0.5 * static_cast<double>(k));
    }
}

BOOST_AUTO_TEST_CASE(count_and_end_cut_the_last_group) {
    // Groups of exactly 5: count 7 leaves a group of 2, count 6 one person alone.
    const ScenarioSpec seven = loaded("seven.xml", hall(R"(rate="1" count="7" group_size_min="5" group_size_max="5")"));
    BOOST_TEST_REQUIRE(seven.agents.size() == 7u);
    const auto u7 = units(seven);
    BOOST_TEST_REQUIRE(u7.size() == 2u);
    BOOST_TEST(u7[0].size() == 5u);
    BOOST_TEST(u7[1].size() == 2u);
    BOOST_TEST(seven.agents[6].group == "door/g2");
    BOOST_TEST(seven.agents[5].startTime == 5.0, "the second group comes when its first member would");
    const Loaded six = load("six.xml", hall(R"(rate="1" count="6" group_size_min="5" group_size_max="5")"));
    BOOST_TEST_REQUIRE(six.spec.has_value(), six.messages);
    BOOST_TEST(six.spec->agents.size() == 6u);
    BOOST_TEST(six.spec->groups.size() == 1u);
    BOOST_TEST(six.spec->agents[5].group.empty(), "one left over walks alone");
    BOOST_TEST(six.spec->agents[5].groupIndex == -1);
    BOOST_TEST(six.messages.find("one member") == std::string::npos, six.messages);
    // `end`: arrivals at 0, 1, …, 5 (end 5.5) in groups of 4: a group of 4 and one of 2.
    const ScenarioSpec ended = loaded("end.xml", hall(R"(rate="1" end="5.5" group_size_min="4" group_size_max="4")"));
    BOOST_TEST_REQUIRE(ended.agents.size() == 6u);
    const auto ue = units(ended);
    BOOST_TEST_REQUIRE(ue.size() == 2u);
    BOOST_TEST(ue[1].size() == 2u);
    for (const AgentSpec& a : ended.agents) BOOST_TEST(a.startTime <= 5.5);
}

BOOST_AUTO_TEST_CASE(group_share_is_the_fraction_of_people_in_groups) {
    // Groups of 3 for half the people: a unit is a group with probability 0.5/(0.5 + 0.5·3) = 1/4.
    const ScenarioSpec half = loaded("half.xml", hall(R"(rate="10" count="4000" group_size_min="3" group_size_max="3" group_share="0.5")"));
    double inGroups = 0;
    for (const AgentSpec& a : half.agents) inGroups += a.group.empty() ? 0 : 1;
    const double share = inGroups / static_cast<double>(half.agents.size());
    BOOST_TEST(std::abs(share - 0.5) < 0.04, "share of people in groups " << share);
    const ScenarioSpec none = loaded("none.xml", hall(R"(rate="10" count="200" group_size_min="2" group_size_max="4" group_share="0")"));
    for (const AgentSpec& a : none.agents) BOOST_TEST(a.group.empty());
    BOOST_TEST(none.groups.empty());
}

BOOST_AUTO_TEST_CASE(members_arrive_in_one_step_beside_their_first_member) {
    // Standing people (long premovement) so that later arrivals meet those already there.
    const ScenarioSpec s = loaded("together.xml", hall(R"(rate="3" count="60" premovement="1000" group_size_min="2" group_size_max="5")", true, 1, 30));
    const Run r = run(s);
    const auto u = units(s);
    BOOST_TEST_REQUIRE(r.arrivals.size() == 60u);
    int groups = 0;
    double farthest = 0;
    for (const auto& g : u) {
        const AgentSpec& first = s.agents[g.front()];
        const Arrival& a0 = r.arrivals.at(first.id);
        for (std::size_t m : g) {
            const Arrival& a = r.arrivals.at(s.agents[m].id);
            BOOST_TEST(a.step == a0.step, "member " << s.agents[m].id << " of " << first.group << " arrives at step " << a.step
                                                    << ", its first member at " << a0.step);
            farthest = std::max(farthest, (a.at - a0.at).norm());
            BOOST_TEST((a.at - a0.at).norm() <= Navigation::kGroupPlacementRadius + 1e-9,
                       first.group << ": a member placed " << (a.at - a0.at).norm() << " m from the first");
        }
        groups += g.size() >= 2 ? 1 : 0;
    }
    BOOST_TEST(groups >= 10);
    BOOST_TEST_MESSAGE(groups << " groups; farthest member from its first: " << farthest << " m");
    // Nobody overlaps anybody where they were placed (all are standing still, so all are still there).
    for (const auto& [i, ai] : r.arrivals)
        for (const auto& [j, aj] : r.arrivals)
            if (i < j) BOOST_TEST((ai.at - aj.at).norm() >= ai.radius + aj.radius - 1e-9, "agents " << i << " and " << j << " overlap");
}

BOOST_AUTO_TEST_CASE(a_full_area_delays_a_group_as_a_whole) {
    // A 2 m × 2 m area fed 10 persons/s in groups of 4-5, people standing: the area fills, arrivals
    // wait, and each group still arrives in one step.
    const ScenarioSpec s = loaded("full.xml", hall(R"(rate="10" count="40" premovement="3" group_size_min="4" group_size_max="5")", true, 1, 40, "",
                                                   R"(xmin="1" xmax="3" ymin="9" ymax="11")"));
    const Run r = run(s);
    BOOST_TEST_REQUIRE(r.arrivals.size() == 40u);
    int delayed = 0;
    for (const auto& g : units(s)) {
        const Arrival& a0 = r.arrivals.at(s.agents[g.front()].id);
        delayed += static_cast<double>(a0.step) * 0.1 > s.agents[g.front()].startTime + 0.25 ? 1 : 0;
        for (std::size_t m : g) BOOST_TEST(r.arrivals.at(s.agents[m].id).step == a0.step, s.agents[g.front()].group);
    }
    BOOST_TEST(delayed >= 3, delayed << " groups delayed by a full area");
}

BOOST_AUTO_TEST_CASE(agent_specs_are_released_only_once_everyone_has_arrived_and_change_nothing) {
    // Simulation::releaseAgentSpecs (what the program calls after every step): refused while
    // anyone is still to come, arrivals waiting for room in a full area included; once done, the
    // specs are gone, the count of agents stays, and every position is the bits of a run that
    // keeps them.
    const ScenarioSpec s = loaded("release.xml", hall(R"(rate="10" count="40" premovement="3" group_size_min="4" group_size_max="5")", true, 1, 30, "",
                                                      R"(xmin="1" xmax="3" ymin="9" ymax="11")"));
    Simulation kept(s), freed(s);
    bool waited = false;  // a step with arrivals waiting for room, whose specs must stay
    std::size_t releasedAt = 0;
    while (!kept.finished()) {
        kept.stepCoarse();
        freed.stepCoarse();
        waited = waited || freed.waitingArrivals() > 0;
        const bool anyoneToCome = freed.pending() > 0;
        const bool released = freed.releaseAgentSpecs();
        BOOST_TEST(released == !anyoneToCome);
        BOOST_TEST(freed.agentSpecsReleased() == released);
        BOOST_TEST(freed.spec().agents.size() == (released ? 0u : s.agents.size()));
        BOOST_TEST(freed.totalAgents() == s.agents.size());
        if (released && releasedAt == 0) releasedAt = kept.coarseSteps();
        BOOST_TEST_REQUIRE(freed.agents().size() == kept.agents().size());
        for (std::size_t i = 0; i < kept.agents().size(); ++i) {
            BOOST_TEST_REQUIRE(freed.agents().id[i] == kept.agents().id[i]);
            BOOST_TEST_REQUIRE(freed.agents().pos[i].x() == kept.agents().pos[i].x());  // bit for bit
            BOOST_TEST_REQUIRE(freed.agents().pos[i].y() == kept.agents().pos[i].y());
        }
    }
    BOOST_TEST(waited, "some arrivals waited for room");
    BOOST_TEST(releasedAt > 0u, "the specs were released once all 40 had arrived");
    BOOST_TEST(kept.spec().agents.size() == s.agents.size());
    BOOST_TEST(freed.health().injuredCount() == kept.health().injuredCount());
    BOOST_TEST(freed.evacuations().size() == kept.evacuations().size());
}

BOOST_AUTO_TEST_CASE(groups_and_places_are_the_same_on_1_and_2_threads_and_every_run) {
    const std::string xml = hall(R"(rate="3" count="60" group_size_min="2" group_size_max="5")", true, 7, 40);
    const ScenarioSpec a = loaded("det-a.xml", xml), b = loaded("det-b.xml", xml);
    BOOST_TEST(a.groups == b.groups);
    for (std::size_t k = 0; k < a.agents.size(); ++k) {
        BOOST_TEST(a.agents[k].group == b.agents[k].group);
        BOOST_TEST(a.agents[k].startTime == b.agents[k].startTime);
    }
    const Run one = run(a, 1, 20), two = run(a, 2, 20), again = run(b, 1, 20);
    BOOST_TEST_REQUIRE(one.final.size() > 10u);
    for (const Run* other : {&two, &again}) {
        BOOST_TEST_REQUIRE(other->final.size() == one.final.size());
        for (std::size_t i = 0; i < one.final.size(); ++i) {
            BOOST_TEST(other->final[i].first == one.final[i].first);
            BOOST_TEST(other->final[i].second.x() == one.final[i].second.x());  // bit for bit
            BOOST_TEST(other->final[i].second.y() == one.final[i].second.y());
        }
        for (const auto& [id, arr] : one.arrivals) {
            BOOST_TEST(other->arrivals.at(id).step == arr.step);
            BOOST_TEST(other->arrivals.at(id).at.x() == arr.at.x());
        }
    }
    // Another seed draws other groups.
    const ScenarioSpec c = loaded("det-c.xml", hall(R"(rate="3" count="60" group_size_min="2" group_size_max="5")", true, 8, 40));
    bool differs = false;
    for (std::size_t k = 0; k < a.agents.size(); ++k) differs = differs || a.agents[k].group != c.agents[k].group;
    BOOST_TEST(differs, "seed 8 draws the same groups as seed 7");
}

BOOST_AUTO_TEST_CASE(bad_group_settings_are_errors_at_their_line) {
    struct Case {
        std::string attrs, words;
    };
    const std::vector<Case> cases = {
        {R"(rate="1" count="9" group_size_min="1" group_size_max="3")", "Source@group_size_min: "},
        {R"(rate="1" count="9" group_size_min="2" group_size_max="21")", "Source@group_size_max: "},
        {R"(rate="1" count="9" group_size_min="4" group_size_max="3")", "Source: group_size_min (4) must not exceed group_size_max (3)"},
        {R"(rate="1" count="9" group_size_min="2" group_size_max="3" group_share="1.5")", "Source@group_share: "},
        {R"(rate="1" count="9" group_size_min="2" group_size_max="3" group_share="-0.1")", "Source@group_share: "},
        {R"(rate="1" count="9" group_share="0.5")", "Source@group_share: nobody arrives in a group without group_size_min"},
        {R"(rate="1" count="9" group_size_min="3")", "Source@group_size_max: missing required value"},
        {R"(rate="1" count="9" group_size_max="3")", "Source@group_size_min: missing required value"},
        {R"(rate="1" count="9" group_size_min="2.5" group_size_max="3")", "Source@group_size_min: "},
    };
    int k = 0;
    for (const Case& c : cases) {
        const std::string xml = hall(c.attrs);
        const Loaded l = load("bad" + std::to_string(k++) + ".xml", xml);
        BOOST_TEST(!l.spec.has_value(), c.attrs);
        const std::string where = l.path + ":" + std::to_string(lineOf(xml, "<Source")) + ": error: " + c.words;
        BOOST_TEST(l.messages.find(where) != std::string::npos, l.messages << "\nexpected: " << where);
    }
    // Two sources drawing groups under one id, and an agent whose group name is a drawn group's.
    std::string two = hall(R"(rate="1" count="4" group_size_min="2" group_size_max="2")");
    const std::string second = R"(<Source id="door" xmin="1" xmax="3" ymin="1" ymax="3" count="4" group_size_min="2" group_size_max="3" journey="j"><Policy id="0" /></Source>
</Agents>)";
    two.replace(two.find("</Agents>"), 9, second);
    const Loaded l2 = load("twice.xml", two);
    BOOST_TEST(!l2.spec.has_value());
    const std::string at2 = l2.path + ":" + std::to_string(lineOf(two, R"(<Source id="door" xmin="1" xmax="3")")) +
                            ": error: Source 'door': another <Source> that draws groups has this id";
    BOOST_TEST(l2.messages.find(at2) != std::string::npos, l2.messages << "\nexpected: " << at2);
    const std::string agent = R"(<Agent group="door/g1"><pos x="20" y="5" /><goal x="30" y="5" /><Policy id="0" /></Agent>
<Agent group="door/g1"><pos x="20" y="6" /><goal x="30" y="6" /><Policy id="0" /></Agent>
)";
    const std::string clash = hall(R"(rate="1" count="4" group_size_min="2" group_size_max="2")", true, 1, 60, agent);
    const Loaded l3 = load("clash.xml", clash);
    BOOST_TEST(!l3.spec.has_value());
    const std::string at3 = l3.path + ":" + std::to_string(lineOf(clash, "<Agent group")) +
                            ": error: group 'door/g1' is also a group drawn by Source 'door'";
    BOOST_TEST(l3.messages.find(at3) != std::string::npos, l3.messages << "\nexpected: " << at3);
    // Good settings load without a word.
    const Loaded ok = load("ok.xml", hall(R"(rate="1" count="9" group_size_min="3" group_size_max="3" group_share="0.5")"));
    BOOST_TEST(ok.spec.has_value(), ok.messages);
    BOOST_TEST(ok.messages.empty(), ok.messages);
}

namespace {
/// Over a run: for each drawn group, the largest distance of a member from the group's centre while
/// every member is walking in the open hall (all present, premovement over, x in [14, 34]).
std::vector<double> groupSpreads(const ScenarioSpec& spec) {
    Simulation sim(spec);
    std::vector<double> spread(spec.groups.size(), 0.0);
    std::vector<int> size(spec.groups.size(), 0);
    for (const AgentSpec& a : spec.agents)
        if (a.groupIndex >= 0) ++size[static_cast<std::size_t>(a.groupIndex)];
    while (!sim.finished()) {
        sim.stepCoarse();
        const AgentStore& A = sim.agents();
        std::vector<Vec2> sum(spec.groups.size(), Vec2(0, 0));
        std::vector<int> present(spec.groups.size(), 0), inside(spec.groups.size(), 0);
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (A.group[i] < 0) continue;
            const std::size_t g = static_cast<std::size_t>(A.group[i]);
            sum[g] += A.pos[i];
            ++present[g];
            inside[g] += A.pos[i].x() >= 14 && A.pos[i].x() <= 34 ? 1 : 0;
        }
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (A.group[i] < 0) continue;
            const std::size_t g = static_cast<std::size_t>(A.group[i]);
            if (present[g] != size[g] || inside[g] != size[g]) continue;
            const Vec2 c = sum[g] / static_cast<double>(present[g]);
            spread[g] = std::max(spread[g], (A.pos[i] - c).norm());
        }
    }
    return spread;
}
}  // namespace

BOOST_AUTO_TEST_CASE(drawn_groups_walk_together_with_the_social_groups_force) {
    const std::string attrs = R"(rate="1" count="40" group_size_min="2" group_size_max="4")";
    const ScenarioSpec with = loaded("walk.xml", hall(attrs, true, 3, 90));
    const ScenarioSpec without = loaded("walk-alone.xml", hall(attrs, false, 3, 90));
    const std::vector<double> a = groupSpreads(with), b = groupSpreads(without);
    BOOST_TEST_REQUIRE(a.size() >= 8u);
    double worstWith = 0, worstWithout = 0, meanWith = 0, meanWithout = 0;
    for (std::size_t g = 0; g < a.size(); ++g) {
        worstWith = std::max(worstWith, a[g]);
        worstWithout = std::max(worstWithout, b[g]);
        meanWith += a[g] / static_cast<double>(a.size());
        meanWithout += b[g] / static_cast<double>(b.size());
    }
    BOOST_TEST_MESSAGE(a.size() << " groups; largest distance from the group's centre: with SocialGroups "
                                << worstWith << " m (mean over groups " << meanWith << "), without " << worstWithout
                                << " m (mean " << meanWithout << ")");
    BOOST_TEST(worstWith < 1.6, "a member " << worstWith << " m from its group's centre");
    BOOST_TEST(meanWithout > 2 * meanWith, "without the force " << meanWithout << " m, with " << meanWith << " m");
}

namespace {
/// A 20 m × 20 m room with exits in the east wall at y 4..6 and 14..16 (the nearer one taken), a
/// source over the middle of the west side (y 6..14: its arrivals split between the exits at
/// y = 10), and `agents`.
std::string twoExits(const std::string& sourceAttrs, const std::string& agents = "") {
    return std::string(R"(<Simulation delta_time="0.1" end_time="120" seed="2">
<World type="Planar" xmin="-1" xmax="22" ymin="-1" ymax="21">
<Navigation cell_size="0.25" clearance="0.4" />
<Obstacles>
<Obstacle><Point x="0" y="0" /><Point x="20" y="0" /></Obstacle>
<Obstacle><Point x="0" y="20" /><Point x="20" y="20" /></Obstacle>
<Obstacle><Point x="0" y="0" /><Point x="0" y="20" /></Obstacle>
<Obstacle><Point x="20" y="0" /><Point x="20" y="4" /></Obstacle>
<Obstacle><Point x="20" y="6" /><Point x="20" y="14" /></Obstacle>
<Obstacle><Point x="20" y="16" /><Point x="20" y="20" /></Obstacle>
</Obstacles>
<Exit id="south" xmin="20.3" xmax="21" ymin="4" ymax="6" />
<Exit id="north" xmin="20.3" xmax="21" ymin="14" ymax="16" />
<ExitSet id="east" exits="south north" choice="nearest" />
<Journey id="out" leave_by="east" />
</World>
<Policies>
<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
<costfunction name="SocialForcesAvoidance" range="5" R="0.1" />
<costfunction name="GoalReachingForce" />
<costfunction name="SocialGroups" />
</Policy>
</Policies>
<Agents>
)") + agents +
           R"(<Source id="west" xmin="1" xmax="4" ymin="6" ymax="14" journey="out" )" + sourceAttrs + R"(>
<Policy id="0" />
<Draw attribute="pref_speed" distribution="normal" mean="1.34" sd="0.26" min="0.8" max="1.8" />
</Source>
</Agents>
</Simulation>
)";
}
}  // namespace

BOOST_AUTO_TEST_CASE(a_group_leaves_by_one_exit) {
    // Two members either side of the line between the exits' catchments, and 60 arrivals of a
    // source in groups of 2-5 over it: each group leaves by one exit, and everyone leaves.
    const std::string pair = R"(<Agent group="pair" journey="out"><pos x="8" y="9.6" /><Policy id="0" /></Agent>
<Agent group="pair" journey="out"><pos x="8" y="10.4" /><Policy id="0" /></Agent>
)";
    const ScenarioSpec s = loaded("two-exits.xml", twoExits(R"(rate="2" count="60" group_size_min="2" group_size_max="5")", pair));
    Simulation sim(s);
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(sim.evacuations().size() == s.agents.size(), "evacuated " << sim.evacuations().size() << " of " << s.agents.size());
    std::map<AgentId, int> groupOf;
    for (const AgentSpec& a : s.agents) groupOf[a.id] = a.groupIndex;
    std::map<int, std::set<int>> exitsOf;  // group → the exits its members left by
    std::set<int> used;
    for (const auto& e : sim.evacuations()) {
        used.insert(e.exit);
        if (groupOf.at(e.id) >= 0) exitsOf[groupOf.at(e.id)].insert(e.exit);
    }
    BOOST_TEST(used.size() == 2u, "both exits are used");
    BOOST_TEST_REQUIRE(exitsOf.size() >= 10u);
    for (const auto& [g, exits] : exitsOf) BOOST_TEST(exits.size() == 1u, "group '" << s.groups[static_cast<std::size_t>(g)] << "' left by " << exits.size() << " exits");
}

BOOST_AUTO_TEST_CASE(members_are_not_placed_across_a_wall) {
    // A wall at x = 6 across the source's area (open above y = 18): each member is placed on its
    // first member's side, though the other side is often within 1.5 m.
    std::string xml = hall(R"(rate="3" count="90" premovement="1000" group_size_min="2" group_size_max="5")", true, 4, 40, "",
                           R"(xmin="1" xmax="11" ymin="1" ymax="17")");
    xml.replace(xml.find("</Obstacles>"), 12, "<Obstacle><Point x=\"6\" y=\"0\" /><Point x=\"6\" y=\"18\" /></Obstacle>\n</Obstacles>");
    const ScenarioSpec s = loaded("wall.xml", xml);
    const Run r = run(s);
    BOOST_TEST_REQUIRE(r.arrivals.size() == 90u);
    int nearWall = 0;
    for (const auto& g : units(s)) {
        const Arrival& a0 = r.arrivals.at(s.agents[g.front()].id);
        if (g.size() >= 2 && std::abs(a0.at.x() - 6) < 1.5) ++nearWall;
        for (std::size_t m : g) {
            const Arrival& a = r.arrivals.at(s.agents[m].id);
            BOOST_TEST((a.at.x() < 6) == (a0.at.x() < 6), s.agents[g.front()].group << ": a member at x = " << a.at.x()
                                                                                     << ", its first at x = " << a0.at.x());
        }
    }
    BOOST_TEST(nearWall >= 5, nearWall << " groups whose first member is within 1.5 m of the wall");
}

BOOST_AUTO_TEST_CASE(a_group_without_room_for_all_waits_10_s_then_arrives_as_it_fits) {
    // A 1 m × 1 m area in a hole of a crowd standing 0.6 m apart (policy 1: no avoidance, so it
    // stays put): a group of 10 cannot fit. It waits kGroupPatience, then its first member comes.
    std::string grids;
    auto grid = [&](double x, double y, int columns, int rows) {
        grids += "<AgentGrid x=\"" + std::to_string(x) + "\" y=\"" + std::to_string(y) + "\" columns=\"" + std::to_string(columns) +
                 "\" rows=\"" + std::to_string(rows) + "\" spacing=\"0.6\" journey=\"j\" premovement=\"1000\"><Policy id=\"1\" /></AgentGrid>\n";
    };
    grid(2.0, 6.0, 5, 13);  // west, x 2.0..4.4
    grid(6.6, 6.0, 5, 13);  // east, x 6.6..9.0
    grid(5.1, 6.0, 2, 5);   // south, y 6.0..8.4
    grid(5.1, 10.6, 2, 5);  // north, y 10.6..13.0
    std::string xml = hall(R"(rate="100" start="1" count="10" group_size_min="10" group_size_max="10")", true, 1, 13, grids,
                           R"(xmin="5" xmax="6" ymin="9" ymax="10")");
    xml.replace(xml.find("</Policies>"), 11,
                "<Policy id=\"1\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\"><costfunction name=\"GoalReachingForce\" /></Policy>\n</Policies>");
    const ScenarioSpec s = loaded("patience.xml", xml);
    Simulation sim(s);
    const std::size_t standing = s.agents.size() - 10;
    double first = -1;
    std::size_t atFirst = 0;
    while (!sim.finished()) {
        sim.stepCoarse();
        if (sim.agents().size() > standing && first < 0) {
            first = sim.time();
            atFirst = sim.agents().size() - standing;
        }
    }
    BOOST_TEST_MESSAGE("the group's first member arrived at " << first << " s with " << atFirst << " members; "
                                                              << sim.agents().size() + sim.evacuations().size() - standing
                                                              << " of 10 by the end");
    BOOST_TEST(first >= 1 + Navigation::kGroupPatience - 0.05, "arrived at " << first << " s");
    BOOST_TEST(first <= 1 + Navigation::kGroupPatience + 0.25, "arrived at " << first << " s");
    BOOST_TEST(atFirst < 10u);
}
