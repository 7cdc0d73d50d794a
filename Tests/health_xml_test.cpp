// CrowdHealth tests — <CrowdHealth>, <Schedule>, <Ramp> and <PanicEvent> in XML: errors carry
// file:line; the paper's four experiments load and run (a few seconds each).
#define BOOST_TEST_MODULE health_xml
#include <boost/test/unit_test.hpp>

#include "crowdhealth/health/health.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

using namespace ch;

namespace {

std::string data(const std::string& name) { return std::string(CH_SOURCE_DIR) + "/Tests/data/health/" + name; }

struct Load {
    Diagnostics diags;
    std::optional<ScenarioSpec> spec;
    std::vector<std::string> lines;
    explicit Load(const std::string& path) {
        spec = loadScenario(path, diags);
        for (const Diagnostic& d : diags.all()) lines.push_back(d.format());
        std::ostringstream out;
        diags.print(out);
        BOOST_TEST_MESSAGE("diagnostics of " << path << ":\n" << out.str());
    }
    /// A diagnostic at path:line whose text starts with `text`.
    bool has(const std::string& path, int line, const std::string& text) const {
        const std::string prefix = path + ":" + std::to_string(line) + ": " + text;
        for (const std::string& l : lines)
            if (l.rfind(prefix, 0) == 0) return true;
        return false;
    }
};

#define CHECK_AT(load, path, line, text) BOOST_TEST((load).has(path, line, text), "missing: " << path << ":" << line << ": " << text)

}  // namespace

BOOST_AUTO_TEST_CASE(ramp_and_crowdhealth_errors_carry_file_and_line) {
    const std::string f = data("ramp_errors.xml");
    Load L(f);
    BOOST_TEST(!L.spec.has_value());
    CHECK_AT(L, f, 10, "error: unknown attribute 'panicSped' on <CrowdHealth> (did you mean 'panicSpeed'?)");
    CHECK_AT(L, f, 10, "error: CrowdHealth@panic: 1.5 is not in [0, 1]");
    CHECK_AT(L, f, 17, "error: Ramp@component: unknown component 'SPh' (did you mean 'SPH'?); known: ");
    CHECK_AT(L, f, 18, "error: Ramp@parameter: SPH has no parameter 'restDensityMx' (did you mean 'restDensityMax'?)");
    CHECK_AT(L, f, 19, "error: Ramp@from: -1 is out of range for SPH.restDensityMax (allowed: [0, 1000] 1/m2)");
    CHECK_AT(L, f, 20, "error: Ramp@end: 40 s is before start (60 s)");
    CHECK_AT(L, f, 21, "error: Ramp@policy: policy 7 does not exist (defined: 0)");
    CHECK_AT(L, f, 22, "error: Ramp@component: policy 0 has no component 'ContactForces'");
    CHECK_AT(L, f, 23, "error: Ramp@to: 30 is out of range for agents.pref_speed (allowed: [0, 20] m/s)");
    CHECK_AT(L, f, 24, "error: Ramp@parameter: SPH.walls is not a real number");
    CHECK_AT(L, f, 25, "error: PanicEvent@radius: 0 is not in (0, inf) m");
    // Read when the run starts: a ramp would silently do nothing (coeff) or too little (range).
    CHECK_AT(L, f, 26, "error: Ramp@parameter: SPH.coeff is fixed for the run");
    CHECK_AT(L, f, 27, "error: Ramp@parameter: SPH.range is fixed for the run");
    BOOST_TEST(L.diags.errorCount() == 13);
}

BOOST_AUTO_TEST_CASE(crowdhealth_placement_errors) {
    const std::string f = data("crowdhealth_nolayer.xml");
    Load L(f);
    BOOST_TEST(!L.spec.has_value());
    CHECK_AT(L, f, 13, "error: more than one <CrowdHealth> in policy 1 (the first is at line 12)");
    CHECK_AT(L, f, 20, "error: Ramp@component: policy 0 has no <CrowdHealth> layer to ramp");
    BOOST_TEST(L.diags.errorCount() == 2);
}

BOOST_AUTO_TEST_CASE(safety_errors_carry_file_and_line) {
    const std::string f = data("safety_errors.xml");
    Load L(f);
    BOOST_TEST(!L.spec.has_value());
    CHECK_AT(L, f, 13, "error: unknown attribute 'crowd_presure' on <Safety> (did you mean 'crowd_pressure'?)");
    CHECK_AT(L, f, 13, "error: Safety@cell_size: 0.1 is not in [0.25, 50] m");
    CHECK_AT(L, f, 14, "error: Safety@density_critical: -2 is not in (0, 100] persons/m2");
    CHECK_AT(L, f, 13, "error: Safety@density_dangerous (1.5) must be greater than density_caution (2.17, the default)");
    CHECK_AT(L, f, 15, "error: more than one <Safety> (the first is at line 13)");
    CHECK_AT(L, f, 16, "error: unknown element <Safty> in <Simulation> (did you mean 'Safety'?)");
    BOOST_TEST(L.diags.errorCount() == 6);
}

BOOST_AUTO_TEST_CASE(the_paper_experiments_load_and_run) {
    struct Case {
        const char* file;
        const char* column;
        double from, to;
    };
    const Case cases[] = {
        {"experiment-a-rest-density.xml", "SPH.restDensityMax", 3, 7},
        {"experiment-b-gas-constant.xml", "SPH.gasConstant", 200, 0},
        {"experiment-c-preferred-speed.xml", "agents.pref_speed", 1, 1.8},
        {"experiment-d-goal-strength.xml", "GoalReachingForce.strength", 0.5, 2.5},
    };
    for (const Case& c : cases) {
        BOOST_TEST_CONTEXT(c.file) {
            Load L(std::string(CH_SOURCE_DIR) + "/Examples/doorway/" + c.file);
            BOOST_REQUIRE(L.spec.has_value());
            BOOST_TEST(L.diags.all().empty());
            BOOST_REQUIRE(L.spec->ramps.size() == 1u);
            BOOST_TEST(L.spec->ramps[0].start == 40.0);
            BOOST_TEST(L.spec->ramps[0].end == 60.0);
            BOOST_TEST(L.spec->policies.at(0).health.has_value());
            BOOST_TEST(L.spec->agents.size() == 400u);
            L.spec->endTime = 2;
            Simulation sim(*L.spec);
            MetricsRecorder m(1.0);
            m.sample(sim);
            while (!sim.finished()) {
                sim.stepCoarse();
                m.maybeSample(sim);
            }
            BOOST_REQUIRE(sim.scheduleColumns().size() == 1u);
            BOOST_TEST(sim.scheduleColumns()[0] == c.column);
            BOOST_TEST(sim.scheduleValues()[0] == c.from);  // held at `from` before 40 s
            const std::string csv = m.csv();
            BOOST_TEST(csv.substr(0, csv.find('\n')) == std::string(kMetricsHeader) + "," + c.column);
            BOOST_TEST(sim.agents().size() > 0u);
            for (std::size_t i = 0; i < sim.agents().size(); ++i) {
                BOOST_TEST(std::isfinite(sim.agents().pos[i].x()));
                BOOST_TEST(std::isfinite(sim.agents().pos[i].y()));
            }
        }
    }
}
