// `crowdhealth verify` (Engine/verify.cpp, docs/verification.md): the quick run passes and its
// report.md and verify.csv hold a row for every test and a cell for every model; a claimed test
// that fails makes the exit status 1; bad names are usage errors (2). Label `verify`.
#define BOOST_TEST_MODULE cli_verify
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

using namespace clitest;

namespace {

const fs::path kTests = fs::path(CH_SOURCE_DIR) / "Examples" / "verification";

/// The test ids and models of `crowdhealth verify --list`.
std::pair<std::vector<std::string>, std::vector<std::string>> listed(const fs::path& dir) {
    const Result r = run(dir, {"verify", "--list"});
    BOOST_TEST_REQUIRE(r.status == 0, r.err);
    std::vector<std::string> ids, models;
    std::istringstream in(r.out);
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("models:", 0) == 0) {
            std::istringstream m(line.substr(7));
            for (std::string w; m >> w;) models.push_back(w);
        } else if (!line.empty()) {
            ids.push_back(line.substr(0, line.find(' ')));
        }
    }
    return {ids, models};
}

}  // namespace

BOOST_AUTO_TEST_CASE(quick_run_passes_and_reports_every_test) {
    const fs::path dir = freshDir(caseName());
    const auto [ids, models] = listed(dir);
    BOOST_TEST(ids.size() >= 20u);
    BOOST_TEST(models.size() >= 3u);
    std::vector<std::string> args = {"verify", "--quick", "-o", "out", "--tests-dir", kTests.string(), "--jobs", "2"};
    // Under the sanitizers (CROWDHEALTH_SHORT, scripts/test.sh --sanitize) every run is 10-20 times
    // slower: the quick run there covers the first tests only; the Release suite runs them all.
    if (std::getenv("CROWDHEALTH_SHORT")) args.insert(args.end(), {"--test", "rimea-1", "rimea-2", "rimea-4", "rimea-6", "iso-max-flow", "iso-groups"});
    const Result r = run(dir, args);
    BOOST_TEST(r.status == 0, r.out << r.err);
    const std::string md = readFile(dir / "out" / "report.md");
    const std::string csv = readFile(dir / "out" / "verify.csv");
    BOOST_TEST(md.find("every claimed test passes") != std::string::npos);
    BOOST_TEST(csv.rfind("test,model,status,claimed,", 0) == 0u);
    for (const std::string& id : ids) {
        if (std::getenv("CROWDHEALTH_SHORT") && md.find("\n| " + id + " |") == std::string::npos) continue;
        // One matrix row per test in report.md, with one cell per model.
        const auto at = md.find("\n| " + id + " |");
        BOOST_TEST_REQUIRE(at != std::string::npos, id << " has no row in report.md");
        const std::string row = md.substr(at + 1, md.find('\n', at + 1) - at - 1);
        BOOST_TEST(static_cast<std::size_t>(std::count(row.begin(), row.end(), '|')) == models.size() + 2, row);
        BOOST_TEST(row.find("|  |") == std::string::npos, "an empty cell: " << row);
        if (id == "rimea-2") BOOST_TEST(row.find("out of scope") != std::string::npos, row);
        if (id == "rimea-4") BOOST_TEST(row.find("| documented ") != std::string::npos, row);
        if (id == "rimea-1") BOOST_TEST(row.find("pass 29.9") != std::string::npos, row);
        for (const std::string& m : models)
            BOOST_TEST(csv.find("\n" + id + "," + m + ",") != std::string::npos, id << " x " << m << " not in verify.csv");
    }
    // The quick run's cells: each runnable test ran for one model; stairs are out of scope.
    BOOST_TEST(csv.find("\nrimea-1,SocialForces,pass,yes,1,1,") != std::string::npos, csv);
    BOOST_TEST(csv.find("\nrimea-2,ORCA,out of scope,") != std::string::npos);
    BOOST_TEST(csv.find(",pending,") == std::string::npos, "every test is built");
    BOOST_TEST(csv.find(",not run,") != std::string::npos);
    BOOST_TEST(csv.find(",fail,") == std::string::npos);
    // The figure of a test that ran (iso-max-flow: evacuation curves), linked from the report.
    const std::string png = readFile(dir / "out" / "figures" / "iso-max-flow.png");
    BOOST_TEST(png.rfind("\x89PNG", 0) == 0u, "figures/iso-max-flow.png is not a PNG");
    BOOST_TEST(md.find("![iso-max-flow](figures/iso-max-flow.png)") != std::string::npos);
    BOOST_TEST(!fs::exists(dir / "out" / "figures" / "rimea-2.png"), "no figure for a test that did not run");
}

BOOST_AUTO_TEST_CASE(no_figures_writes_none) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"verify", "--quick", "--test", "iso-max-flow", "--no-figures", "-o", "out", "--tests-dir", kTests.string()});
    BOOST_TEST(r.status == 0, r.out << r.err);
    BOOST_TEST(!fs::exists(dir / "out" / "figures"));
    BOOST_TEST(readFile(dir / "out" / "report.md").find("figures/") == std::string::npos);
}

BOOST_AUTO_TEST_CASE(a_claimed_test_that_fails_exits_1) {
    // A copy of the tests whose corridor is 60 m long: the arrival (about 45 s) is outside 26-34 s.
    const fs::path dir = freshDir(caseName());
    fs::create_directories(dir / "Examples");
    fs::copy(kTests, dir / "Examples" / "verification", fs::copy_options::recursive);
    fs::copy(kTests.parent_path() / "policies", dir / "Examples" / "policies", fs::copy_options::recursive);
    fs::copy(kTests.parent_path() / "venues", dir / "Examples" / "venues", fs::copy_options::recursive);
    const fs::path file = dir / "Examples" / "verification" / "rimea-01-corridor.xml";
    std::string xml = readFile(file);
    for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
             {"x=\"40\"", "x=\"60\""}, {"xmin=\"40\" xmax=\"41\"", "xmin=\"60\" xmax=\"61\""}, {"xmax=\"42\"", "xmax=\"62\""}}) {
        for (auto at = xml.find(from); at != std::string::npos; at = xml.find(from, at + to.size())) xml.replace(at, from.size(), to);
    }
    std::ofstream(file) << xml;
    const Result r = run(dir, {"verify", "--test", "rimea-1", "--policy", "ORCA", "-o", "out"});
    BOOST_TEST(r.status == 1, r.out << r.err);
    BOOST_TEST(r.out.find("fail: rimea-1 with ORCA") != std::string::npos, r.out);
    const std::string csv = readFile(dir / "out" / "verify.csv");
    BOOST_TEST(csv.find("\nrimea-1,ORCA,fail,yes,3,0,") != std::string::npos, csv);
}

BOOST_AUTO_TEST_CASE(unknown_names_are_usage_errors) {
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"verify", "--policy", "Nope", "-o", "out"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("unknown model 'Nope'") != std::string::npos, r.err);
    r = run(dir, {"verify", "--test", "rimea-99", "-o", "out"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("unknown test 'rimea-99'") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"), "nothing is written on a usage error");
}

BOOST_AUTO_TEST_CASE(each_model_runs_its_own_policy_and_jobs_change_nothing) {
    // The maximum flow tells ORCA (about 0.5 P/(m s)) from RVO (about 2.7): the model's policy
    // replaced the test's. The same runs on 1 and on 2 threads give the same verify.csv.
    const fs::path dir = freshDir(caseName());
    // Under the sanitizers (CROWDHEALTH_SHORT) one seed: still two jobs (one per model) to order.
    const std::string seeds = std::getenv("CROWDHEALTH_SHORT") ? "1" : "2";
    const std::vector<std::string> args = {"verify", "--test", "iso-max-flow", "rimea-7", "--policy", "ORCA", "RVO",
                                           "--seeds", seeds, "--tests-dir", kTests.string()};
    auto with = [&](std::vector<std::string> a, const std::string& out, const std::string& jobs) {
        a.insert(a.end(), {"-o", out, "--jobs", jobs});
        return a;
    };
    const Result one = run(dir, with(args, "one", "1"));
    const Result two = run(dir, with(args, "two", "2"));
    // iso-max-flow is claimed for ORCA only: RVO's flow is documented, and the exit status is 0.
    BOOST_TEST(one.status == 0, one.out << one.err);
    BOOST_TEST(two.status == 0, two.out << two.err);
    const std::string csv = readFile(dir / "one" / "verify.csv");
    BOOST_TEST(csv == readFile(dir / "two" / "verify.csv"));
    auto meanOf = [&](const std::string& prefix) {
        const auto at = csv.find("\n" + prefix);
        BOOST_TEST_REQUIRE(at != std::string::npos, prefix << " not in\n" << csv);
        std::istringstream row(csv.substr(at + 1, csv.find('\n', at + 1) - at - 1));
        std::string field;
        for (int k = 0; k <= 6; ++k) std::getline(row, field, ',');
        return std::stod(field);  // value_mean
    };
    BOOST_TEST(meanOf("iso-max-flow,ORCA,pass,") < 1.0);
    BOOST_TEST(meanOf("iso-max-flow,RVO,documented,") > 2.0);
}

BOOST_AUTO_TEST_CASE(a_validation_asked_alone_runs_the_test_it_reads) {
    // val-weidmann reads RiMEA 4's corridor runs (TestDef::runsOf): asked for alone, those run, and
    // only its row is reported.
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"verify", "--quick", "--test", "val-weidmann", "--no-figures", "-o", "out", "--tests-dir", kTests.string()});
    BOOST_TEST(r.status == 0, r.out << r.err);
    const std::string csv = readFile(dir / "out" / "verify.csv");
    BOOST_TEST(csv.find("\nval-weidmann,SocialForces,validation,no,1,") != std::string::npos, csv);
    BOOST_TEST(csv.find("\nrimea-4,") == std::string::npos, csv);
}

BOOST_AUTO_TEST_CASE(a_model_fine_step_that_does_not_divide_the_test_step_is_an_input_error) {
    // SPH's model file brings delta_time_fine 0.02 s, which verify gives to every test it runs in;
    // a test stepping 0.03 s cannot take it: exit 2 naming the file, nothing written.
    const fs::path dir = freshDir(caseName());
    fs::create_directories(dir / "Examples");
    fs::copy(kTests, dir / "Examples" / "verification", fs::copy_options::recursive);
    fs::copy(kTests.parent_path() / "policies", dir / "Examples" / "policies", fs::copy_options::recursive);
    fs::copy(kTests.parent_path() / "doorway", dir / "Examples" / "doorway", fs::copy_options::recursive);
    const fs::path file = dir / "Examples" / "verification" / "rimea-01-corridor.xml";
    std::string xml = readFile(file);
    xml.replace(xml.find("delta_time=\"0.1\""), 16, "delta_time=\"0.03\"");
    std::ofstream(file) << xml;
    const Result r = run(dir, {"verify", "--test", "rimea-1", "--policy", "SPH", "-o", "out"});
    BOOST_TEST(r.status == 2, r.out << r.err);
    BOOST_TEST(r.err.find("rimea-01-corridor.xml: error: delta_time 0.03 s is not a multiple of model SPH's delta_time_fine 0.02 s") !=
                   std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"));
    // The same copy with SPH's own step divides: it runs.
    xml.replace(xml.find("delta_time=\"0.03\""), 17, "delta_time=\"0.1\"");
    std::ofstream(file) << xml;
    BOOST_TEST(run(dir, {"verify", "--test", "rimea-1", "--policy", "SPH", "--seeds", "1", "-o", "out", "-q"}).status == 0);
}
