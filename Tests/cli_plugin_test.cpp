// Plugins (issue 18, docs/adding-a-policy.md): a force from a shared library built apart from the
// program (Examples/plugin, DistancingForce) runs in a scenario named by <Plugin file="…"/> or by
// --plugin; --list-policies lists it with its parameters; the loader checks them like a built-in
// component's; and every plugin that cannot be used is refused with the file and the reason.
#define BOOST_TEST_MODULE cli_plugin
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <cmath>
#include <fstream>
#include <map>

using namespace clitest;

namespace {

const std::string kPlugin = CH_EXAMPLE_PLUGIN;
const fs::path kRefused = CH_TEST_PLUGIN_DIR;

/// Two walkers side by side, 1 m apart (centres at y = ±0.5), walking +x for 10 s. `plugin` is
/// put inside <Simulation>, `extra` inside the policy after GoalReachingForce.
std::string twoWalkers(const std::string& plugin, const std::string& extra) {
    std::string agents;
    for (int k = 0; k < 2; ++k) {
        const std::string y = k == 0 ? "0.5" : "-0.5";
        agents += "    <Agent id=\"" + std::to_string(k) + "\" rad=\"0.25\" pref_speed=\"1.2\" max_speed=\"1.6\">"
                  "<pos x=\"0\" y=\"" + y + "\"/><goal x=\"100\" y=\"" + y + "\"/><Policy id=\"0\"/></Agent>\n";
    }
    return "<Simulation delta_time=\"0.1\" end_time=\"10\">\n" + plugin +
           "  <World type=\"Infinite\" />\n"
           "  <Policies>\n"
           "    <Policy id=\"0\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\">\n"
           "      <costfunction name=\"GoalReachingForce\" />\n" +
           extra +
           "    </Policy>\n"
           "  </Policies>\n"
           "  <Agents>\n" + agents + "  </Agents>\n"
           "</Simulation>\n";
}

std::string pluginElement(const std::string& file) { return "  <Plugin file=\"" + file + "\" />\n"; }

/// The distance between the two walkers in the last frame of trajectories.txt.
double finalSeparation(const fs::path& file) {
    std::map<long, std::map<long, std::pair<double, double>>> frames;
    for (const std::string& l : lines(readFile(file))) {
        if (l.empty() || l[0] == '#') continue;
        std::istringstream in(l);
        long id = -1, frame = -1;
        double x = 0, y = 0, z = 0;
        BOOST_REQUIRE_MESSAGE(static_cast<bool>(in >> id >> frame >> x >> y >> z), "row: " << l);
        frames[frame][id] = {x, y};
    }
    BOOST_REQUIRE(!frames.empty());
    const auto& last = frames.rbegin()->second;
    BOOST_REQUIRE(last.size() == 2u);
    const auto& a = last.at(0);
    const auto& b = last.at(1);
    return std::hypot(a.first - b.first, a.second - b.second);
}

/// The line of `text` in `file` (1-based; 0 if absent).
int lineOf(const fs::path& file, const std::string& text) {
    const auto all = lines(readFile(file));
    for (std::size_t i = 0; i < all.size(); ++i)
        if (all[i].find(text) != std::string::npos) return static_cast<int>(i) + 1;
    return 0;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

BOOST_AUTO_TEST_CASE(list_policies_shows_the_plugin_force_and_its_parameters) {
    const fs::path dir = freshDir(caseName());
    const Result without = run(dir, {"--list-policies"});
    BOOST_REQUIRE_MESSAGE(without.status == 0, without.err);
    BOOST_TEST(!contains(without.out, "DistancingForce"));
    const Result r = run(dir, {"--plugin", kPlugin, "--list-policies"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const auto at = r.out.find("\nDistancingForce  [force]");
    BOOST_REQUIRE_MESSAGE(at != std::string::npos, r.out);
    const std::string entry = r.out.substr(at, r.out.find("\n\n", at + 1) - at);
    BOOST_TEST(contains(entry, "From the plugin " + fs::canonical(kPlugin).string()));
    BOOST_TEST(contains(entry, "distance"));
    BOOST_TEST(contains(entry, "[0, 10]"));
    BOOST_TEST(contains(entry, "strength"));
    BOOST_TEST(contains(entry, "coeff"));  // the common parameters, as for built-in components
    const Result md = run(dir, {"--plugin", kPlugin, "--list-policies", "--format", "markdown"});
    BOOST_REQUIRE_MESSAGE(md.status == 0, md.err);
    BOOST_TEST(contains(md.out, "### DistancingForce"));
    BOOST_TEST(contains(md.out, "*From the plugin*"));
}

BOOST_AUTO_TEST_CASE(the_plugin_force_keeps_two_walkers_at_its_distance) {
    // Without the force the two walk straight on, 1 m apart. With it (distance 1.5 m) they are
    // pushed apart until 1.5 m and then feel nothing more: the linear spring with the goal force's
    // damping (τ = 0.5 s) settles within a few seconds, with a small overshoot at most.
    const fs::path dir = freshDir(caseName());
    writeText(dir / "without.xml", twoWalkers("", ""));
    writeText(dir / "with.xml", twoWalkers(pluginElement(kPlugin),
                                           "      <costfunction name=\"DistancingForce\" distance=\"1.5\" strength=\"2\" />\n"));
    const Result a = run(dir, {"-i", "without.xml", "-o", "without", "--trajectories", "txt", "-q"});
    BOOST_REQUIRE_MESSAGE(a.status == 0, a.err);
    const Result b = run(dir, {"-i", "with.xml", "-o", "with", "--trajectories", "txt", "-q"});
    BOOST_REQUIRE_MESSAGE(b.status == 0, b.err);
    BOOST_TEST(std::abs(finalSeparation(dir / "without" / "trajectories.txt") - 1.0) < 1e-9);
    const double d = finalSeparation(dir / "with" / "trajectories.txt");
    BOOST_TEST_MESSAGE("separation with DistancingForce after 10 s: " << d << " m");
    BOOST_TEST(d > 1.49);
    BOOST_TEST(d < 1.60);

    // The same run with the plugin given on the command line instead, and on 1 and 2 threads:
    // the same bits.
    writeText(dir / "cli.xml", twoWalkers("", "      <costfunction name=\"DistancingForce\" distance=\"1.5\" strength=\"2\" />\n"));
    const Result c1 = run(dir, {"--plugin", kPlugin, "-i", "cli.xml", "-o", "cli1", "--trajectories", "txt", "-q", "-t", "1"});
    BOOST_REQUIRE_MESSAGE(c1.status == 0, c1.err);
    const Result c2 = run(dir, {"--plugin", kPlugin, "-i", "cli.xml", "-o", "cli2", "--trajectories", "txt", "-q", "-t", "2"});
    BOOST_REQUIRE_MESSAGE(c2.status == 0, c2.err);
    BOOST_TEST(readFile(dir / "cli1" / "trajectories.txt") == readFile(dir / "with" / "trajectories.txt"));
    BOOST_TEST(readFile(dir / "cli2" / "trajectories.txt") == readFile(dir / "with" / "trajectories.txt"));
    BOOST_TEST(readFile(dir / "cli1" / "metrics.csv") == readFile(dir / "cli2" / "metrics.csv"));
    // summary.json names the plugin (provenance), whether <Plugin> or --plugin brought it.
    const std::string quoted = "\"plugins\": [\n    \"" + fs::canonical(kPlugin).string() + "\"\n  ]";
    BOOST_TEST(contains(readFile(dir / "with" / "summary.json"), quoted), readFile(dir / "with" / "summary.json"));
    BOOST_TEST(contains(readFile(dir / "cli1" / "summary.json"), quoted));
    BOOST_TEST(contains(readFile(dir / "without" / "summary.json"), "\"plugins\": [],"));
}

BOOST_AUTO_TEST_CASE(a_plugin_named_in_a_policies_file_relative_to_that_file) {
    // <Plugin> inside <Policies file="…">, its path relative to the policies file; named again by
    // --plugin: loaded once, no error.
    const fs::path dir = freshDir(caseName());
    fs::create_directories(dir / "lib");
    fs::copy_file(kPlugin, dir / "lib" / "libdistancing.so");
    writeText(dir / "policies" / "distancing.xml",
              "<Policies>\n  <Plugin file=\"../lib/libdistancing.so\" />\n"
              "  <Policy id=\"0\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\">\n"
              "    <costfunction name=\"GoalReachingForce\" />\n"
              "    <costfunction name=\"DistancingForce\" distance=\"1.5\" />\n"
              "  </Policy>\n</Policies>\n");
    std::string xml = twoWalkers("", "");
    const auto from = xml.find("  <Policies>"), to = xml.find("</Policies>\n") + 12;
    xml.replace(from, to - from, "  <Policies file=\"policies/distancing.xml\" />\n");
    writeText(dir / "scenario.xml", xml);
    const Result r = run(dir, {"-i", "scenario.xml", "-o", "out", "--trajectories", "txt", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(finalSeparation(dir / "out" / "trajectories.txt") > 1.49);
    const Result twice = run(dir, {"--plugin", "lib/libdistancing.so", "-i", "scenario.xml", "-o", "out2", "-q"});
    BOOST_TEST_MESSAGE(twice.err);
    BOOST_TEST(twice.status == 0);
}

BOOST_AUTO_TEST_CASE(a_sweep_is_not_resumed_after_an_included_file_or_a_plugin_changed) {
    // The scenario names a policies file, which names the plugin. A sweep's resume compares the
    // content of both with the first call's (OUTDIR/.sweep/arguments): an edited policies file or
    // a rebuilt plugin is refused, exit 2, naming what changed; nothing in OUTDIR changes.
    const fs::path dir = freshDir(caseName());
    fs::create_directories(dir / "lib");
    fs::copy_file(kPlugin, dir / "lib" / "libdistancing.so");
    const std::string policies = "<Policies>\n  <Plugin file=\"../lib/libdistancing.so\" />\n"
                                 "  <Policy id=\"0\" OptimizationMethod=\"gradient\" RelaxationTime=\"0.5\">\n"
                                 "    <costfunction name=\"GoalReachingForce\" />\n"
                                 "    <costfunction name=\"DistancingForce\" distance=\"1.5\" />\n"
                                 "  </Policy>\n</Policies>\n";
    writeText(dir / "policies" / "distancing.xml", policies);
    std::string xml = twoWalkers("", "");
    const auto from = xml.find("  <Policies>"), to = xml.find("</Policies>\n") + 12;
    xml.replace(from, to - from, "  <Policies file=\"policies/distancing.xml\" />\n");
    writeText(dir / "scenario.xml", xml);
    const std::vector<std::string> args = {"sweep", "-i", "scenario.xml", "-o", "sw", "--vary", "agents.pref_speed=1,1.2",
                                           "--end-time", "2", "--quiet"};
    const Result first = run(dir, args);
    BOOST_REQUIRE_MESSAGE(first.status == 0, first.err);
    const std::string summary = readFile(dir / "sw" / "sweep-summary.csv");
    const std::string arguments = readFile(dir / "sw" / ".sweep" / "arguments");
    BOOST_TEST(contains(arguments, "included " + fs::canonical(dir / "policies" / "distancing.xml").string() + " (content "), arguments);
    BOOST_TEST(contains(arguments, "plugin " + fs::canonical(dir / "lib" / "libdistancing.so").string() + " (content "), arguments);
    // Unchanged files: the same call resumes (nothing left to run).
    const Result same = run(dir, args);
    BOOST_TEST(same.status == 0, same.err);

    writeText(dir / "policies" / "distancing.xml", policies.substr(0, policies.find("1.5")) + "1.4" +
                                                       policies.substr(policies.find("1.5") + 3));
    const Result edited = run(dir, args);
    BOOST_TEST(edited.status == 2);
    BOOST_TEST(contains(edited.err, "other arguments"), edited.err);
    const std::string policiesFile = fs::canonical(dir / "policies" / "distancing.xml").string();
    BOOST_TEST(contains(edited.err, "there: 'included " + policiesFile + " (content "), edited.err);
    BOOST_TEST(contains(edited.err, "now: 'included " + policiesFile + " (content "), edited.err);
    writeText(dir / "policies" / "distancing.xml", policies);
    BOOST_TEST(run(dir, args).status == 0);

    // A rebuilt plugin: other bytes in the same file (bytes appended to a shared library leave it
    // loadable).
    {
        std::ofstream lib(dir / "lib" / "libdistancing.so", std::ios::binary | std::ios::app);
        lib << "rebuilt";
    }
    const Result rebuilt = run(dir, args);
    BOOST_TEST(rebuilt.status == 2);
    BOOST_TEST(contains(rebuilt.err, "there: 'plugin " + fs::canonical(dir / "lib" / "libdistancing.so").string() + " (content "),
               rebuilt.err);
    BOOST_TEST(readFile(dir / "sw" / "sweep-summary.csv") == summary);
    BOOST_TEST(readFile(dir / "sw" / ".sweep" / "arguments") == arguments);
}

BOOST_AUTO_TEST_CASE(the_loader_checks_plugin_parameters_like_built_in_ones) {
    const fs::path dir = freshDir(caseName());
    writeText(dir / "range.xml", twoWalkers(pluginElement(kPlugin), "      <costfunction name=\"DistancingForce\" distance=\"20\" />\n"));
    const Result r = run(dir, {"-i", "range.xml", "-o", "out", "-q"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(contains(r.err, "range.xml:" + std::to_string(lineOf(dir / "range.xml", "distance=\"20\"")) + ": error:"), r.err);
    BOOST_TEST(contains(r.err, "distance"));
    BOOST_TEST(!fs::exists(dir / "out"));

    writeText(dir / "typo.xml", twoWalkers(pluginElement(kPlugin), "      <costfunction name=\"DistancingForce\" distanse=\"1\" />\n"));
    const Result t = run(dir, {"-i", "typo.xml", "--check"});
    BOOST_TEST(t.status == 2);
    BOOST_TEST(contains(t.err, "typo.xml:" + std::to_string(lineOf(dir / "typo.xml", "distanse")) + ": error:"), t.err);
    BOOST_TEST(contains(t.err, "did you mean 'distance'"), t.err);

    // Without the plugin the name is unknown, and the message says where such names come from.
    writeText(dir / "missing.xml", twoWalkers("", "      <costfunction name=\"DistancingForce\" />\n"));
    const Result m = run(dir, {"-i", "missing.xml", "--check"});
    BOOST_TEST(m.status == 2);
    BOOST_TEST(contains(m.err, "unknown cost function 'DistancingForce'"), m.err);
    BOOST_TEST(contains(m.err, "--plugin"), m.err);
}

BOOST_AUTO_TEST_CASE(plugins_that_cannot_be_used_are_refused_with_the_file_and_the_reason) {
    const fs::path dir = freshDir(caseName());
    writeText(dir / "not-a-library.so", "this is text\n");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"nowhere.so", "no such file"},
        {"not-a-library.so", "not a shared library"},
        {(kRefused / "libno_entry.so").string(), "has no entry point crowdhealth_plugin_abi: not a CrowdHealth plugin"},
        {(kRefused / "libwrong_version.so").string(), "was built against 'CrowdHealth 0.0.1, plugin interface 1"},
        {(kRefused / "libmissing_symbol.so").string(), "undefined symbol"},
        {(kRefused / "libduplicate.so").string(), "'GoalReachingForce' is registered twice (the name is a built-in component's)"},
    };
    for (const auto& [file, why] : cases) {
        BOOST_TEST_CONTEXT(file) {
            // In a scenario: path:line: error: Plugin@file: 'FILE' REASON; nothing written.
            writeText(dir / "scenario.xml", twoWalkers(pluginElement(file), ""));
            const Result r = run(dir, {"-i", "scenario.xml", "-o", "out", "-q"});
            BOOST_TEST(r.status == 2);
            BOOST_TEST(contains(r.err, "scenario.xml:2: error: Plugin@file: '" + file + "' "), r.err);
            BOOST_TEST(contains(r.err, why), r.err);
            BOOST_TEST(!fs::exists(dir / "out"));
            // On the command line: crowdhealth: error: --plugin 'FILE': REASON.
            const Result c = run(dir, {"--plugin", file, "--list-policies"});
            BOOST_TEST(c.status == 2);
            BOOST_TEST(contains(c.err, "crowdhealth: error: --plugin '" + file + "': "), c.err);
            BOOST_TEST(contains(c.err, why), c.err);
            BOOST_TEST(c.out.empty());
        }
    }
    // The wrong version is said in full, with what to do.
    const Result v = run(dir, {"--plugin", (kRefused / "libwrong_version.so").string(), "--list-policies"});
    BOOST_TEST(contains(v.err, "this program is 'CrowdHealth "), v.err);
    BOOST_TEST(contains(v.err, "rebuild the plugin"), v.err);
    // A refused plugin registers nothing, not even its valid components.
    writeText(dir / "both.xml", twoWalkers(pluginElement((kRefused / "libduplicate.so").string()),
                                           "      <costfunction name=\"ValidButRefusedWithItsPlugin\" />\n"));
    const Result both = run(dir, {"-i", "both.xml", "--check"});
    BOOST_TEST(both.status == 2);
    BOOST_TEST(contains(both.err, "unknown cost function 'ValidButRefusedWithItsPlugin'"), both.err);
    BOOST_TEST(contains(both.err, "a <Plugin> of this scenario could not be loaded"), both.err);
    // <Plugin> without file=.
    writeText(dir / "nofile.xml", twoWalkers("  <Plugin />\n", ""));
    const Result n = run(dir, {"-i", "nofile.xml", "--check"});
    BOOST_TEST(n.status == 2);
    BOOST_TEST(contains(n.err, "nofile.xml:2: error: <Plugin> needs file="), n.err);
}

BOOST_AUTO_TEST_CASE(a_bare_plugin_name_is_found_in_CROWDHEALTH_PLUGIN_PATH) {
    const fs::path dir = freshDir(caseName());
    writeText(dir / "scenario.xml", twoWalkers(pluginElement("libdistancing.so"),
                                               "      <costfunction name=\"DistancingForce\" />\n"));
    const Result none = run(dir, {"-i", "scenario.xml", "--check"});
    BOOST_TEST(none.status == 2);
    BOOST_TEST(contains(none.err, "'libdistancing.so' no such file"), none.err);
    const std::string path = "CROWDHEALTH_PLUGIN_PATH=/nonexistent:" + fs::path(kPlugin).parent_path().string();
    const Result r = runIn(dir, "env " + shellQuote(path), CH_BINARY, {"-i", "scenario.xml", "--check"});
    BOOST_TEST(r.status == 0, r.err);
}

BOOST_AUTO_TEST_CASE(sweep_and_calibrate_take_plugin_parameters) {
    // A plugin's parameter is a sweep target like any other, with --plugin or <Plugin>.
    const fs::path dir = freshDir(caseName());
    writeText(dir / "cli.xml", twoWalkers("", "      <costfunction name=\"DistancingForce\" />\n"));
    const Result r = run(dir, {"sweep", "--plugin", kPlugin, "-i", "cli.xml", "-o", "sweep", "--vary",
                               "0.DistancingForce.distance=1,1.5", "--quiet", "--jobs", "1"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const auto rows = lines(readFile(dir / "sweep" / "sweep.csv"));
    BOOST_REQUIRE(rows.size() == 3u);
    BOOST_TEST(contains(rows[0], "0.DistancingForce.distance"));
    BOOST_TEST(contains(rows[1], ",ok,"), rows[1]);
    BOOST_TEST(contains(rows[2], ",ok,"), rows[2]);
    const Result bad = run(dir, {"sweep", "--plugin", "nowhere.so", "-i", "cli.xml", "-o", "sweep2", "--vary",
                                 "0.DistancingForce.distance=1"});
    BOOST_TEST(bad.status == 2);
    BOOST_TEST(contains(bad.err, "crowdhealth: error: --plugin 'nowhere.so': no such file"), bad.err);
    const Result cal = run(dir, {"calibrate", "--plugin", "nowhere.so", "-i", "cli.xml", "--data", "x.csv", "--fit",
                                 "0.DistancingForce.distance=1:2", "-o", "cal"});
    BOOST_TEST(cal.status == 2);
    BOOST_TEST(contains(cal.err, "crowdhealth: error: --plugin 'nowhere.so': no such file"), cal.err);
    BOOST_TEST(!fs::exists(dir / "sweep2"));
    BOOST_TEST(!fs::exists(dir / "cal"));
}
