// CrowdHealth tests — van Toll et al. 2021's density blend (profiles SF→SPH and RVO→SPH) and the
// step weight that expresses it (<Step BlendField BlendFrom BlendTo>, StepSpec::blend):
//  * the weight κ = clamp((ρ − 2)/2, 0, 1) at ρ = 1…5, its complement, monotonicity, bad inputs;
//  * in a loaded profile every agent's weights follow its SPH density and sum to 1;
//  * a lone agent still reaches its goal through the door under each blended profile (not under
//    SF→SPH, see below), and under pure social forces what stops it: UMANS' wall rule stops it as
//    our nearest-point rule does, and lets it through only when the room is listed clockwise;
//  * the loader reports bad blend attributes with file and line.
#define BOOST_TEST_MODULE vantoll_blend
#include <boost/test/unit_test.hpp>

#include "crowdhealth/policy.h"
#include "crowdhealth/simulation.h"
#include "crowdhealth/xml.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <unistd.h>
#include <string>

using namespace ch;
namespace fs = std::filesystem;

namespace {

const std::string kDir = std::string(CH_SOURCE_DIR) + "/Examples/doorway/vantoll/";

double kappa(double rho) { return PolicyStep::blendWeight(rho, 2.0, 4.0); }

ScenarioSpec load(const std::string& file) {
    Diagnostics diags;
    auto spec = loadScenario(file, diags);
    std::ostringstream msg;
    diags.print(msg);
    BOOST_TEST_REQUIRE(spec.has_value(), "cannot load " << file << ":\n" << msg.str());
    return *spec;
}

/// Loads an XML text written to a temporary file; returns every diagnostic, one per line.
std::string diagnosticsOf(const std::string& xml, bool& loaded) {
    const fs::path path = fs::temp_directory_path() / ("vantoll_blend_" + std::to_string(::getpid()) + ".xml");
    {
        std::ofstream out(path);
        out << xml;
    }
    Diagnostics diags;
    loaded = loadScenario(path.string(), diags).has_value();
    fs::remove(path);
    std::ostringstream msg;
    diags.print(msg);
    return msg.str();
}

std::string scenarioWithStep(const std::string& stepAttributes, const std::string& components =
                                 "<CostFunction name=\"GoalReachingForce\"/><CostFunction name=\"SPH\"/>") {
    return "<Simulation delta_time=\"0.1\" delta_time_fine=\"0.02\" end_time=\"1\">\n"
           "<World type=\"Infinite\"/>\n<Policies><Policy id=\"0\">\n"
           "<Step DeltaTime=\"fine\" " + stepAttributes + ">\n" + components + "\n</Step>\n"
           "</Policy></Policies>\n"
           "<Agents><Agent id=\"0\" rad=\"0.24\"><pos x=\"0\" y=\"0\"/><goal x=\"5\" y=\"0\"/><Policy id=\"0\"/></Agent></Agents>\n"
           "</Simulation>\n";
}

}  // namespace

BOOST_AUTO_TEST_CASE(kappa_values) {
    BOOST_TEST(kappa(1.0) == 0.0);
    BOOST_TEST(kappa(2.0) == 0.0);
    BOOST_TEST(kappa(3.0) == 0.5);
    BOOST_TEST(kappa(4.0) == 1.0);
    BOOST_TEST(kappa(5.0) == 1.0);
    // The navigation side: BlendFrom 4, BlendTo 2 gives 1 − κ.
    for (double rho : {1.0, 2.0, 2.5, 3.0, 3.7, 4.0, 5.0})
        BOOST_TEST(PolicyStep::blendWeight(rho, 4.0, 2.0) == 1.0 - kappa(rho), boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(kappa_is_monotone_and_bounded) {
    double previous = -1;
    for (int k = 0; k <= 1000; ++k) {
        const double rho = 0.01 * k;  // 0 … 10 people/m²
        const double w = kappa(rho);
        BOOST_TEST(w >= 0.0);
        BOOST_TEST(w <= 1.0);
        BOOST_TEST(w >= previous);
        previous = w;
    }
    BOOST_TEST(PolicyStep::blendWeight(std::numeric_limits<double>::quiet_NaN(), 2, 4) == 0.0);
    BOOST_TEST(PolicyStep::blendWeight(3.0, 2, 2) == 0.0);
}

BOOST_AUTO_TEST_CASE(loaded_profiles_weigh_by_sph_density) {
    for (const char* name : {"sf-to-sph-rho5.xml", "rvo-to-sph-rho5.xml"}) {
        BOOST_TEST_CONTEXT(name) {
            Simulation sim(load(kDir + name));
            sim.setThreads(1);
            for (int k = 0; k < 100; ++k) sim.stepCoarse();  // 10 s: a dense crowd at the door
            Policy& policy = sim.policies().at(0);
            const std::vector<double>& rho = *policy.findComponent("SPH")->field("density");
            BOOST_TEST_REQUIRE(rho.size() == sim.agents().size());
            // The navigation steps have weight 1 − κ, the SPH step κ.
            const auto& steps = policy.steps();
            const PolicyStep& sphStep = steps.back();
            const PolicyStep& navStep = steps.front();
            bool sawBlend = false, sawZero = false;
            for (std::size_t i = 0; i < rho.size(); ++i) {
                BOOST_TEST(sphStep.weight(i) == kappa(rho[i]));
                BOOST_TEST(navStep.weight(i) + sphStep.weight(i) == 1.0, boost::test_tools::tolerance(1e-12));
                sawBlend = sawBlend || (sphStep.weight(i) > 0 && sphStep.weight(i) < 1);
                sawZero = sawZero || sphStep.weight(i) == 0;
            }
            BOOST_TEST(sawBlend);  // both sides are in use in this crowd
            BOOST_TEST(sawZero);
        }
    }
}

namespace {
/// Runs one agent from `start` (default (3, 4): off the door's axis, it must turn into the door)
/// to the goal behind the door; returns its evacuation time, or −1 (and reports where it ended)
/// when it did not arrive within 60 s.
double loneAgent(ScenarioSpec spec, const std::string& name, const Vec2& start = Vec2(3.0, 4.0)) {
    AgentSpec lone = spec.agents.front();
    lone.id = 0;
    lone.position = start;
    lone.goal = Vec2(22.0, 10.0);
    spec.agents = {lone};
    spec.endTime = 60;
    Simulation sim(spec);
    sim.setThreads(1);
    while (!sim.finished()) sim.stepCoarse();
    if (sim.evacuations().size() == 1) return sim.evacuations().front().time;
    if (sim.agents().size() == 1)
        BOOST_TEST_MESSAGE(name << ": lone agent still at (" << sim.agents().pos[0].x() << ", " << sim.agents().pos[0].y()
                                << ") after 60 s, speed " << sim.agents().vel[0].norm());
    return -1;
}
double loneAgent(const std::string& name) { return loneAgent(load(kDir + name), name); }

/// sf-k1000.xml (social forces + goal + contact) with SocialForcesAvoidance's `walls` set to
/// `walls` (0 nearest, 1 umans) and, if `clockwise`, every wall polygon listed the other way round.
ScenarioSpec pureSocialForces(double walls, bool clockwise) {
    ScenarioSpec spec = load(kDir + "sf-k1000.xml");
    int found = 0;
    for (PolicySpec& policy : spec.policies)
        for (StepSpec& step : policy.steps)
            for (ComponentSpec& c : step.components)
                if (c.name == "SocialForcesAvoidance") {
                    c.params.set("walls", walls);
                    ++found;
                }
    BOOST_TEST_REQUIRE(found == 1);
    if (clockwise)
        for (ObstacleSpec& o : spec.obstacles) std::reverse(o.points.begin(), o.points.end());
    return spec;
}
}  // namespace

BOOST_AUTO_TEST_CASE(lone_agent_reaches_its_goal_rvo_to_sph) {
    for (const char* name : {"rvo-to-sph-rho4.xml", "rvo-to-sph-rho5.xml", "rvo-to-sph-rho6.xml"}) {
        BOOST_TEST_CONTEXT(name) {
            const double t = loneAgent(name);
            BOOST_TEST(t > 0.0);
            BOOST_TEST(t < 30.0);  // ~20 m at 1.4 m/s: well under 30 s unless it got stuck
        }
    }
}

// KNOWN FAILURE, not hidden: a lone agent has SPH density ~1.3, so kappa = 0 and it walks by
// social forces alone. With UMANS' wall parameters (U0 10 m²/s², R 0.2 m) the two jambs of the
// 0.8 m door repel it, each from its nearest corner, by more than the goal term can pull
// (≈ 4.2 m/s² at 0.4 m before the door against at most 1.4/0.5 = 2.8 m/s²), so it stops 0.4–0.5 m
// before the door. UMANS 1.x's own wall rule (walls="umans", used by the profiles) does the same
// for this room: the next test case. docs/policies.md, "Differences over 15 %".
BOOST_AUTO_TEST_CASE(lone_agent_reaches_its_goal_sf_to_sph, *boost::unit_test::expected_failures(3)) {
    for (const char* name : {"sf-to-sph-rho4.xml", "sf-to-sph-rho5.xml", "sf-to-sph-rho6.xml"}) {
        BOOST_TEST_CONTEXT(name) {
            const double t = loneAgent(name);
            BOOST_TEST((t > 0.0 && t < 30.0));
        }
    }
}

// What a lone agent on the door's axis meets under pure social forces (sf-k1000.xml). UMANS 1.x
// applies a wall segment only when the agent is on its right (the outer side for the
// counter-clockwise polygons UMANS assumes and never checks) and a shared corner once: at the
// jambs of our counter-clockwise room that is the same single corner force as our nearest-point
// rule, so the agent stops before the door either way. Listed clockwise, UMANS' test drops the
// faces the agent sees and keeps those it is behind: straight in front of the door no wall force
// acts, and the agent walks through (docs/policies.md, "What UMANS' SocialForcesAvoidance
// computes").
BOOST_AUTO_TEST_CASE(lone_agent_and_the_social_force_walls) {
    const Vec2 onAxis(12.0, 10.0);
    BOOST_TEST(loneAgent(pureSocialForces(0, false), "walls=nearest", onAxis) < 0.0);
    BOOST_TEST(loneAgent(pureSocialForces(1, false), "walls=umans", onAxis) < 0.0);
    const double t = loneAgent(pureSocialForces(1, true), "walls=umans, clockwise room", onAxis);
    BOOST_TEST((t > 0.0 && t < 20.0));
    // The nearest-point rule does not depend on the order of the points.
    BOOST_TEST(loneAgent(pureSocialForces(0, true), "walls=nearest, clockwise room", onAxis) < 0.0);
}

BOOST_AUTO_TEST_CASE(loader_accepts_a_valid_blend) {
    bool loaded = false;
    const std::string out =
        diagnosticsOf(scenarioWithStep("BlendField=\"SPH.density\" BlendFrom=\"2\" BlendTo=\"4\""), loaded);
    BOOST_TEST(loaded, out);
}

BOOST_AUTO_TEST_CASE(loader_reports_bad_blends) {
    struct Case {
        std::string attributes, expected;
    };
    const Case cases[] = {
        {"BlendField=\"SPH.density\" BlendFrom=\"3\" BlendTo=\"3\"", "must differ from BlendFrom"},
        {"BlendField=\"SPH.density\" BlendTo=\"4\"", "BlendFrom"},
        {"BlendField=\"SPHdensity\" BlendFrom=\"2\" BlendTo=\"4\"", "not of the form Component.field"},
        {"BlendField=\"SPG.density\" BlendFrom=\"2\" BlendTo=\"4\"", "did you mean 'SPH'"},
        {"BlendField=\"SPH.densty\" BlendFrom=\"2\" BlendTo=\"4\"", "no per-agent field 'densty'"},
        {"BlendFrom=\"2\" BlendTo=\"4\"", "needs Step@BlendField"},
        {"BlendField=\"SPH.density\" BlendFrom=\"nan\" BlendTo=\"4\"", "BlendFrom"},
    };
    for (const Case& c : cases) {
        BOOST_TEST_CONTEXT(c.attributes) {
            bool loaded = true;
            const std::string out = diagnosticsOf(scenarioWithStep(c.attributes), loaded);
            BOOST_TEST(!loaded);
            BOOST_TEST(out.find(c.expected) != std::string::npos, out);
            BOOST_TEST(out.find(".xml:4: error:") != std::string::npos, out);  // the <Step> line (4)
        }
    }
}
