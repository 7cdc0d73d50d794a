// Every JSON file the program writes parses with an independent parser (python3's json module,
// strict about NaN/Infinity), and the readers of summary.json (render --replay, plot, compare)
// report a broken file with its path and what is wrong, exit status 2.
#define BOOST_TEST_MODULE cli_json
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/json.h>

using namespace clitest;

namespace {

/// Parses every *.json under dir with python3; returns how many.
std::size_t checkEveryJson(const fs::path& dir) {
    const auto files = filesEndingIn(dir, ".json");
    for (const fs::path& f : files) BOOST_TEST(pythonJsonProblem(f).empty(), f << ": " << pythonJsonProblem(f));
    return files.size();
}

bool haveGnuplot() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

}  // namespace

BOOST_AUTO_TEST_CASE(python_parses_every_json_a_run_and_its_replications_and_renders_write) {
    BOOST_REQUIRE_MESSAGE(std::system("python3 -c 'import json' >/dev/null 2>&1") == 0, "python3 is needed");
    const fs::path dir = freshDir(caseName());
    // A scenario path with a quote, a backslash and a non-ASCII letter: summary.json names it.
    const fs::path odd = dir / "scén\"ario\\1.xml";
    fs::copy_file(testData("evacuation.xml"), odd);
    Result r = run(dir, {"-i", odd.filename().string(), "-o", "run", "-t", "1", "-q", "--trajectories", "txt,bin"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    r = run(dir, {"-i", odd.filename().string(), "-o", "reps", "--replications", "2", "-t", "2", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    // An interrupted run (its evacuation time and flow are null).
    r = run(dir, {"-i", odd.filename().string(), "-o", "stopped", "-t", "1", "-q", "--debug-interrupt-after", "3"});
    BOOST_REQUIRE_MESSAGE(r.status == 130, r.err);
    std::size_t expected = 4;  // run, reps/run_000, reps/run_001, stopped
    if (haveGnuplot()) {
        r = run(dir, {"render", "--replay", "run", "-o", "frames", "--time", "1", "-q"});
        BOOST_TEST(r.status == 0, r.err);
        ++expected;  // frames/render.json
    } else {
        BOOST_TEST_MESSAGE("gnuplot missing: render.json not checked");
    }
    BOOST_TEST(checkEveryJson(dir) == expected);

    // What the independent parser read is what the program meant.
    const ch::Json s = ch::readJsonFile(dir / "run" / "summary.json");
    BOOST_TEST(s["scenario"].get<std::string>() == odd.filename().string());
    BOOST_TEST(s["interrupted"].get<bool>() == false);
    const ch::Json stopped = ch::readJsonFile(dir / "stopped" / "summary.json");
    BOOST_TEST(stopped["interrupted"].get<bool>());
    BOOST_TEST(stopped["evacuation_time"].is_null());
    BOOST_TEST(stopped["coarse_steps"].get<int>() == 3);
}

BOOST_AUTO_TEST_CASE(a_broken_summary_json_is_reported_with_its_path_and_the_problem) {
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "run", "-t", "1", "-q", "--trajectories", "txt"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::string good = readFile(dir / "run" / "summary.json");
    std::ofstream(dir / "run" / "summary.json") << good.substr(0, good.size() / 2);  // cut in the middle

    const std::string path = (fs::path("run") / "summary.json").string();
    r = run(dir, {"plot", "run", "-q"});
    if (haveGnuplot()) {
        BOOST_TEST(r.status == 2, r.err);
        BOOST_TEST(r.err.find(path + ": not valid JSON") != std::string::npos, r.err);
        BOOST_TEST(r.err.find("line ") != std::string::npos, r.err);
        r = run(dir, {"compare", "run", "-o", "cmp", "--no-plot", "-q"});
        BOOST_TEST(r.status == 2, r.err);
        BOOST_TEST(r.err.find(path + ": not valid JSON") != std::string::npos, r.err);
        r = run(dir, {"render", "--replay", "run", "-o", "frames", "--time", "1", "-q"});
        BOOST_TEST(r.status == 2, r.err);
        BOOST_TEST(r.err.find(path + ": not valid JSON") != std::string::npos, r.err);
    } else {
        BOOST_TEST_MESSAGE("gnuplot missing: plot and render not checked");
    }
    r = run(dir, {"compare", "run", "-o", "cmp", "--no-plot", "-q"});
    BOOST_TEST(r.status == 2, r.err);
    BOOST_TEST(r.err.find(path + ": not valid JSON") != std::string::npos, r.err);

    // Valid JSON, wrong type: named with the key.
    std::ofstream(dir / "run" / "summary.json") << "{\"scenario\": 3, \"evacuation_time\": \"soon\"}\n";
    r = run(dir, {"compare", "run", "-o", "cmp", "--no-plot", "-q"});
    BOOST_TEST(r.status == 2, r.err);
    BOOST_TEST(r.err.find(path + ": \"scenario\" should be a string") != std::string::npos, r.err);
}
