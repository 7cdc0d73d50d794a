// `crowdhealth calibrate`: fits --fit parameters so that the ensemble mean of what a scenario
// template's runs measure matches a data file (docs/sweeps.md, Calibration).
// Tests/data/cli/calibrate-door.xml: 12 agents leave a 4 x 4 m room through a door of width
// ${width}. The synthetic data are the mean evacuation times of that scenario at widths 1.8 and
// 2 m with agents.pref_speed = 1.2 m/s and the seeds 3 and 4, made by `crowdhealth sweep` on the
// filled-in files: calibrate, with the same seeds, must find 1.2 again.
#define BOOST_TEST_MODULE cli_calibrate
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <map>
#include <set>

using namespace clitest;

namespace {

std::string templ() { return testData("calibrate-door.xml"); }

/// The template with its placeholders filled for `width` (as calibrate fills them).
std::string filled(const std::string& width, const std::string& lower, const std::string& upper) {
    std::string t = readFile(templ());
    auto replace = [&](const std::string& from, const std::string& to) {
        for (std::size_t at = t.find(from); at != std::string::npos; at = t.find(from, at + to.size())) t.replace(at, from.size(), to);
    };
    replace("${2.5 - width/2}", lower);
    replace("${2 + width/2}", upper);
    replace("${width}", width);
    return t;
}

/// The mean evacuation time over the seeds 3 and 4 at pref_speed 1.2, by `crowdhealth sweep`.
std::string modelMean(const fs::path& dir, const std::string& name, const std::string& text) {
    const fs::path scenario = dir / (name + ".xml");
    writeText(scenario, text);
    const Result r = run(dir, {"sweep", "-i", scenario.string(), "-o", (dir / name).string(), "--vary",
                               "agents.pref_speed=1.2", "--replications", "2", "--seed", "3", "--quiet"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const auto rows = lines(readFile(dir / name / "sweep-summary.csv"));
    BOOST_REQUIRE_EQUAL(rows.size(), 2u);
    const auto header = split(rows[0], ','), cells = split(rows[1], ',');
    for (std::size_t k = 0; k < header.size(); ++k)
        if (header[k] == "evacuation_time_mean") return cells[k];
    BOOST_FAIL("no evacuation_time_mean in sweep-summary.csv");
    return "";
}

/// The synthetic data file (made once per process).
const fs::path& syntheticData() {
    static const fs::path file = [] {
        const fs::path d = freshDir("synthetic");
        const std::string narrow = modelMean(d, "w18", filled("1.8", "1.6", "2.9"));
        const std::string wide = modelMean(d, "w20", filled("2", "1.5", "3"));
        const fs::path f = d / "door.csv";
        writeText(f, "# made by the model: pref_speed 1.2, seeds 3 and 4\nwidth,evacuation_time\n1.8," + narrow +
                         "\n2," + wide + "\n");
        return f;
    }();
    return file;
}

std::vector<std::string> calibrateArgs(const fs::path& out, const std::vector<std::string>& more = {}) {
    std::vector<std::string> a = {"calibrate", "-i", templ(), "--data", syntheticData().string(), "--fit",
                                  "agents.pref_speed=0.7:1.6", "--seeds", "2", "--seed", "3", "--tolerance", "0.002",
                                  "-o", out.string(), "--quiet"};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

/// The calibration with --jobs 2, run once per process (the other cases compare with it).
const fs::path& fitDir() {
    static const fs::path dir = [] {
        const fs::path d = freshDir("fit");
        const Result r = run(d, calibrateArgs(d / "out", {"--jobs", "2"}));
        BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
        return d / "out";
    }();
    return dir;
}

}  // namespace

BOOST_AUTO_TEST_CASE(recovers_the_preferred_speed_the_data_were_made_with) {
    const nlohmann::json j = nlohmann::json::parse(readFile(fitDir() / "calibration-result.json"));
    BOOST_REQUIRE_EQUAL(j["parameters"].size(), 1u);
    const nlohmann::json& p = j["parameters"][0];
    BOOST_TEST(p["target"].get<std::string>() == "agents.pref_speed");
    const double v = p["value"].get<double>();
    // The data are the model's own means at 1.2 with the same seeds (common random numbers), so the
    // objective is 0 there. Elsewhere it is not smooth: the evacuation time (the last of 12 out)
    // moves by steps of delta_time = 0.05 s and, from one speed to the next, by the chaotic
    // rearrangement of who leaves last, so it has shallow local minima. The seed error the program
    // reports (the spread of the 2 seeds carried through the fit) is about 0.02 m/s here; the search
    // must land within it, and within 0.02 m/s of 1.2 (a slope of about -8 s per m/s: 0.16 s of
    // evacuation time, three time steps).
    const double seedError = p["seed_error"].get<double>();
    BOOST_TEST(seedError > 0.005);
    BOOST_TEST(seedError < 0.05);
    BOOST_TEST(std::abs(v - 1.2) < 0.02, "fitted pref_speed " << v);
    BOOST_TEST(std::abs(v - 1.2) < seedError, "fitted pref_speed " << v << ", seed error " << seedError);
    BOOST_TEST(j["objective"].get<double>() < 1e-3);
    BOOST_TEST(j["converged"].get<bool>());
    BOOST_TEST(j["observable"].get<std::string>() == "evacuation_time");
    BOOST_REQUIRE_EQUAL(j["points"].size(), 2u);
    BOOST_TEST(j["points"][0]["width"].get<double>() == 1.8);
    BOOST_TEST(j["points"][0]["runs"].get<int>() == 2);
    // The search's path: a header, then one row per evaluation, the last two the error estimate's.
    const auto rows = lines(readFile(fitDir() / "calibration.csv"));
    BOOST_REQUIRE_GE(rows.size(), 5u);
    BOOST_TEST(rows[0] == "evaluation,step,agents.pref_speed,objective,status");
    BOOST_TEST(rows[1].rfind("0,start,1.15,", 0) == 0, rows[1]);  // the box's centre first
    BOOST_TEST(rows.back().find(",jacobian,") != std::string::npos);
    for (std::size_t k = 1; k < rows.size(); ++k) {
        const auto c = split(rows[k], ',');
        BOOST_REQUIRE_EQUAL(c.size(), 5u);
        const double x = std::stod(c[2]);
        BOOST_TEST((x >= 0.7 && x <= 1.6), "evaluation outside the box: " << rows[k]);
    }
    BOOST_TEST(fs::exists(fitDir() / "calibration.png"));
}

BOOST_AUTO_TEST_CASE(same_result_with_one_job_and_with_two) {
    const fs::path d = freshDir(caseName());
    const Result r = run(d, calibrateArgs(d / "out", {"--jobs", "1"}));
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(readFile(d / "out" / "calibration.csv") == readFile(fitDir() / "calibration.csv"));
    BOOST_TEST(readFile(d / "out" / "calibration-result.json") == readFile(fitDir() / "calibration-result.json"));
}

BOOST_AUTO_TEST_CASE(killed_and_interrupted_calibrations_resume_to_the_same_files) {
    // Each run that gives a value is recorded in OUTDIR/.calibrate/runs.txt as it arrives; the same
    // command again takes those from the record and runs the others, and must write what a
    // calibration made in one go writes (fitDir()), having made each run once.
    const fs::path d = freshDir(caseName());
    const fs::path out = d / "out", runs = out / ".calibrate" / "runs.txt";
    const std::vector<std::string> args = calibrateArgs(out, {"--jobs", "1"});
    auto recorded = [&] { return fs::exists(runs) ? lines(readFile(runs)).size() : 0u; };
    {  // killed (SIGKILL) after a few runs
        Background b(d, args);
        BOOST_REQUIRE(waitFor([&] { return recorded() >= 6; }, 120));
        b.signal(SIGKILL);
        BOOST_TEST(b.wait() == 1000 + SIGKILL);
    }
    BOOST_TEST(!fs::exists(out / "calibration.csv"));
    // A record cut short, as a kill while writing leaves it: dropped, and the file cut back.
    {
        std::ofstream cut(runs, std::ios::binary | std::ios::app);
        cut << "1 4 1.0";
    }
    const std::size_t afterKill = recorded();
    {  // resumed, then interrupted (Ctrl-C)
        Background b(d, args);
        BOOST_REQUIRE(waitFor([&] { return recorded() >= afterKill + 4 || !b.running(); }, 120));
        b.signal(SIGINT);
        const int status = b.wait();
        if (status == 130) {
            BOOST_TEST(b.err().find("run the same command again to resume") != std::string::npos, b.err());
            BOOST_TEST(!fs::exists(out / "calibration.csv"));
        } else {
            BOOST_TEST(status == 0);  // it finished before the signal arrived
        }
    }
    std::vector<std::string> loud = args;
    loud.erase(std::find(loud.begin(), loud.end(), "--quiet"));
    const Result resumed = run(d, loud);
    BOOST_REQUIRE_MESSAGE(resumed.status == 0, resumed.err);
    BOOST_TEST(resumed.err.find("calibrate: resuming: ") != std::string::npos, resumed.err);
    BOOST_TEST(readFile(out / "calibration.csv") == readFile(fitDir() / "calibration.csv"));
    BOOST_TEST(readFile(out / "calibration-result.json") == readFile(fitDir() / "calibration-result.json"));
    // Every run (2 conditions x 2 seeds) of every point evaluated (the search comes back to some:
    // their runs are made once) recorded once, each a whole record; every evaluation ran here.
    std::set<std::string> points;
    for (const std::string& row : lines(readFile(out / "calibration.csv"))) {
        const auto c = split(row, ',');
        BOOST_REQUIRE_EQUAL(c.size(), 5u);
        if (c[0] != "evaluation") points.insert(c[2]);
        if (c[0] != "evaluation") BOOST_TEST(c[4] == "ok", row);
    }
    const auto records = lines(readFile(runs));
    BOOST_TEST(records.size() == 4 * points.size());
    std::set<std::string> jobs;
    for (const std::string& r : records) {
        const auto fields = split(r, '\t');
        BOOST_REQUIRE_EQUAL(fields.size(), 2u);
        BOOST_TEST(split(fields[0], ' ').size() == 3u, r);  // condition, seed, pref_speed
        BOOST_TEST(fields[1].rfind("ok ", 0) == 0, r);
        jobs.insert(fields[0]);
    }
    BOOST_TEST(jobs.size() == records.size());
    // Called again: nothing to run, the same files.
    const Result again = run(d, args);
    BOOST_REQUIRE_MESSAGE(again.status == 0, again.err);
    BOOST_TEST(lines(readFile(runs)).size() == records.size());
    BOOST_TEST(readFile(out / "calibration-result.json") == readFile(fitDir() / "calibration-result.json"));
    // Other arguments on the same OUTDIR are refused, and change nothing.
    std::vector<std::string> three = args;
    *(std::find(three.begin(), three.end(), "--seeds") + 1) = "3";
    const Result other = run(d, three);
    BOOST_TEST(other.status == 2);
    BOOST_TEST(other.err.find("there: 'seeds 2', now: 'seeds 3'") != std::string::npos, other.err);
    BOOST_TEST(lines(readFile(runs)).size() == records.size());
}

BOOST_AUTO_TEST_CASE(an_edited_policies_file_is_not_resumed) {
    // The template with its policies in a file of their own (<Policies file>): the file's content
    // is part of OUTDIR/.calibrate/arguments, so an edit between two calls is refused (exit 2,
    // naming it) and the file as it was resumes.
    const fs::path d = freshDir(caseName());
    std::string t = readFile(templ());
    const auto from = t.find("\t<Policies>"), to = t.find("</Policies>\n") + 12;
    const std::string policies = t.substr(from, to - from);
    t.replace(from, to - from, "\t<Policies file=\"door-policies.xml\"/>\n");
    writeText(d / "door.xml", t);
    writeText(d / "door-policies.xml", policies);
    std::vector<std::string> args = calibrateArgs(d / "out", {"--max-evaluations", "3"});
    *(std::find(args.begin(), args.end(), "-i") + 1) = (d / "door.xml").string();
    const Result first = run(d, args);
    BOOST_REQUIRE_MESSAGE(first.status == 0, first.err);
    const std::string result = readFile(d / "out" / "calibration-result.json");
    BOOST_TEST(readFile(d / "out" / ".calibrate" / "arguments").find("included " + fs::canonical(d / "door-policies.xml").string() + " (content ") !=
               std::string::npos);
    writeText(d / "door-policies.xml", "<!-- edited -->\n" + policies);
    const Result edited = run(d, args);
    BOOST_TEST(edited.status == 2);
    BOOST_TEST(edited.err.find("there: 'included " + fs::canonical(d / "door-policies.xml").string() + " (content ") != std::string::npos, edited.err);
    BOOST_TEST(readFile(d / "out" / "calibration-result.json") == result);
    writeText(d / "door-policies.xml", policies);
    const Result again = run(d, args);
    BOOST_TEST(again.status == 0, again.err);
    BOOST_TEST(readFile(d / "out" / "calibration-result.json") == result);
}

BOOST_AUTO_TEST_CASE(a_bound_is_reached_and_respected) {
    // The data want 1.2; a box that stops at 1.0 gives 1.0 (at_bound), never a value above it.
    const fs::path d = freshDir(caseName());
    std::vector<std::string> a = calibrateArgs(d / "out");
    for (std::string& w : a)
        if (w == "agents.pref_speed=0.7:1.6") w = "agents.pref_speed=0.6:1.0";
    const Result r = run(d, a);
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const nlohmann::json j = nlohmann::json::parse(readFile(d / "out" / "calibration-result.json"));
    const double v = j["parameters"][0]["value"].get<double>();
    BOOST_TEST(v <= 1.0);
    BOOST_TEST(v > 0.99);
    BOOST_TEST(j["parameters"][0]["at_bound"].get<bool>());
}

BOOST_AUTO_TEST_CASE(bad_arguments_exit_2_and_write_nothing) {
    const fs::path d = freshDir(caseName());
    writeText(d / "unknown-observable.csv", "width,throughput\n0.8,1\n");
    writeText(d / "bad-number.csv", "# a comment\nwidth,flow\n0.8,1.1\n1.2,fast\n");
    writeText(d / "no-placeholder.csv", "width,depth,flow\n0.8,3,1\n");
    writeText(d / "other-name.csv", "gap,flow\n0.8,1\n");
    writeText(d / "no-rows.csv", "width,flow\n");
    const std::string data = syntheticData().string();
    struct Case {
        std::vector<std::string> args;
        std::string message;
    };
    const std::vector<Case> cases = {
        {{"--fit", "agents.pref_speed=1.6:0.8", "--data", data}, "--fit 'agents.pref_speed=1.6:0.8': LO (1.6) must be below HI (0.8)"},
        {{"--fit", "agents.pref_speed=0.8", "--data", data}, "the range is LO:HI (two numbers)"},
        {{"--fit", "agents.pref_speed=a:1", "--data", data}, "LO 'a' is not a number"},
        {{"--fit", "agents.speed=0.8:1.6", "--data", data}, "--fit 'agents.speed=0.8:1.6'"},
        {{"--fit", "0.SocialForcesAvoidance.nonsense=1:2", "--data", data}, "--fit '0.SocialForcesAvoidance.nonsense=1:2'"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--fit", "agents.pref_speed=1:2", "--data", data}, "is fitted twice"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", data, "--seeds", "0"}, "--seeds must be a whole number"},
        {{"--fit", "agents.pref_speed=0.8:1.6"}, "no data given: use --data FILE"},
        {{"--data", data}, "nothing to fit"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "missing.csv").string()}, "missing.csv:0: error: cannot read the data file"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "unknown-observable.csv").string()},
         "unknown-observable.csv:1: error: no observable in the header 'width,throughput'"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "bad-number.csv").string()},
         "bad-number.csv:4: error: flow: 'fast' is not a number"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "no-placeholder.csv").string()},
         "error: the data's variable 'depth'"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "other-name.csv").string()},
         "calibrate-door.xml:3: error: placeholder ${width}: 'width' is not a column of the data file (its variables: gap)"},
        {{"--fit", "agents.pref_speed=0.8:1.6", "--data", (d / "no-rows.csv").string()}, "no-rows.csv:1: error: no data rows"},
    };
    for (const Case& c : cases) {
        std::vector<std::string> a = {"calibrate", "-i", templ(), "-o", (d / "out").string()};
        a.insert(a.end(), c.args.begin(), c.args.end());
        const Result r = run(d, a);
        BOOST_TEST(r.status == 2, c.message << ": exit " << r.status);
        BOOST_TEST(r.err.find(c.message) != std::string::npos, "expected '" << c.message << "' in: " << r.err);
        BOOST_TEST(!fs::exists(d / "out"), c.message << ": OUTDIR was created");
    }
}

BOOST_AUTO_TEST_CASE(help_lists_the_command) {
    const fs::path d = freshDir(caseName());
    const Result top = run(d, {"--help"});
    BOOST_TEST(top.out.find("crowdhealth calibrate -i SCENARIO --fit TARGET=LO:HI") != std::string::npos);
    const Result own = run(d, {"calibrate", "--help"});
    BOOST_TEST(own.status == 0);
    BOOST_TEST(own.out.find("--data") != std::string::npos);
    BOOST_TEST(own.out.find("Resume") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(the_shipped_templates_run_with_their_data) {
    // Examples/validation's templates are not scenarios on their own (examples_run_test skips
    // them): one evaluation each, with the data they are shipped for, must fill, load and run.
    const fs::path d = freshDir(caseName());
    const fs::path v = fs::path(CH_SOURCE_DIR) / "Examples" / "validation";
    const std::vector<std::vector<std::string>> cases = {
        {"-i", (v / "kretz-bottleneck-sph.xml").string(), "--data", (v / "kretz2006-flow-width.csv").string(),
         "--fit", "0.SPH.restDensityMax=1.5:6", "-o", (d / "kretz").string()},
        {"-i", (v / "weidmann-corridor.xml").string(), "--data", (v / "weidmann1993-speed-density.csv").string(),
         "--measure-from", "10", "--fit", "0.SocialForcesAvoidance.V0=0.5:6", "-o", (d / "weidmann").string()},
    };
    for (const auto& c : cases) {
        std::vector<std::string> a = {"calibrate", "--seeds", "1", "--max-evaluations", "1", "--quiet"};
        a.insert(a.end(), c.begin(), c.end());
        const Result r = run(d, a);
        BOOST_TEST(r.status == 0, c[1] << ": " << r.err);
        const std::string result = readFile(fs::path(c.back()) / "calibration-result.json");
        BOOST_TEST(result.find("\"objective\"") != std::string::npos, c[1]);
    }
}
