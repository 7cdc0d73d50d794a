// CrowdHealth tests — the CrowdHealth paper's four experiments (DESIGN §7, Examples/doorway/
// experiment-*.xml) run past their ramps (40 s → 60 s) and each ramp moves the crowd the way the
// paper describes, against the same file with its ramps held flat at their start values (same
// room, seed and crowd; only the change at 40 s is missing), over the same times: (a) ρ0_max 3 → 7: the density follows the rest density up; (b) k 200 → 0: the crowd
// compresses; (c) v_pref 1 → 1.8: people move faster at a similar density; (d) K_goal 0.5 → 2.5:
// more people out per second. About 70 s of a 400-agent doorway per file, one thread.
#define BOOST_TEST_MODULE health_experiments
#include <boost/test/unit_test.hpp>

#include "crowdhealth/io/output.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>

using namespace ch;

namespace {

struct Run {
    std::map<int, MetricsRow> rows;  ///< by whole second
    std::vector<double> exits;       ///< evacuation times (s)
    double at(int t, double MetricsRow::*m) const { return rows.at(t).*m; }
    /// Mean of a column over [from, to] (whole seconds).
    double mean(int from, int to, double MetricsRow::*m) const {
        double s = 0;
        for (int t = from; t <= to; ++t) s += at(t, m);
        return s / (to - from + 1);
    }
    /// People out during [from, to) seconds.
    std::size_t outBetween(double from, double to) const {
        std::size_t n = 0;
        for (double e : exits) n += e >= from && e < to;
        return n;
    }
};

/// Runs an experiment to 70 s; `flat`: every ramp held at its start value (to = from).
Run run(const std::string& name, bool flat = false) {
    Diagnostics diags;
    auto spec = loadScenario(std::string(CH_SOURCE_DIR) + "/Examples/doorway/" + name, diags);
    std::ostringstream msg;
    diags.print(msg);
    BOOST_TEST_REQUIRE(spec.has_value(), msg.str());
    BOOST_TEST_REQUIRE(!spec->ramps.empty());
    if (flat)
        for (RampSpec& r : spec->ramps) r.to = r.from;
    spec->endTime = 70;
    Simulation sim(*spec);
    sim.setThreads(1);
    MetricsRecorder metrics(1.0);
    metrics.sample(sim);
    while (!sim.finished()) {
        sim.stepCoarse();
        metrics.maybeSample(sim);
    }
    Run r;
    for (const MetricsRow& row : metrics.rows()) r.rows[static_cast<int>(std::lround(row.time))] = row;
    for (const Evacuation& e : sim.evacuations()) r.exits.push_back(e.time);
    BOOST_TEST_REQUIRE(r.rows.count(70) == 1u, name << " ended before 70 s");
    return r;
}


}  // namespace

BOOST_AUTO_TEST_CASE(a_rest_density_ramp_raises_the_density) {
    const Run a = run("experiment-a-rest-density.xml"), flat = run("experiment-a-rest-density.xml", true);
    const double before = a.mean(30, 39, &MetricsRow::meanDensity);
    const double after = a.mean(60, 69, &MetricsRow::meanDensity);
    const double held = flat.mean(60, 69, &MetricsRow::meanDensity);
    BOOST_TEST_MESSAGE("(a) mean density 30-39 s " << before << ", 60-69 s " << after << " (held at 3: " << held << ")");
    // At rho0_max = 3 before the ramp (the SPH rows: the density follows rho0_max), 6-7 after.
    BOOST_TEST(std::abs(before - 3.27) < 0.3);
    BOOST_TEST(after > 5.5);
    BOOST_TEST(std::abs(held - before) < 0.3);
}

BOOST_AUTO_TEST_CASE(b_gas_constant_ramp_to_zero_compresses_the_crowd) {
    const Run b = run("experiment-b-gas-constant.xml"), flat = run("experiment-b-gas-constant.xml", true);
    const double after = b.mean(60, 69, &MetricsRow::meanDensity), held = flat.mean(60, 69, &MetricsRow::meanDensity);
    const double peak = b.mean(60, 69, &MetricsRow::maxDensity), heldPeak = flat.mean(60, 69, &MetricsRow::maxDensity);
    BOOST_TEST_MESSAGE("(b) 60-69 s: mean density " << after << " (k held at 200: " << held << "), max density "
                                                    << peak << " (" << heldPeak << ")");
    // No pressure left: the crowd packs into the door ("violent compression", extreme density).
    BOOST_TEST(after > held + 0.8);
    BOOST_TEST(peak > heldPeak + 1.5);
}

BOOST_AUTO_TEST_CASE(c_preferred_speed_ramp_speeds_the_crowd_at_similar_density) {
    const Run c = run("experiment-c-preferred-speed.xml"), flat = run("experiment-c-preferred-speed.xml", true);
    const double speed = c.mean(60, 69, &MetricsRow::meanSpeed), held = flat.mean(60, 69, &MetricsRow::meanSpeed);
    BOOST_TEST_MESSAGE("(c) 60-69 s: mean speed " << speed << " (v_pref held at 1: " << held << "), density "
                                                  << c.mean(60, 69, &MetricsRow::meanDensity) << " ("
                                                  << flat.mean(60, 69, &MetricsRow::meanDensity) << ")");
    BOOST_TEST_MESSAGE("(c) out in 55-70 s: " << c.outBetween(55, 70) << " (" << flat.outBetween(55, 70) << ")");
    BOOST_TEST(speed > 1.1 * held);
    BOOST_TEST(static_cast<double>(c.outBetween(55, 70)) > 1.3 * static_cast<double>(flat.outBetween(55, 70)));
    BOOST_TEST(std::abs(c.mean(60, 69, &MetricsRow::meanDensity) - flat.mean(60, 69, &MetricsRow::meanDensity)) < 0.5);
    // The ramp is in the agents' motion: their preferred speed is the ramped value.
    BOOST_REQUIRE(!c.rows.at(65).schedule.empty());
    BOOST_TEST(std::abs(c.rows.at(65).schedule.at(0) - 1.8) < 1e-9);
    BOOST_TEST(std::abs(flat.rows.at(65).schedule.at(0) - 1.0) < 1e-9);
}

BOOST_AUTO_TEST_CASE(d_goal_strength_ramp_gets_more_people_out) {
    const Run d = run("experiment-d-goal-strength.xml"), flat = run("experiment-d-goal-strength.xml", true);
    const std::size_t after = d.outBetween(55, 70), held = flat.outBetween(55, 70);
    BOOST_TEST_MESSAGE("(d) out in 55-70 s: " << after << " (K_goal held at 0.5: " << held << ")");
    BOOST_TEST(static_cast<double>(after) > 1.3 * static_cast<double>(held));
    BOOST_TEST(d.outBetween(0, 40) == flat.outBetween(0, 40));  // identical until the ramp starts
}
