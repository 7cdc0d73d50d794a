// The pass criteria of the evacuation family of `crowdhealth verify`
// (Engine/verify_criteria_evacuation.h), each just inside and just outside its bounds, and on the
// inputs that must fail (a run in which not everyone left, nobody to check).
// docs/verification/evacuation.md lists the mutations these cases catch.
#define BOOST_TEST_MODULE verify_evacuation
#include <boost/test/unit_test.hpp>

#include "verify_criteria_evacuation.h"

#include <cmath>

using namespace chverify;

BOOST_AUTO_TEST_CASE(rimea8_times_fall_at_every_step) {
    const Check ok = timesDecrease({80.0, 60.0, 40.0});
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 2.0, "value: first over last");
    BOOST_TEST(timesDecrease({80.0, 79.9}).pass);
    BOOST_TEST(!timesDecrease({80.0, 80.0, 40.0}).pass, "equal times do not fall");
    BOOST_TEST(!timesDecrease({80.0, 60.0, 60.1}).pass, "a rise at the last step");
    BOOST_TEST(!timesDecrease({60.0, 80.0, 40.0}).pass, "a rise at the first step");
    const Check stuck = timesDecrease({80.0, std::nullopt, 40.0});
    BOOST_TEST(!stuck.pass);
    BOOST_TEST(std::isnan(stuck.value));
    BOOST_TEST(!timesDecrease({80.0}).pass, "one run says nothing");
    BOOST_TEST(!timesDecrease({}).pass);
}

BOOST_AUTO_TEST_CASE(rimea9_ratio_in_1_6_to_2_4) {
    const Check ok = evacuationTimeRatio(50.0, 100.0);
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 2.0);
    BOOST_TEST(evacuationTimeRatio(50.0, 80.0).pass, "1.6 is inside");
    BOOST_TEST(evacuationTimeRatio(50.0, 120.0).pass, "2.4 is inside");
    BOOST_TEST(!evacuationTimeRatio(50.0, 79.9).pass);
    BOOST_TEST(!evacuationTimeRatio(50.0, 120.1).pass);
    BOOST_TEST(!evacuationTimeRatio(100.0, 50.0).pass, "the ratio is fewer over all exits, not the inverse");
    BOOST_TEST(!evacuationTimeRatio(std::nullopt, 100.0).pass);
    BOOST_TEST(!evacuationTimeRatio(50.0, std::nullopt).pass);
    BOOST_TEST(std::isnan(evacuationTimeRatio(50.0, std::nullopt).value));
}

BOOST_AUTO_TEST_CASE(rimea11_most_nearer_some_farther) {
    const Check ok = nearerExitMajority(76, 74, 150);
    BOOST_TEST(ok.pass);
    BOOST_TEST(std::abs(ok.value - 100.0 * 76 / 150) < 1e-12, "value: share by the nearer exit in %");
    BOOST_TEST(!nearerExitMajority(75, 75, 150).pass, "half is not a majority");
    BOOST_TEST(nearerExitMajority(149, 1, 150).pass, "one by the farther is enough");
    BOOST_TEST(!nearerExitMajority(150, 0, 150).pass, "nobody by the farther exit");
    BOOST_TEST(!nearerExitMajority(100, 49, 150).pass, "one person did not leave");
    BOOST_TEST(!nearerExitMajority(0, 0, 0).pass);
}

BOOST_AUTO_TEST_CASE(rimea15_corner_between_the_straights) {
    const Check mid = cornerBetweenStraights(40.0, 50.0, 60.0);
    BOOST_TEST(mid.pass);
    BOOST_TEST(mid.value == 0.5);
    BOOST_TEST(cornerBetweenStraights(40.0, 40.0, 60.0).pass, "bounds included");
    BOOST_TEST(cornerBetweenStraights(40.0, 60.0, 60.0).pass);
    BOOST_TEST(!cornerBetweenStraights(40.0, 39.9, 60.0).pass, "faster than the short straight");
    BOOST_TEST(!cornerBetweenStraights(40.0, 60.1, 60.0).pass, "slower than the long straight");
    BOOST_TEST(cornerBetweenStraights(60.0, 50.0, 40.0).pass, "whichever straight is quicker");
    BOOST_TEST(!cornerBetweenStraights(40.0, std::nullopt, 60.0).pass);
    BOOST_TEST(!cornerBetweenStraights(std::nullopt, 50.0, 60.0).pass);
    BOOST_TEST(!cornerBetweenStraights(40.0, 50.0, std::nullopt).pass);
}

BOOST_AUTO_TEST_CASE(dynamic_exits_nobody_out_by_the_closed_exit) {
    const double close = 10.0, grace = 0.1;
    std::vector<ExitTime> ok = {{1, std::string("east"), 4.0}, {2, std::string("east"), 10.1}, {3, std::string("west"), 30.0}};
    const Check c = closedExitUnused(ok, "east", close, grace);
    BOOST_TEST(c.pass, "out by east up to the closing time plus the grace");
    BOOST_TEST(c.value == 0.0);
    std::vector<ExitTime> late = ok;
    late[1].time = 10.11;
    const Check l = closedExitUnused(late, "east", close, grace);
    BOOST_TEST(!l.pass, "just after the grace");
    BOOST_TEST(l.value == 1.0);
    std::vector<ExitTime> stuck = ok;
    stuck[2].exit.reset();
    BOOST_TEST(!closedExitUnused(stuck, "east", close, grace).pass, "someone did not leave");
    std::vector<ExitTime> otherLate = {{1, std::string("west"), 50.0}};
    BOOST_TEST(closedExitUnused(otherLate, "east", close, grace).pass, "the open exit any time");
    BOOST_TEST(!closedExitUnused({}, "east", close, grace).pass);
}
