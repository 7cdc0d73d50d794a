// Same seed ⇒ byte-identical outputs whatever the thread count (DESIGN §2 step contract), checked
// end to end through the program on UMANS examples where many agents interact.
#define BOOST_TEST_MODULE cli_determinism
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

using namespace clitest;

namespace {

/// Runs `scenario` to t = 20 s with 1 and with 2 threads and compares every output byte for byte
/// (summary.json aside, which holds the thread count and the wall time).
void checkSameWithOneAndTwoThreads(const std::string& scenario) {
    const fs::path dir = freshDir(caseName());
    for (const char* t : {"1", "2"}) {
        const Result r = run(dir, {"-i", scenario, "-o", std::string("t") + t, "-t", t, "--end-time", "20",
                                   "--trajectories", "both,bin", "--seed", "7", "-q"});
        BOOST_REQUIRE_MESSAGE(r.status == 0, "-t " << t << ": " << r.err);
    }
    const std::string m1 = readFile(dir / "t1" / "metrics.csv"), m2 = readFile(dir / "t2" / "metrics.csv");
    BOOST_TEST(lines(m1).size() == 22u);  // header + t = 0 … 20
    BOOST_TEST((m1 == m2), "metrics.csv differs between -t 1 and -t 2");

    // The comparison means something only if agents actually pushed each other: some row must
    // show a contact acceleration (column 9, max_contact_accel) and a crowd pressure above 0.
    bool contact = false, pressure = false;
    const auto rows = lines(m1);
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto c = split(rows[i], ',');
        contact = contact || std::stod(c[9]) > 0;
        pressure = pressure || std::stod(c[13]) > 0;
    }
    BOOST_TEST(contact);
    BOOST_TEST(pressure);

    for (const auto& e : fs::directory_iterator(dir / "t1")) {
        const std::string name = e.path().filename().string();
        if (name == "summary.json") continue;
        BOOST_TEST((readFile(e.path()) == readFile(dir / "t2" / name)), name << " differs between -t 1 and -t 2");
    }
    BOOST_TEST(tmpFiles(dir).empty());
}

}  // namespace

BOOST_AUTO_TEST_CASE(circle_of_50_social_forces_same_bytes_with_1_and_2_threads) {
    checkSameWithOneAndTwoThreads(umansExample("Circle50-SocialForces.xml"));
}

BOOST_AUTO_TEST_CASE(two_crossing_groups_social_forces_same_bytes_with_1_and_2_threads) {
    checkSameWithOneAndTwoThreads(umansExample("25to25-90Degrees-SocialForces.xml"));
}
