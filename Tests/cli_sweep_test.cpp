// `crowdhealth sweep`: the Cartesian product of --vary values × seeds, run several at a time,
// written to sweep.csv (one row per run, in run order) and sweep-summary.csv (mean, sd, 95 % CI,
// n per combination); resumable from the per-run records in OUTDIR/.sweep/runs; bad targets and
// values exit 2 naming the argument. Tests/data/cli/doorway-small.xml: 42 agents leave a 6 x 6 m
// room through a door (seed 11, end time 20 s), the SPH model as policy 0.
#define BOOST_TEST_MODULE cli_sweep
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <map>

using namespace clitest;

namespace {

std::string scenario() { return testData("doorway-small.xml"); }

const std::vector<std::string> kGrid = {"--vary", "0.SPH.restDensityMax=4,6", "--vary", "agents.pref_speed=1,1.6",
                                        "--replications", "2", "--seed", "5", "--quiet"};

std::vector<std::string> sweepArgs(const fs::path& out, const std::vector<std::string>& more) {
    std::vector<std::string> a = {"sweep", "-i", scenario(), "-o", out.string()};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

/// A CSV as rows of cells by column name.
struct Csv {
    std::vector<std::string> header;
    std::vector<std::map<std::string, std::string>> rows;
    explicit Csv(const std::string& text) {
        const auto all = lines(text);
        BOOST_REQUIRE(!all.empty());
        header = split(all[0], ',');
        for (std::size_t i = 1; i < all.size(); ++i) {
            const auto c = split(all[i], ',');
            BOOST_REQUIRE_MESSAGE(c.size() == header.size(), "line " << i << ": " << all[i]);
            std::map<std::string, std::string> row;
            for (std::size_t k = 0; k < c.size(); ++k) row[header[k]] = c[k];
            rows.push_back(row);
        }
    }
};

/// sweep.csv without its last column (wall_time).
std::string withoutWallTime(const std::string& text) {
    std::string out;
    for (const std::string& l : lines(text)) out += l.substr(0, l.rfind(',')) + "\n";
    return out;
}

/// The 2 x 2 x 2 sweep, run once per process of this test suite (the other cases compare with it).
const fs::path& gridDir() {
    static const fs::path dir = [] {
        const fs::path d = freshDir("grid");
        const Result r = run(d, sweepArgs(d / "out", [] {
            auto a = kGrid;
            a.insert(a.end(), {"--jobs", "2"});
            return a;
        }()));
        BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
        return d / "out";
    }();
    return dir;
}

}  // namespace

BOOST_AUTO_TEST_CASE(grid_rows_and_summary) {
    const Csv runs(readFile(gridDir() / "sweep.csv"));
    const std::vector<std::string> header = {"run", "0.SPH.restDensityMax", "agents.pref_speed", "seed", "status",
                                             "evacuated", "evacuation_time", "flow", "peak_density",
                                             "peak_contact_accel", "injured", "verdict", "wall_time"};
    BOOST_TEST(runs.header == header, boost::test_tools::per_element());
    BOOST_REQUIRE_EQUAL(runs.rows.size(), 8u);
    // Run order: the first --vary slowest, the seed fastest.
    const std::vector<std::array<std::string, 3>> expected = {
        {"4", "1", "5"}, {"4", "1", "6"}, {"4", "1.6", "5"}, {"4", "1.6", "6"},
        {"6", "1", "5"}, {"6", "1", "6"}, {"6", "1.6", "5"}, {"6", "1.6", "6"}};
    for (std::size_t k = 0; k < 8; ++k) {
        const auto& r = runs.rows[k];
        BOOST_TEST(r.at("run") == std::to_string(k));
        BOOST_TEST(r.at("0.SPH.restDensityMax") == expected[k][0]);
        BOOST_TEST(r.at("agents.pref_speed") == expected[k][1]);
        BOOST_TEST(r.at("seed") == expected[k][2]);
        BOOST_TEST(r.at("status") == "ok");
        BOOST_TEST(r.at("evacuated") == "42");  // everybody leaves within 20 s
        BOOST_TEST(!r.at("evacuation_time").empty());
        BOOST_TEST(std::stod(r.at("peak_density")) > 0);
    }
    // The two seeds of a combination are different runs.
    BOOST_TEST(runs.rows[0].at("evacuation_time") != runs.rows[1].at("evacuation_time"));

    const Csv summary(readFile(gridDir() / "sweep-summary.csv"));
    BOOST_REQUIRE_EQUAL(summary.rows.size(), 4u);
    for (std::size_t c = 0; c < 4; ++c) {
        const auto& s = summary.rows[c];
        BOOST_TEST(s.at("0.SPH.restDensityMax") == expected[2 * c][0]);
        BOOST_TEST(s.at("agents.pref_speed") == expected[2 * c][1]);
        BOOST_TEST(s.at("runs") == "2");
        BOOST_TEST(s.at("failed") == "0");
        for (const std::string out : {"evacuated", "evacuation_time", "flow", "peak_density", "peak_contact_accel", "injured"}) {
            const double a = std::stod(runs.rows[2 * c].at(out)), b = std::stod(runs.rows[2 * c + 1].at(out));
            const double mean = (a + b) / 2, sd = std::abs(a - b) / std::sqrt(2.0);
            BOOST_TEST(std::stod(s.at(out + "_mean")) == mean, boost::test_tools::tolerance(1e-8));
            BOOST_TEST(s.at(out + "_n") == "2");
            // The rows have 10 significant digits: a small sd is known to about 1e-9 of the values.
            const double scale = 1e-8 * std::max({1.0, std::abs(a), std::abs(b)});
            BOOST_TEST(std::abs(std::stod(s.at(out + "_sd")) - sd) <= scale, out << " sd");
            // Student t, 1 degree of freedom: t(0.975) = 12.7062047.
            BOOST_TEST(std::abs(std::stod(s.at(out + "_ci95")) - 12.7062047 * sd / std::sqrt(2.0)) <= 13 * scale, out << " ci95");
        }
    }
    // A value applied really changes the run: walking at 1.6 m/s empties the room sooner than at 1 m/s.
    for (const std::size_t c : {0u, 2u})
        BOOST_TEST(std::stod(summary.rows[c + 1].at("evacuation_time_mean")) <
                   std::stod(summary.rows[c].at("evacuation_time_mean")) - 1.0);
    // ... and so does the rest density (SPH packs the crowd closer at 6 than at 4).
    BOOST_TEST(std::stod(summary.rows[2].at("peak_density_mean")) > std::stod(summary.rows[0].at("peak_density_mean")));
    // One figure per varied parameter; no run folders without --keep-runs.
    BOOST_TEST(fs::exists(gridDir() / "sweep-0.SPH.restDensityMax.png"));
    BOOST_TEST(fs::exists(gridDir() / "sweep-agents.pref_speed.png"));
    BOOST_TEST(!fs::exists(gridDir() / "runs"));
    BOOST_TEST(!fs::exists(gridDir() / ".sweep" / "work"));
}

BOOST_AUTO_TEST_CASE(jobs_do_not_change_results) {
    const fs::path d = freshDir(caseName());
    auto a = kGrid;
    a.insert(a.end(), {"--jobs", "1"});
    const Result r = run(d, sweepArgs(d / "out", a));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(gridDir() / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(gridDir() / "sweep-summary.csv"));
}

BOOST_AUTO_TEST_CASE(resume_runs_only_the_missing_runs) {
    const fs::path d = freshDir(caseName());
    fs::copy(gridDir(), d / "out", fs::copy_options::recursive);
    const fs::path records = d / "out" / ".sweep" / "runs";
    const std::string kept = readFile(records / "run_000000.txt");
    // As if the sweep had been killed: three records missing, no outputs yet.
    for (const char* gone : {"run_000002.txt", "run_000005.txt", "run_000007.txt"}) fs::remove(records / gone);
    fs::remove(d / "out" / "sweep.csv");
    fs::remove(d / "out" / "sweep-summary.csv");
    auto a = kGrid;
    a.erase(std::find(a.begin(), a.end(), "--quiet"));
    const Result r = run(d, sweepArgs(d / "out", a));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(r.err.find("5 runs of 8 already finished, 3 to run") != std::string::npos, r.err);
    BOOST_TEST(r.out.find("(5 already done, 3 run now") != std::string::npos, r.out);
    BOOST_TEST(readFile(records / "run_000000.txt") == kept);  // not run again (its wall time is the old one)
    BOOST_TEST(fs::exists(records / "run_000005.txt"));
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(gridDir() / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(gridDir() / "sweep-summary.csv"));
    // Everything done: a third call runs nothing and writes the same files.
    const Result again = run(d, sweepArgs(d / "out", kGrid));
    BOOST_REQUIRE_MESSAGE(again.status == 0, again.err);
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(gridDir() / "sweep-summary.csv"));

    // Other arguments on the same folder are refused, naming what differs; nothing changes.
    auto other = kGrid;
    other[5] = "3";  // --replications 3
    const Result refused = run(d, sweepArgs(d / "out", other));
    BOOST_TEST(refused.status == 2);
    BOOST_TEST(refused.err.find("other arguments") != std::string::npos, refused.err);
    BOOST_TEST(refused.err.find("replications 2") != std::string::npos, refused.err);
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(gridDir() / "sweep-summary.csv"));
}

BOOST_AUTO_TEST_CASE(a_failing_run_is_marked_and_the_others_go_on) {
    const fs::path d = freshDir(caseName());
    const Result r = run(d, sweepArgs(d / "out", {"--vary", "agents.pref_speed=1.2,1.4", "--end-time", "2",
                                                  "--debug-fail-run", "1", "--quiet"}));
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("run 1 (seed 11) failed") != std::string::npos, r.err);
    const Csv runs(readFile(d / "out" / "sweep.csv"));
    BOOST_REQUIRE_EQUAL(runs.rows.size(), 2u);
    BOOST_TEST(runs.rows[0].at("status") == "ok");
    BOOST_TEST(runs.rows[1].at("status") == "failed");
    BOOST_TEST(runs.rows[1].at("evacuated").empty());
    const Csv summary(readFile(d / "out" / "sweep-summary.csv"));
    BOOST_TEST(summary.rows[1].at("failed") == "1");
    BOOST_TEST(summary.rows[1].at("evacuated_n") == "0");
    BOOST_TEST(!fs::exists(d / "out" / ".sweep" / "runs" / "run_000001.txt"));  // tried again on resume
}

BOOST_AUTO_TEST_CASE(ranges_and_kept_runs) {
    const fs::path d = freshDir(caseName());
    const Result r = run(d, sweepArgs(d / "out", {"--vary", "agents.max_speed=1.5:2.1:0.3", "--end-time", "1",
                                                  "--keep-runs", "--quiet"}));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const Csv runs(readFile(d / "out" / "sweep.csv"));
    BOOST_REQUIRE_EQUAL(runs.rows.size(), 3u);  // the end of the range is included
    BOOST_TEST(runs.rows[0].at("agents.max_speed") == "1.5");
    BOOST_TEST(runs.rows[1].at("agents.max_speed") == "1.8");
    BOOST_TEST(runs.rows[2].at("agents.max_speed") == "2.1");
    BOOST_TEST(fs::exists(d / "out" / "runs" / "run_000002" / "summary.json"));
    // The value is held for the whole run (a constant ramp, shown in metrics.csv).
    const std::string metrics = readFile(d / "out" / "runs" / "run_000002" / "metrics.csv");
    BOOST_TEST(lines(metrics)[0].find("agents.max_speed") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(bad_targets_and_values_exit_2_naming_the_argument) {
    const fs::path d = freshDir(caseName());
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"0.SPH.restDensityMux=3", "did you mean 'restDensityMax'"},
        {"0.SHP.restDensityMax=3", "unknown component 'SHP'"},
        {"7.SPH.restDensityMax=3", "policy 7 does not exist"},
        {"0.ORCA.timeHorizon=3", "policy 0 has no component 'ORCA'"},
        {"0.CrowdHealth.panic=0.5", "<CrowdHealth> layer"},
        {"agents.speed=1", "agents has no parameter 'speed'"},
        {"agents.pref_speed=-1", "out of range"},
        {"0.SPH.walls=1", "not a real number"},
        {"SPH.restDensityMax=3", "POLICY.COMPONENT.PARAMETER"},
        {"agents.pref_speed", "TARGET=VALUES"},
        {"agents.pref_speed=", "no values"},
        {"agents.pref_speed=1,,2", "empty value"},
        {"agents.pref_speed=1,abc", "'abc' is not a number"},
        {"agents.pref_speed=1:2:0", "step"},
        {"agents.pref_speed=1:2:-0.5", "step"},
        {"agents.pref_speed=2:1:0.5", "before it starts"},
        {"agents.pref_speed=1:2", "FROM:TO:STEP"},
        {"agents.pref_speed=1,1", "repeated"},
    };
    for (const auto& [vary, expected] : cases) {
        const Result r = run(d, sweepArgs(d / "out", {"--vary", vary}));
        BOOST_TEST(r.status == 2, vary);
        BOOST_TEST(r.err.find("error: --vary '" + vary + "'") != std::string::npos, vary << ": " << r.err);
        BOOST_TEST(r.err.find(expected) != std::string::npos, vary << ": " << r.err);
        BOOST_TEST(!fs::exists(d / "out"), vary << ": nothing is written");
    }
    const Result twice = run(d, sweepArgs(d / "out", {"--vary", "agents.pref_speed=1", "--vary", "agents.pref_speed=2"}));
    BOOST_TEST(twice.status == 2);
    BOOST_TEST(twice.err.find("varied twice") != std::string::npos, twice.err);
    const Result none = run(d, {"sweep", "-i", scenario(), "-o", (d / "out").string()});
    BOOST_TEST(none.status == 2);
    BOOST_TEST(none.err.find("--vary") != std::string::npos, none.err);
}

BOOST_AUTO_TEST_CASE(help_text) {
    const fs::path d = freshDir(caseName());
    const Result r = run(d, {"sweep", "--help"});
    BOOST_TEST(r.status == 0);
    for (const char* word : {"--vary", "--replications", "--seed", "--jobs", "--keep-runs", "--quiet", "sweep.csv",
                             "sweep-summary.csv", "Resume", "MPI"})
        BOOST_TEST(r.out.find(word) != std::string::npos, word);
    const Result top = run(d, {"--help"});
    BOOST_TEST(top.out.find("crowdhealth sweep") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(killed_and_interrupted_sweeps_resume_to_the_same_files) {
    const fs::path d = freshDir(caseName());
    const std::vector<std::string> args = {"--vary", "agents.pref_speed=1:1.9:0.1", "--replications", "3", "--jobs", "1",
                                           "--quiet"};
    const Result whole = run(d, sweepArgs(d / "whole", args));
    BOOST_REQUIRE_MESSAGE(whole.status == 0, whole.err);
    const fs::path records = d / "out" / ".sweep" / "runs";
    auto recorded = [&] {
        std::size_t n = 0;
        if (fs::exists(records))
            for (const auto& e : fs::directory_iterator(records)) n += e.path().extension() == ".txt";
        return n;
    };
    {  // killed (SIGKILL) after a few runs
        Background b(d, sweepArgs(d / "out", args));
        BOOST_REQUIRE(waitFor([&] { return recorded() >= 3; }, 60));
        b.signal(SIGKILL);
        BOOST_TEST(b.wait() == 1000 + SIGKILL);
    }
    const std::size_t afterKill = recorded();
    BOOST_TEST_REQUIRE(afterKill < 30u);
    BOOST_TEST(!fs::exists(d / "out" / "sweep.csv"));
    {  // resumed, then interrupted (Ctrl-C)
        Background b(d, sweepArgs(d / "out", args));
        BOOST_REQUIRE(waitFor([&] { return recorded() >= afterKill + 2 || !b.running(); }, 60));
        b.signal(SIGINT);
        const int status = b.wait();
        if (status == 130) {
            BOOST_TEST(b.err().find("run the same command again") != std::string::npos, b.err());
            BOOST_TEST(!fs::exists(d / "out" / "sweep.csv"));
        } else {
            BOOST_TEST(status == 0);  // it finished before the signal arrived
        }
    }
    const Result resumed = run(d, sweepArgs(d / "out", args));
    BOOST_REQUIRE_MESSAGE(resumed.status == 0, resumed.err);
    BOOST_TEST(recorded() == 30u);
    BOOST_TEST(withoutWallTime(readFile(d / "out" / "sweep.csv")) == withoutWallTime(readFile(d / "whole" / "sweep.csv")));
    BOOST_TEST(readFile(d / "out" / "sweep-summary.csv") == readFile(d / "whole" / "sweep-summary.csv"));
    BOOST_TEST(tmpFiles(d / "out").empty());
}
