// Signals sent from outside to a running program (cli_interrupt_test raises SIGINT from inside):
// SIGTERM behaves like Ctrl-C; SIGKILL mid-run leaves every file of the last completed write
// intact and no half-written file under a final name; SIGINT to `--replications N -t 2` stops
// every run going cleanly, with valid outputs for the time each simulated and a clear summary.
//
// The runs are long on purpose (two agents that never leave, --end-time 1e6 s: minutes of work);
// the tests wait until the run is under way (its streamed trajectories.txt.tmp grows), signal it,
// and wait for it to end.
#define BOOST_TEST_MODULE cli_signals
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/json.h>

#include <map>

using namespace clitest;

namespace {

/// A run that goes on until it is stopped: two agents that never leave, 10^7 coarse steps,
/// a trajectory frame every 100 s (so the streamed file grows while it runs).
std::vector<std::string> longRun(const std::string& out) {
    return {"-i", testData("stay.xml"), "-o", out, "--end-time", "1e6", "--trajectories", "txt",
            "--trajectory-interval", "100", "-q", "-t", "1"};
}

/// Waits until `file` exists and has grown past its first bytes (the run is under way).
bool underWay(Background& p, const fs::path& file) {
    return waitFor([&] { return sizeOf(file) > 200 || !p.running(); }) && p.running();
}

/// Every file of dir by name → content (the helpers' _ files left out).
std::map<std::string, std::string> contents(const fs::path& dir) {
    std::map<std::string, std::string> m;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string n = e.path().filename().string();
        if (n[0] != '_' && e.is_regular_file()) m[n] = readFile(e.path());
    }
    return m;
}

/// metrics.csv ends at the time summary.json says was simulated.
void metricsEndAtTheSimulatedTime(const fs::path& dir) {
    const ch::Json s = ch::readJsonFile(dir / "summary.json");
    const auto rows = lines(readFile(dir / "metrics.csv"));
    BOOST_REQUIRE(rows.size() >= 2u);
    const double last = std::stod(split(rows.back(), ',').at(0));
    BOOST_TEST(std::abs(last - s["simulated_time"].get<double>()) < 1e-6, dir << ": " << rows.back());
}

}  // namespace

BOOST_AUTO_TEST_CASE(sigterm_stops_a_run_like_ctrl_c) {
    const fs::path dir = freshDir(caseName());
    Background p(dir, longRun("out"));
    BOOST_REQUIRE_MESSAGE(underWay(p, dir / "out" / "trajectories.txt.tmp"), p.err());
    p.signal(SIGTERM);
    const int status = p.wait();
    BOOST_TEST(status == 130, status << " " << p.err());
    BOOST_TEST(p.err().find("interrupted at t = ") != std::string::npos, p.err());

    const fs::path out = dir / "out";
    BOOST_TEST(pythonJsonProblem(out / "summary.json").empty());
    const ch::Json s = ch::readJsonFile(out / "summary.json");
    BOOST_TEST(s["interrupted"].get<bool>());
    BOOST_TEST(s["simulated_time"].get<double>() > 100.0);  // some frames were streamed
    BOOST_TEST(s["simulated_time"].get<double>() < 1e6);
    metricsEndAtTheSimulatedTime(out);
    BOOST_TEST(fs::exists(out / "trajectories.txt"));
    BOOST_TEST(tmpFiles(out).empty());
    BOOST_TEST(manifestOf(out).size() == 6u);
}

BOOST_AUTO_TEST_CASE(sigkill_leaves_the_files_of_the_last_completed_write_intact) {
    const fs::path dir = freshDir(caseName());
    // A completed run first.
    Result r = run(dir, {"-i", testData("stay.xml"), "-o", "out", "--end-time", "5", "--trajectories", "txt", "-q",
                         "-t", "1"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const auto before = contents(dir / "out");
    BOOST_REQUIRE(before.size() == 7u);  // 6 outputs and the manifest

    // Then a long run into the same folder, killed outright while it simulates.
    {
        Background p(dir, longRun("out"));
        // Under way: its trajectories stream into the .tmp — or, should files ever be written in
        // place, 5 s have passed; the checks below then see the damage instead of timing out.
        waitFor([&] { return sizeOf(dir / "out" / "trajectories.txt.tmp") > 200 || !p.running(); }, 5);
        BOOST_REQUIRE_MESSAGE(p.running(), p.err());
        p.signal(SIGKILL);
        BOOST_TEST(p.wait() == 1000 + SIGKILL);
    }
    // Every file under a final name is the earlier run's, whole; only .tmp files are new.
    auto after = contents(dir / "out");
    for (const auto& [name, text] : before) {
        BOOST_TEST(after.count(name) == 1u, name);
        BOOST_TEST(after[name] == text, name);
    }
    for (const auto& [name, text] : after)
        if (!before.count(name)) BOOST_TEST(fs::path(name).extension() == ".tmp", name);
    BOOST_TEST(after.count("trajectories.txt.tmp") == 1u);
    BOOST_TEST(pythonJsonProblem(dir / "out" / "summary.json").empty());

    // The next run into the folder knows the leftovers as its own: not refused, cleaned up.
    r = run(dir, {"-i", testData("stay.xml"), "-o", "out", "--end-time", "3", "-q", "-t", "1"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(tmpFiles(dir / "out").empty());
    BOOST_TEST(!fs::exists(dir / "out" / "trajectories.txt"));  // the earlier run's, not written now
}

BOOST_AUTO_TEST_CASE(sigint_stops_every_run_of_replications_cleanly) {
    const fs::path dir = freshDir(caseName());
    std::vector<std::string> args = longRun("out");
    args.back() = "2";  // -t 2: two runs at a time
    for (const char* a : {"--replications", "4"}) args.push_back(a);
    Background p(dir, args);
    BOOST_REQUIRE_MESSAGE(underWay(p, dir / "out" / "run_000" / "trajectories.txt.tmp"), p.err());
    BOOST_REQUIRE_MESSAGE(underWay(p, dir / "out" / "run_001" / "trajectories.txt.tmp"), p.err());
    p.signal(SIGINT);
    const int status = p.wait();
    BOOST_TEST(status == 130, status << " " << p.err());
    BOOST_TEST(p.err().find("interrupted: 2 runs stopped early") != std::string::npos, p.err());
    BOOST_TEST(p.err().find("2 runs not started") != std::string::npos, p.err());

    const fs::path out = dir / "out";
    for (const char* k : {"run_000", "run_001"}) {
        BOOST_TEST(pythonJsonProblem(out / k / "summary.json").empty(), k);
        const ch::Json s = ch::readJsonFile(out / k / "summary.json");
        BOOST_TEST(s["interrupted"].get<bool>(), k);
        BOOST_TEST(s["simulated_time"].get<double>() > 100.0, k);
        metricsEndAtTheSimulatedTime(out / k);
        BOOST_TEST(fs::exists(out / k / "trajectories.txt"), k);
    }
    BOOST_TEST(!fs::exists(out / "run_002"));
    BOOST_TEST(!fs::exists(out / "run_003"));
    BOOST_TEST(tmpFiles(out).empty());
    const auto rows = lines(readFile(out / "summary.csv"));
    BOOST_REQUIRE(rows.size() == 6u);  // header, 2 runs, mean, sd, n
    BOOST_TEST(rows[1].rfind("run_000,", 0) == 0u);
    BOOST_TEST(rows[1].substr(rows[1].size() - 5) == ",true");
    BOOST_TEST(rows[2].substr(rows[2].size() - 5) == ",true");
    BOOST_TEST(manifestOf(out) == (std::vector<std::string>{"run_000/", "run_001/", "summary.csv"}));
}

BOOST_AUTO_TEST_CASE(a_run_killed_while_writing_leaves_no_file_the_next_run_would_not_know) {
    // The program's hidden --debug-kill-before-summary sends itself SIGKILL after writing every
    // output but summary.json: the instant a kill while writing is most damaging.
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "-q", "-t", "1"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::string summary = readFile(dir / "out" / "summary.json");
    r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "-q", "-t", "1", "--end-time", "2",
                  "--trajectories", "umans,txt", "--debug-kill-before-summary"});
    BOOST_TEST((r.status == 128 + SIGKILL || r.status == -1), r.status << " " << r.err);  // killed (the shell says 137)
    // The new files are whole, summary.json is still the earlier run's (it is written last).
    BOOST_TEST(fs::exists(dir / "out" / "trajectories.txt"));
    BOOST_TEST(fs::exists(dir / "out" / "output_0.csv"));
    BOOST_TEST(readFile(dir / "out" / "summary.json") == summary);
    BOOST_TEST(lines(readFile(dir / "out" / "metrics.csv")).back().rfind("2,", 0) == 0u);
    // The manifest already listed the files being written: the next run knows them all, is not
    // refused, and removes those it does not write.
    r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "-q", "-t", "1"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(!fs::exists(dir / "out" / "trajectories.txt"));
    BOOST_TEST(!fs::exists(dir / "out" / "output_0.csv"));
    BOOST_TEST(manifestOf(dir / "out").size() == 5u);
}
