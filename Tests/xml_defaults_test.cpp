// CrowdHealth tests — "right by default": a setting nobody wrote never adds physics, settings that
// contradict each other are warned about with file and line, and files that are not XML text get
// plain errors. With the real registry (ContactForces, SPH), scenarios written to a temporary folder.
#define BOOST_TEST_MODULE xml_defaults
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/health/safety.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

using namespace ch;
using namespace ch::test;
namespace fs = std::filesystem;

namespace {

/// A fresh folder for one test case's files.
fs::path freshDir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("ch_xml_defaults_" + std::to_string(::getpid())) / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void write(const fs::path& file, const std::string& bytes) {
    std::ofstream out(file, std::ios::binary);
    out << bytes;
}

struct Load {
    Diagnostics diags;
    std::optional<ScenarioSpec> spec;
    std::string text;  ///< every diagnostic, formatted
    explicit Load(const fs::path& file) {
        spec = loadScenario(file.string(), diags);
        std::ostringstream out;
        diags.print(out);
        text = out.str();
        BOOST_TEST_MESSAGE(file.filename().string() << ":\n" << text);
    }
    bool has(const std::string& s) const { return text.find(s) != std::string::npos; }
};

/// A scenario with one policy whose first line is line 3: `policy` is written as it stands (one
/// line), obstacles (one line, may be empty) on line 2.
std::string scenario(const std::string& policy, const std::string& obstacles = "") {
    return "<Simulation delta_time=\"0.1\" delta_time_fine=\"0.02\" end_time=\"1\">\n"  // 1
           "<World type=\"Infinite\"/><Obstacles>" + obstacles + "</Obstacles>\n"          // 2
           "<Policies>" + policy + "</Policies>\n"                                           // 3
           "<Agents><Agent id=\"0\" rad=\"0.24\"><pos x=\"0\" y=\"0\"/><goal x=\"5\" y=\"0\"/>"
           "<Policy id=\"0\"/></Agent></Agents>\n"
           "</Simulation>\n";
}

const std::string kSphSteps =
    "<Step DeltaTime=\"fine\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\">"
    "<CostFunction name=\"GoalReachingForce\"/><CostFunction name=\"SPH\"/>"
    "<CostFunction name=\"ContactForces\"/></Step></Policy>";

}  // namespace

BOOST_AUTO_TEST_CASE(a_contact_component_replaces_umans_implicit_contact) {
    const fs::path dir = freshDir("contact");
    struct Case {
        std::string name, policy;
        double scale;
        bool warned;
    };
    const Case cases[] = {
        // van Toll's SPH profile as documented: goal + SPH + ContactForces, nothing else written.
        {"documented.xml", "<Policy id=\"0\">" + kSphSteps, 0.0, false},
        {"explicit-zero.xml", "<Policy id=\"0\" ContactForceScale=\"0\">" + kSphSteps, 0.0, false},
        // Both written: both applied, and the file is told so.
        {"both.xml", "<Policy id=\"0\" ContactForceScale=\"62.5\">" + kSphSteps, 62.5, true},
        // A UMANS 1.x policy without a contact component keeps UMANS' contact (UMANS' default).
        {"umans.xml",
         "<Policy id=\"0\" OptimizationMethod=\"gradient\"><costfunction name=\"SocialForcesAvoidance\"/>"
         "<costfunction name=\"GoalReachingForce\"/></Policy>",
         62.5, false},
        // The 1.x form with ContactForces among its components is covered by the same rule.
        {"umans-with-contact.xml",
         "<Policy id=\"0\" OptimizationMethod=\"gradient\"><costfunction name=\"GoalReachingForce\"/>"
         "<costfunction name=\"ContactForces\"/></Policy>",
         0.0, false},
    };
    for (const Case& c : cases) {
        BOOST_TEST_CONTEXT(c.name) {
            write(dir / c.name, scenario(c.policy));
            const Load L(dir / c.name);
            BOOST_REQUIRE(L.spec.has_value());
            BOOST_TEST(L.spec->policies.at(0).contactForceScale == c.scale);
            BOOST_TEST(L.diags.all().size() == (c.warned ? 1u : 0u), L.text);
            if (c.warned) {
                // At the attribute's line, naming the component and its line (the <Policy> line, 3).
                BOOST_TEST(L.has((dir / c.name).string() + ":3: warning: Policy@ContactForceScale=62.5 adds UMANS' "
                                                           "post-step contact on top of ContactForces (" +
                                 (dir / c.name).string() + ":3)"),
                           L.text);
            }
        }
    }
}

BOOST_AUTO_TEST_CASE(no_implicit_contact_moves_agents_under_a_contact_component) {
    // Two agents overlapping by 0.2 m, standing still (goal = position), with ContactForces whose
    // stiffnesses are 0: nothing may push them apart. UMANS' post-step contact, were it added
    // implicitly, would separate them within a second.
    const fs::path dir = freshDir("still");
    const std::string agents =
        "<Agents>"
        "<Agent id=\"0\" rad=\"0.3\"><pos x=\"0\" y=\"0\"/><goal x=\"0\" y=\"0\"/><Policy id=\"0\"/></Agent>"
        "<Agent id=\"1\" rad=\"0.3\"><pos x=\"0.4\" y=\"0\"/><goal x=\"0.4\" y=\"0\"/><Policy id=\"0\"/></Agent>"
        "</Agents>";
    const auto file = [&](const std::string& scale) {
        return "<Simulation delta_time=\"0.1\" delta_time_fine=\"0.02\" end_time=\"1\"><World type=\"Infinite\"/>"
               "<Policies><Policy id=\"0\"" + scale + "><Step DeltaTime=\"fine\" StopAtGoal=\"false\">"
               "<CostFunction name=\"GoalReachingForce\"/>"
               "<CostFunction name=\"ContactForces\" agentStiffness=\"0\" obstacleStiffness=\"0\"/>"
               "</Step></Policy></Policies>" + agents + "</Simulation>\n";
    };
    const auto gap = [&](const std::string& name, const std::string& scale) {
        write(dir / name, file(scale));
        const Load L(dir / name);
        BOOST_REQUIRE(L.spec.has_value());
        Simulation sim(*L.spec);
        while (!sim.finished()) sim.stepCoarse();
        const AgentStore& a = sim.agents();
        BOOST_REQUIRE(a.size() == 2u);
        return (a.pos[1] - a.pos[0]).norm();
    };
    BOOST_TEST(std::abs(gap("implicit.xml", "") - 0.4) < 1e-12);
    // Written explicitly, UMANS' push is applied (and the loader warns): the agents separate.
    BOOST_TEST(gap("explicit.xml", " ContactForceScale=\"62.5\"") > 0.55);
}

BOOST_AUTO_TEST_CASE(sph_walls_follow_the_obstacles_unless_written) {
    const fs::path dir = freshDir("walls");
    const std::string box = "<Box x=\"2\" y=\"-1\" width=\"1\" height=\"2\" particles=\"true\" spacing=\"0.48\"/>";
    const std::string plainBox = "<Box x=\"2\" y=\"-1\" width=\"1\" height=\"2\"/>";
    const auto policy = [](const std::string& walls) {
        return "<Policy id=\"0\"><Step DeltaTime=\"fine\"><CostFunction name=\"GoalReachingForce\"/>"
               "<CostFunction name=\"SPH\"" + walls + "/></Step></Policy>";
    };
    struct Case {
        std::string name, walls, obstacles, expected, warning;
    };
    const Case cases[] = {
        {"particles-unwritten.xml", "", box, "particles", ""},
        {"analytic-unwritten.xml", "", plainBox, "analytic", ""},
        {"particles-written.xml", " walls=\"particles\"", box, "particles", ""},
        {"analytic-over-particles.xml", " walls=\"analytic\"", box, "analytic",
         ":3: warning: SPH@walls=\"analytic\" ignores the SPH boundary particles of the obstacle at "},
        {"particles-without-any.xml", " walls=\"particles\"", plainBox, "particles",
         ":3: warning: SPH@walls=\"particles\" but no obstacle carries boundary particles"},
    };
    for (const Case& c : cases) {
        BOOST_TEST_CONTEXT(c.name) {
            write(dir / c.name, scenario(policy(c.walls), c.obstacles));
            const Load L(dir / c.name);
            BOOST_REQUIRE(L.spec.has_value());
            BOOST_TEST(L.spec->policies.at(0).steps.at(0).components.at(1).params.choice("walls") == c.expected);
            if (c.warning.empty()) {
                BOOST_TEST(L.diags.all().empty(), L.text);
            } else {
                BOOST_TEST(L.diags.all().size() == 1u, L.text);
                BOOST_TEST(L.has((dir / c.name).string() + c.warning), L.text);
            }
            if (c.name == "analytic-over-particles.xml")  // names the obstacle's own line
                BOOST_TEST(L.has("obstacle at " + (dir / c.name).string() + ":2:"), L.text);
        }
    }
}

BOOST_AUTO_TEST_CASE(files_that_are_not_xml_text_get_plain_errors_at_line_1) {
    const fs::path dir = freshDir("text");
    const std::string utf16le = std::string("\xFF\xFE", 2) + std::string("<\0S\0i\0m\0", 8);
    const std::string utf16be = std::string("\xFE\xFF", 2) + std::string("\0<\0S\0i\0m", 8);
    const std::string utf16noBom = std::string("<\0?\0x\0m\0l\0", 10);
    const std::string png = std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
    struct Case {
        std::string name, bytes, message;
    };
    const Case cases[] = {
        {"empty.xml", "", "the file is empty"},
        {"blank.xml", "  \n\t\n", "the file is empty (it holds only white space)"},
        {"utf16le.xml", utf16le, "UTF-16 is not supported: save it as UTF-8"},
        {"utf16be.xml", utf16be, "UTF-16 is not supported: save it as UTF-8"},
        {"utf16.xml", utf16noBom, "UTF-16 is not supported: save it as UTF-8"},
        {"image.xml", png, "not a text file"},
        {"controls.xml", std::string(64, '\x01') + "<Simulation/>", "not a text file"},
    };
    for (const Case& c : cases) {
        BOOST_TEST_CONTEXT(c.name) {
            write(dir / c.name, c.bytes);
            const Load L(dir / c.name);
            BOOST_TEST(!L.spec.has_value());
            BOOST_TEST(L.diags.errorCount() == 1u, L.text);
            BOOST_TEST(L.has((dir / c.name).string() + ":1: error: " + c.message), L.text);
        }
    }
    // A UTF-8 file with a byte-order mark is text.
    write(dir / "bom.xml", "\xEF\xBB\xBF" + scenario("<Policy id=\"0\">" + kSphSteps));
    BOOST_TEST(Load(dir / "bom.xml").spec.has_value());
    // A named file that is not text: the error is at that file's line 1 and says who named it.
    write(dir / "agents.bin", png);
    write(dir / "main.xml", "<Simulation delta_time=\"0.1\" end_time=\"1\">\n<World type=\"Infinite\"/>\n"
                            "<Policies><Policy id=\"0\">" + kSphSteps + "</Policies>\n<Agents file=\"agents.bin\"/>\n"
                            "</Simulation>\n");
    const Load L(dir / "main.xml");
    BOOST_TEST(!L.spec.has_value());
    BOOST_TEST(L.has((dir / "agents.bin").string() + ":1: error: not a text file"), L.text);
    BOOST_TEST(L.has("(named at " + (dir / "main.xml").string() + ":4)"), L.text);
}

BOOST_AUTO_TEST_CASE(a_file_that_includes_itself_is_named_as_such) {
    const fs::path dir = freshDir("self");
    // The main scenario names itself as its agents file.
    write(dir / "main.xml", "<Simulation delta_time=\"0.1\" end_time=\"1\">\n<World type=\"Infinite\"/>\n"
                            "<Policies><Policy id=\"0\">" + kSphSteps + "</Policies>\n<Agents file=\"main.xml\"/>\n"
                            "</Simulation>\n");
    const Load self(dir / "main.xml");
    BOOST_TEST(!self.spec.has_value());
    BOOST_TEST(self.has((dir / "main.xml").string() +
                        ":4: error: Agents@file: 'main.xml' is this file itself: a file cannot include itself"),
               self.text);
    // A named file that names itself, or another file.
    write(dir / "obstacles.xml", "<Obstacles file=\"./obstacles.xml\"/>\n");
    write(dir / "policies.xml", "<Policies file=\"other.xml\"/>\n");
    write(dir / "outer.xml", "<Simulation delta_time=\"0.1\" end_time=\"1\">\n<World type=\"Infinite\">\n"
                             "<Obstacles file=\"obstacles.xml\"/></World>\n<Policies file=\"policies.xml\"/>\n"
                             "<Agents/></Simulation>\n");
    const Load outer(dir / "outer.xml");
    BOOST_TEST(!outer.spec.has_value());
    BOOST_TEST(outer.has((dir / "obstacles.xml").string() +
                         ":1: error: Obstacles@file: './obstacles.xml' is this file itself: a file cannot include itself"),
               outer.text);
    BOOST_TEST(outer.has((dir / "policies.xml").string() +
                         ":1: error: Policies@file: a file named by file= cannot name another file"),
               outer.text);
}

BOOST_AUTO_TEST_CASE(runs_beyond_the_machine_are_refused_or_warned_before_simulating) {
    const fs::path dir = freshDir("limits");
    const std::string policy =
        "<Policies><Policy id=\"0\" OptimizationMethod=\"gradient\"><costfunction name=\"GoalReachingForce\"/>"
        "</Policy></Policies>\n";
    // Two agents 1e15 m apart: the grids could not cover that; refused at the agent's line.
    write(dir / "far.xml", "<Simulation delta_time=\"0.1\" end_time=\"1\"><World type=\"Infinite\"/>\n" + policy +
                               "<Agents><Agent id=\"0\"><pos x=\"0\" y=\"0\"/><goal x=\"1\" y=\"0\"/><Policy id=\"0\"/></Agent>\n"
                               "<Agent id=\"1\"><pos x=\"1e15\" y=\"1e15\"/><goal x=\"1\" y=\"0\"/><Policy id=\"0\"/></Agent>\n"
                               "</Agents></Simulation>\n");
    const Load far(dir / "far.xml");
    BOOST_TEST(!far.spec.has_value());
    BOOST_TEST(far.has((dir / "far.xml").string() + ":4: error: agent 1 starts at (1e+15, 1e+15) m: coordinates "
                                                     "must lie within ±1e+06 m"),
               far.text);
    // 1e10 fine steps: a warning with the numbers, before anything runs.
    write(dir / "tiny.xml", "<Simulation delta_time=\"1e-9\" end_time=\"10\"><World type=\"Infinite\"/>\n" + policy +
                                "<Agents><Agent id=\"0\"><pos x=\"0\" y=\"0\"/><goal x=\"1\" y=\"0\"/><Policy id=\"0\"/></Agent>"
                                "</Agents></Simulation>\n");
    const Load tiny(dir / "tiny.xml");
    BOOST_TEST(tiny.spec.has_value());
    BOOST_TEST(tiny.has((dir / "tiny.xml").string() + ":1: warning: end_time 10 s in fine steps of 1e-09 s is 1e+10 steps"),
               tiny.text);
    // Agents far apart but within the limit run, and their safety grid stays small: only the
    // cells around each agent are evaluated, not the 9e5 x 9e5 m rectangle between them.
    write(dir / "apart.xml", "<Simulation delta_time=\"0.1\" end_time=\"1\"><World type=\"Infinite\"/>\n" + policy +
                                 "<Agents><Agent id=\"0\"><pos x=\"0\" y=\"0\"/><goal x=\"1\" y=\"0\"/><Policy id=\"0\"/></Agent>"
                                 "<Agent id=\"1\"><pos x=\"9e5\" y=\"-9e5\"/><goal x=\"9e5\" y=\"-9e5\"/><Policy id=\"0\"/></Agent>"
                                 "</Agents></Simulation>\n");
    const Load apart(dir / "apart.xml");
    BOOST_REQUIRE(apart.spec.has_value());
    Simulation sim(*apart.spec);
    SafetyRecorder safety(apart.spec->safety);
    safety.record(sim);
    while (!sim.finished()) {
        sim.stepCoarse();
        safety.record(sim);
    }
    const CrowdField f = crowdField(sim.agents(), 1.0, 0.7);
    BOOST_TEST(f.size() <= 2u * 49u);  // (2·3 + 1)² cells around each agent
    const std::string heat = safety.heatmapCsv();
    BOOST_TEST(std::count(heat.begin(), heat.end(), '\n') < 500);
    BOOST_TEST(f.find(0, 0) < f.size());
    BOOST_TEST(f.density[f.find(0, 0)] > 0.1);
}
