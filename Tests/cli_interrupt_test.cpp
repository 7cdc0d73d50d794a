// Ctrl-C: the run stops after the current coarse step, every output is complete for the time
// simulated, summary.json says "interrupted": true, and the exit status is 130.
// The program's hidden --debug-interrupt-after N raises a real SIGINT in the program itself after
// N coarse steps, so the real handler runs at a known step: no sleeping, no timing.
#define BOOST_TEST_MODULE cli_interrupt
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <cmath>

using namespace clitest;

BOOST_AUTO_TEST_CASE(sigint_after_35_steps_finalises_every_output_for_3_5_seconds) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", umansExample("Circle50-SocialForces.xml"), "-o", "out", "--trajectories",
                               "both", "--debug-interrupt-after", "35", "-t", "2"});
    BOOST_TEST(r.status == 130, r.err);
    BOOST_TEST(r.err.find("interrupted") != std::string::npos, r.err);
    const fs::path out = dir / "out";

    const std::string summary = readFile(out / "summary.json");
    BOOST_TEST(summary.find("\"interrupted\": true") != std::string::npos, summary);
    BOOST_TEST(std::abs(jsonValue(summary, "simulated_time") - 3.5) < 1e-9);
    BOOST_TEST(jsonValue(summary, "coarse_steps") == 35);

    // metrics.csv: rows at 0, 1, 2, 3 and the final 3.5 s.
    const auto metrics = lines(readFile(out / "metrics.csv"));
    BOOST_REQUIRE(metrics.size() == 6u);
    BOOST_TEST(metrics.back().rfind("3.5,50,", 0) == 0u, metrics.back());

    // Trajectories end at the interrupted step too.
    const auto rows = lines(readFile(out / "output_0.csv"));
    BOOST_TEST(rows.size() == 35u);
    BOOST_TEST(rows.back().rfind("3.5,", 0) == 0u, rows.back());
    const auto text = lines(readFile(out / "trajectories.txt"));
    BOOST_TEST(text.back().find(" 35 ") != std::string::npos, text.back());

    BOOST_TEST(fs::exists(out / "evacuations.csv"));
    BOOST_TEST(tmpFiles(dir).empty());
}

BOOST_AUTO_TEST_CASE(a_run_that_is_not_interrupted_exits_0_and_says_so) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", umansExample("Circle50-SocialForces.xml"), "-o", "out", "--end-time", "1", "-q"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(readFile(dir / "out" / "summary.json").find("\"interrupted\": false") != std::string::npos);
}
