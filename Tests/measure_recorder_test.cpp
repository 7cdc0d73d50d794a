// Measurement lines and areas (docs/measurement.md): crossings counted per direction for any
// orientation and equal to the crossings of the trajectories, area densities equal to hand counts,
// Fruin's levels at the boundaries of his table, and the verdict reasons they give.
#define BOOST_TEST_MODULE measure_recorder
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/measure/recorder.h"
#include "test_support.h"

#include <cmath>
#include <map>

using namespace ch;
using test::agent;
using test::component;
using test::policy;

namespace {

constexpr double kFoot2 = 0.09290304;  // m² in a square foot

/// Agents standing at the given places (no goal), ids 0, 1, …
AgentStore standing(const std::vector<Vec2>& places, const std::vector<Vec2>& velocities = {}) {
    AgentStore a;
    for (std::size_t k = 0; k < places.size(); ++k) {
        AgentSpec s;
        s.id = static_cast<AgentId>(k);
        s.position = places[k];
        a.add(s, 0);
        if (k < velocities.size()) a.vel[k] = velocities[k];
    }
    return a;
}

ScenarioSpec withMeasurement(std::vector<MeasureLineSpec> lines, std::vector<MeasureAreaSpec> areas, double interval = 1.0) {
    ScenarioSpec s;
    s.measurement.lines = std::move(lines);
    s.measurement.areas = std::move(areas);
    s.measurement.interval = interval;
    return s;
}

MeasureLineSpec line(const std::string& name, Vec2 a, Vec2 b) {
    MeasureLineSpec l;
    l.name = name;
    l.a = a;
    l.b = b;
    return l;
}

MeasureAreaSpec area(const std::string& name, std::vector<Vec2> polygon) {
    MeasureAreaSpec a;
    a.name = name;
    a.polygon = std::move(polygon);
    return a;
}

}  // namespace

BOOST_AUTO_TEST_CASE(crossing_counts_direction_and_extent_for_any_orientation) {
    for (double angle : {0.0, 0.3, 1.0, kPi / 2, 2.5, kPi, 4.0, 5.5}) {
        const auto R = [&](const Vec2& v) { return rotated(v, angle); };
        const Vec2 a = R({-2, 0}), b = R({2, 0});
        // Forward = towards the right of a → b (here −y before rotation).
        BOOST_TEST(crossing(a, b, R({0.5, 0.3}), R({0.4, -0.2})) == +1);
        BOOST_TEST(crossing(a, b, R({0.5, -0.3}), R({0.4, 0.2})) == -1);
        // Beside the segment: no crossing.
        BOOST_TEST(crossing(a, b, R({2.5, 0.3}), R({2.5, -0.3})) == 0);
        BOOST_TEST(crossing(a, b, R({-2.3, 0.3}), R({-2.1, -0.3})) == 0);
        // Not reaching the line: none.
        BOOST_TEST(crossing(a, b, R({0, 0.5}), R({0, 0.1})) == 0);
    }
    // A stop exactly on the line counts once: the move onto it crosses (left to on = right side),
    // the move off it to the right does not cross again, and back to the left crosses backwards.
    const Vec2 a(-2, 0), b(2, 0);
    BOOST_TEST(crossing(a, b, {0, 1}, {0, 0}) == +1);
    BOOST_TEST(crossing(a, b, {0, 0}, {0, -1}) == 0);
    BOOST_TEST(crossing(a, b, {0, 0}, {0, 1}) == -1);
    // Through the end a shared by two lines: counted by one of them only.
    const Vec2 c(-2, 4);
    const int first = crossing(a, b, {-2.5, 1}, {-1.5, -1}), second = crossing(c, a, {-2.5, 1}, {-1.5, -1});
    BOOST_TEST(std::abs(first) + std::abs(second) == 1);
}

BOOST_AUTO_TEST_CASE(line_counts_equal_the_crossings_of_the_trajectories_at_any_angle) {
    // Two groups walk through each other across a 12 m line, one each way, in a scene rotated by
    // several angles. Every agent crosses once: forward = the group starting left, backward = the
    // other; and the counts equal an independent count on the recorded frames (sides of the
    // carrier line and the crossing point within the segment).
    for (double angle : {0.0, 0.7, kPi / 2, 2.2}) {
        const auto R = [&](const Vec2& v) { return rotated(v, angle); };
        std::vector<AgentSpec> agents;
        for (int k = 0; k < 10; ++k) {
            agents.push_back(agent(k, R({-4.0 + 0.9 * k, 3.0 + 0.5 * (k % 3)}), R({-4.0 + 0.9 * k, -6.0}), 0.25));
            agents.push_back(agent(100 + k, R({-3.5 + 0.9 * k, -3.0 - 0.5 * (k % 3)}), R({-3.5 + 0.9 * k, 6.0}), 0.25));
        }
        ScenarioSpec spec = test::scenario(agents, {policy(0, OptimisationMethod::Gradient,
                                                           {component("SocialForcesAvoidance"), component("GoalReachingForce")},
                                                           0.5)},
                                           0.1, 14.0);
        const Vec2 a = R({-6, 0}), b = R({6, 0});
        spec.measurement.lines = {line("across", a, b)};
        Simulation sim(spec);
        MeasurementRecorder rec(spec);
        rec.record(sim);
        std::map<AgentId, Vec2> before;
        for (std::size_t i = 0; i < sim.agents().size(); ++i) before[sim.agents().id[i]] = sim.agents().pos[i];
        int forward = 0, backward = 0;
        while (!sim.finished()) {
            sim.stepCoarse();
            rec.record(sim);
            for (std::size_t i = 0; i < sim.agents().size(); ++i) {
                const Vec2 p = before[sim.agents().id[i]], q = sim.agents().pos[i];
                // Independent: the sign of the signed distance to the carrier, and the crossing
                // point's coordinate along the line.
                const Vec2 u = (b - a).normalized(), n(u.y(), -u.x());  // n points to the right
                const double dp = n.dot(p - a), dq = n.dot(q - a);
                if ((dp > 0) != (dq > 0) || (dp >= 0) != (dq >= 0)) {
                    const double s = dp / (dp - dq);
                    const double along = u.dot(p + s * (q - p) - a);
                    if (along >= 0 && along < (b - a).norm() && dp <= 0 && dq > 0) ++forward;
                    else if (along >= 0 && along < (b - a).norm() && dp > 0 && dq <= 0) ++backward;
                }
                before[sim.agents().id[i]] = q;
            }
        }
        rec.finish();
        const auto [f, bw] = rec.lineTotals(0);
        BOOST_TEST_CONTEXT("angle " << angle) {
            BOOST_TEST(f == 10);
            BOOST_TEST(bw == 10);
            BOOST_TEST(f == forward);
            BOOST_TEST(bw == backward);
            // The rows add up to the totals.
            int rowsF = 0, rowsB = 0;
            for (const auto& r : rec.flowRows()[0]) rowsF += r.forward, rowsB += r.backward;
            BOOST_TEST(rowsF == f);
            BOOST_TEST(rowsB == bw);
        }
    }
}

BOOST_AUTO_TEST_CASE(someone_removed_right_after_crossing_is_counted) {
    // Goals 0.2 m past the line with remove_at_goal (reached 0.05 m past it): for most the move that
    // crosses the line ends at the goal, where they are removed; that move comes from
    // Simulation::removed().
    std::vector<AgentSpec> agents;
    for (int k = 0; k < 6; ++k) {
        AgentSpec a = agent(k, {-3.0 + k, 2.0 + 0.037 * k}, {-3.0 + k, -0.2}, 0.2);
        a.removeAtGoal = true;
        a.goalRadius = 0.15;
        agents.push_back(a);
    }
    ScenarioSpec spec = test::scenario(agents, {policy(0, OptimisationMethod::Gradient, {component("GoalReachingForce")}, 0.5)},
                                       0.1, 10.0);
    spec.measurement.lines = {line("door", {-5, 0}, {5, 0})};
    Simulation sim(spec);
    MeasurementRecorder rec(spec);
    rec.record(sim);
    while (!sim.finished()) {
        sim.stepCoarse();
        rec.record(sim);
    }
    BOOST_TEST(sim.evacuations().size() == 6u);
    BOOST_TEST(rec.lineTotals(0).first == 6);
    BOOST_TEST(rec.lineTotals(0).second == 0);
}

BOOST_AUTO_TEST_CASE(area_density_is_people_inside_over_area_as_counted_by_hand) {
    // A 2 m × 3 m rectangle and a right triangle of legs 4 m (area 8 m²).
    const ScenarioSpec spec = withMeasurement(
        {}, {area("box", {{0, 0}, {2, 0}, {2, 3}, {0, 3}}), area("tri", {{10, 0}, {14, 0}, {10, 4}})}, 1.0);
    // Box: 7 inside, 2 outside (one just beyond the right edge); triangle: 3 inside, 1 beyond the
    // hypotenuse.
    const std::vector<Vec2> places = {{0.5, 0.5}, {1.5, 0.5}, {0.5, 1.5}, {1.5, 1.5}, {0.5, 2.5}, {1.5, 2.5}, {1.0, 1.0},
                                      {2.1, 1.0}, {-0.5, 2.0}, {11, 1}, {12, 1}, {11, 2}, {12.5, 2.5}};
    std::vector<Vec2> v(places.size(), Vec2(0, 0));
    for (int k = 0; k < 7; ++k) v[static_cast<std::size_t>(k)] = Vec2(1.0 + 0.1 * k, 0);
    const AgentStore people = standing(places, v);
    MeasurementRecorder rec(spec);
    rec.record(people, 0.0, {});
    rec.record(people, 0.5, {});
    rec.record(people, 1.0, {});
    BOOST_REQUIRE(rec.areaRows()[0].size() == 1u);
    const auto& box = rec.areaRows()[0][0];
    BOOST_TEST(box.density == 7.0 / 6.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(box.people == 7.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(box.speed == 1.3, boost::test_tools::tolerance(1e-12));  // mean of 1.0 … 1.6
    BOOST_TEST(box.specificFlow == 7.0 / 6.0 * 1.3, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(box.los == fruinLevel(7.0 / 6.0));
    const auto& tri = rec.areaRows()[1][0];
    BOOST_TEST(tri.density == 3.0 / 8.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(tri.speed == 0.0);
    // The CSV carries the same numbers.
    const std::string csv = rec.areasCsv();
    BOOST_TEST(csv.rfind("time,area,density,speed,specific_flow,los,people\n", 0) == 0);
    BOOST_TEST(csv.find("1,box,1.16667,1.3,1.51667,E,7\n") != std::string::npos, csv);
}

BOOST_AUTO_TEST_CASE(fruin_levels_change_exactly_at_the_boundaries_of_his_table) {
    // Area per person (ft²): A ≥ 35 > B ≥ 25 > C ≥ 15 > D ≥ 10 > E ≥ 5 > F.
    const struct { double feet; char above, below; } bounds[] = {{35, 'A', 'B'}, {25, 'B', 'C'}, {15, 'C', 'D'},
                                                                  {10, 'D', 'E'}, {5, 'E', 'F'}};
    for (const auto& b : bounds) {
        const double density = 1.0 / (b.feet * kFoot2);
        BOOST_TEST(fruinLevel(density * (1 - 1e-9)) == b.above, b.feet << " ft2");
        BOOST_TEST(fruinLevel(density * (1 + 1e-9)) == b.below, b.feet << " ft2");
        BOOST_TEST(fruinLowerDensity(b.below) == density, boost::test_tools::tolerance(1e-12));
    }
    BOOST_TEST(fruinLevel(0) == 'A');
    BOOST_TEST(fruinLevel(0.2) == 'A');   // 5 m² per person
    BOOST_TEST(fruinLevel(1.0) == 'D');   // 1 m² = 10.8 ft²
    BOOST_TEST(fruinLevel(2.0) == 'E');   // 0.5 m² = 5.4 ft²
    BOOST_TEST(fruinLevel(2.2) == 'F');
    BOOST_TEST(fruinLevel(6.0) == 'F');
}

BOOST_AUTO_TEST_CASE(a_line_above_capacity_for_long_enough_is_a_reason_with_its_place) {
    // A 1 m line crossed at 2 persons/s for 30 s: over the 10 s window 2 P/(m·s) > 1.33.
    auto run = [](double perSecond, double seconds) {
        ScenarioSpec spec = withMeasurement({line("gate", {0, 0}, {1, 0})}, {});
        MeasurementRecorder rec(spec);
        // Agents stepping across the line, one after another, in records 0.1 s apart.
        double due = 0;
        rec.record(AgentStore{}, 0.0, {});
        std::vector<Vec2> positions;
        for (int step = 1; step * 0.1 <= seconds + 1e-9; ++step) {
            const double t = step * 0.1;
            // Everyone present moves 0.4 m down (crossing y = 0 once); newcomers appear above.
            std::vector<Vec2> places;
            for (Vec2 p : positions) places.push_back(p + Vec2(0, -0.4));
            while (due <= t + 1e-9) {
                places.push_back(Vec2(0.5, 0.3));
                due += 1.0 / perSecond;
            }
            positions = places;
            rec.record(standing(positions), t, {});
        }
        rec.finish();
        return rec.reasons();
    };
    const std::vector<VerdictReason> high = run(2.0, 30.0);
    BOOST_REQUIRE(high.size() == 1u);
    BOOST_TEST(high[0].measure == "flow_capacity");
    BOOST_TEST(high[0].level == "caution");
    BOOST_TEST(high[0].place == "gate");
    BOOST_TEST(high[0].threshold == 1.33);
    BOOST_TEST(high[0].hasWhere);
    BOOST_TEST(high[0].x == 0.5);
    // Above 1.33 once the window holds more than 13 crossings (t ≈ 6.6 s); held to the end.
    BOOST_TEST(high[0].firstTime > 5.0);
    BOOST_TEST(high[0].firstTime < 8.0);
    BOOST_TEST(high[0].duration > 20.0);
    // 1 person/s: 1 P/(m·s) never reaches the capacity.
    BOOST_TEST(run(1.0, 30.0).empty());
}

BOOST_AUTO_TEST_CASE(an_area_at_level_f_for_min_duration_is_a_reason_and_a_shorter_spell_is_not) {
    const ScenarioSpec spec = withMeasurement({}, {area("front", {{0, 0}, {1, 0}, {1, 1}, {0, 1}})});
    const std::vector<Vec2> crowd = {{0.2, 0.2}, {0.5, 0.5}, {0.8, 0.8}};  // 3 persons/m²: F
    auto run = [&](double spell) {
        MeasurementRecorder rec(spec);
        const AgentStore empty;
        const AgentStore dense = standing(crowd);
        for (int step = 0; step <= 50; ++step) {
            const double t = 0.1 * step;
            rec.record(t >= 1.0 && t < 1.0 + spell - 1e-9 ? dense : empty, t, {});
        }
        rec.finish();
        return rec.reasons();
    };
    const std::vector<VerdictReason> held = run(2.0);  // F from 1.0 to 2.9 s: held 1.9 s ≥ 1 s
    BOOST_REQUIRE(held.size() == 1u);
    BOOST_TEST(held[0].measure == "level_of_service");
    BOOST_TEST(held[0].place == "front");
    BOOST_TEST(held[0].firstTime == 1.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(held[0].duration == 1.9, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(held[0].people == 3u);
    BOOST_TEST(run(0.5).empty());  // F for 0.5 s only
}

BOOST_AUTO_TEST_CASE(reasons_join_the_verdict_by_severity) {
    Verdict v;
    VerdictReason danger;
    danger.level = "dangerous";
    v.reasons.push_back(danger);
    v.level = "dangerous";
    VerdictReason c;
    c.level = "caution";
    c.place = "gate";
    addReasons(v, {c});
    BOOST_TEST(v.level == "dangerous");
    BOOST_REQUIRE(v.reasons.size() == 2u);
    BOOST_TEST(v.reasons[1].place == "gate");
    Verdict safe;
    addReasons(safe, {c});
    BOOST_TEST(safe.level == "caution");
    BOOST_TEST(verdictJson(safe).find("\"place\":\"gate\"") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(heatmap_worst_los_is_the_worst_level_held_for_min_duration) {
    // A tight cluster (local density far above F near its centre) for 2 s, then gone; with a
    // spell of 0.5 s instead the worst level held for min_duration (1 s) stays below F.
    std::vector<Vec2> cluster;
    for (int j = 0; j < 6; ++j)
        for (int i = 0; i < 6; ++i) cluster.push_back(Vec2(10.1 + 0.45 * i, 10.1 + 0.45 * j));
    auto worstAtCentre = [&](double spell) {
        SafetyRecorder rec;
        const AgentStore dense = standing(cluster), empty;
        for (int step = 0; step <= 40; ++step) {
            const double t = 0.1 * step;
            rec.recordCrowd(t < spell - 1e-9 ? dense : empty, t);
        }
        // The row of the cell holding (11.2, 11.2): its last column.
        const std::string csv = rec.heatmapCsv();
        const std::size_t at = csv.find("\n11.5,11.5,");
        BOOST_REQUIRE(at != std::string::npos);
        const std::size_t end = csv.find('\n', at + 1);
        return csv[end - 1];
    };
    BOOST_TEST(worstAtCentre(2.0) == 'F');
    const char brief = worstAtCentre(0.5);
    BOOST_TEST(brief != 'F');
    BOOST_TEST(brief == 'A');  // nothing held for 1 s: the cluster was there 0.5 s, then nobody
}

namespace {
/// The worst_los column of heatmap.csv at the cell whose centre is (x, y) (written as in the file).
char worstLosAt(const std::string& csv, const std::string& x, const std::string& y) {
    const std::size_t at = csv.find("\n" + x + "," + y + ",");
    BOOST_REQUIRE(at != std::string::npos);
    const std::size_t end = csv.find('\n', at + 1);
    return csv[end - 1];
}
}  // namespace

BOOST_AUTO_TEST_CASE(heatmap_worst_los_restarts_after_a_record_that_missed_the_cell) {
    // The tight cluster for 0.7 s, gone for one record (nobody within reach: the cell is not
    // evaluated), back for 0.7 s: neither spell lasts min_duration (1 s), so no level of
    // service held, though the two together would have.
    std::vector<Vec2> cluster;
    for (int j = 0; j < 6; ++j)
        for (int i = 0; i < 6; ++i) cluster.push_back(Vec2(10.1 + 0.45 * i, 10.1 + 0.45 * j));
    SafetyRecorder rec;
    const AgentStore dense = standing(cluster), empty;
    for (int step = 0; step <= 14; ++step) rec.recordCrowd(step == 7 ? empty : dense, 0.1 * step);
    BOOST_TEST(worstLosAt(rec.heatmapCsv(), "11.5", "11.5") == 'A');
    // Without the gap the same 1.4 s make level F.
    SafetyRecorder steady;
    for (int step = 0; step <= 14; ++step) steady.recordCrowd(dense, 0.1 * step);
    BOOST_TEST(worstLosAt(steady.heatmapCsv(), "11.5", "11.5") == 'F');
}

BOOST_AUTO_TEST_CASE(heatmap_worst_los_with_no_min_duration_is_the_worst_level_reached) {
    // min_duration 0: one record is enough. One person standing alone makes a local density of
    // about 1/(πR²)·e^{−d²/R²} at the centre of their cell, 0.65 P/m² for R = 0.7 m and d ≈ 0
    // (level C: 0.43–0.72 P/m²), so the worst level there is C, not worse.
    SafetyThresholds t;
    t.minDuration = 0;
    SafetyRecorder rec(t);
    const AgentStore one = standing({Vec2(5.5, 5.5)});
    for (int step = 0; step <= 3; ++step) rec.recordCrowd(one, 0.1 * step);
    BOOST_TEST(fruinLevel(1 / (kPi * 0.49)) == 'C');
    BOOST_TEST(worstLosAt(rec.heatmapCsv(), "5.5", "5.5") == 'C');
    // The cell beside it (centre 1 m away: 0.65·e^{−1/0.49} = 0.085 P/m²) is level A.
    BOOST_TEST(worstLosAt(rec.heatmapCsv(), "6.5", "5.5") == 'A');
}

BOOST_AUTO_TEST_CASE(an_area_empty_part_of_the_interval_reports_the_speed_of_those_present) {
    // Someone walks at 1.2 m/s through the box during one record of three: the row's speed is
    // theirs (1.2 m/s), not lowered by the empty records; the density is the mean (1/3 of 1/6).
    const ScenarioSpec spec = withMeasurement({}, {area("box", {{0, 0}, {2, 0}, {2, 3}, {0, 3}})});
    MeasurementRecorder rec(spec);
    rec.record(AgentStore{}, 0.0, {});
    rec.record(standing({{1, 1}}, {{1.2, 0}}), 0.5, {});
    rec.record(AgentStore{}, 1.0, {});
    BOOST_REQUIRE(rec.areaRows()[0].size() == 1u);
    BOOST_TEST(rec.areaRows()[0][0].speed == 1.2, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(rec.areaRows()[0][0].density == 1.0 / 18.0, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(flows_divide_by_the_interval_as_it_ran) {
    // Records every 0.3 s with an interval of 1 s: the first row closes at 1.2 s and its flow is
    // its crossings over 1.2 s.
    ScenarioSpec spec = withMeasurement({line("gate", {0, 0}, {1, 0})}, {});
    MeasurementRecorder rec(spec);
    rec.record(standing({{0.5, 0.5}, {0.2, 0.5}, {0.8, 0.5}}), 0.0, {});
    rec.record(standing({{0.5, -0.5}, {0.2, -0.5}, {0.8, -0.5}}), 0.3, {});
    rec.record(standing({{0.5, -0.6}, {0.2, -0.6}, {0.8, -0.6}}), 0.6, {});
    rec.record(standing({{0.5, -0.7}, {0.2, -0.7}, {0.8, -0.7}}), 0.9, {});
    rec.record(standing({{0.5, -0.8}, {0.2, -0.8}, {0.8, -0.8}}), 1.2, {});
    const std::string csv = rec.flowsCsv();
    BOOST_TEST(csv.find("1.2,gate,line,3,0,2.5,2.5\n") != std::string::npos, csv);
}
