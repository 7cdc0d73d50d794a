// The pass criteria of `crowdhealth verify` (Engine/verify_criteria.h), each on values just inside
// and just outside its bounds, and on the inputs that must fail (nothing measured, nobody to check).
// docs/verification.md lists the mutations of verify_criteria.cpp these cases catch.
#define BOOST_TEST_MODULE verify_criteria
#include <boost/test/unit_test.hpp>

#include "verify_criteria.h"

#include <cmath>

using namespace chverify;

BOOST_AUTO_TEST_CASE(rimea1_arrival_time_in_26_to_34_s) {
    BOOST_TEST(arrivalTime(30.1).pass);
    BOOST_TEST(arrivalTime(26.0).pass);
    BOOST_TEST(arrivalTime(34.0).pass);
    BOOST_TEST(!arrivalTime(25.9).pass);
    BOOST_TEST(!arrivalTime(34.1).pass);
    BOOST_TEST(arrivalTime(29.9).value == 29.9);
    const Check never = arrivalTime(std::nullopt);
    BOOST_TEST(!never.pass);
    BOOST_TEST(std::isnan(never.value));
}

BOOST_AUTO_TEST_CASE(rimea5_nobody_starts_before_its_premovement) {
    const std::vector<StartRecord> onTime = {{0, 10.0, 10.5}, {1, 55.0, 55.0}, {2, 99.0, 99.05}};
    const Check ok = premovementStarts(onTime);
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 0.5, "the value is the largest delay");
    // Within one step of observation early: still on time.
    BOOST_TEST(premovementStarts({{0, 10.0, 9.95}}).pass);
    // Early by more than the tolerance: fails.
    BOOST_TEST(!premovementStarts({{0, 10.0, 10.2}, {1, 20.0, 19.8}}).pass);
    // Everyone starting together at t = 0 (premovement ignored) fails.
    BOOST_TEST(!premovementStarts({{0, 10.0, 0.1}, {1, 50.0, 0.1}}).pass);
    // Late is documented, not failed (someone may stand in the way).
    const Check late = premovementStarts({{0, 10.0, 40.0}});
    BOOST_TEST(late.pass);
    BOOST_TEST(late.value == 30.0);
    // Someone who never moved fails; so does an empty list.
    BOOST_TEST(!premovementStarts({{0, 10.0, 10.0}, {1, 20.0, std::nullopt}}).pass);
    BOOST_TEST(!premovementStarts({}).pass);
}

BOOST_AUTO_TEST_CASE(rimea6_everyone_round_and_no_wall_penetration) {
    BOOST_TEST(cornerPassage(20, 20, 0.0, 0.05).pass);
    BOOST_TEST(cornerPassage(20, 20, 0.05, 0.05).pass);
    BOOST_TEST(!cornerPassage(20, 20, 0.051, 0.05).pass);
    BOOST_TEST(!cornerPassage(19, 20, 0.0, 0.05).pass);
    BOOST_TEST(!cornerPassage(0, 0, 0.0, 0.05).pass, "an empty scenario proves nothing");
    BOOST_TEST(cornerPassage(20, 20, 0.012, 0.05).value == 0.012);
}

BOOST_AUTO_TEST_CASE(rimea7_speeds_in_their_group_range) {
    std::vector<SpeedRecord> people = {{0, "under 30", 0.58, 1.61, 0.58},
                                       {1, "under 30", 0.58, 1.61, 1.61},
                                       {2, "limited", 0.46, 0.76, 0.60}};
    BOOST_TEST(speedsInRanges(people).pass);
    BOOST_TEST(speedsInRanges(people).value == 0.0);
    people[2].speed = 0.775;  // within the 0.02 m/s measuring tolerance above 0.76
    BOOST_TEST(speedsInRanges(people).pass);
    people[2].speed = 0.79;
    const Check fast = speedsInRanges(people);
    BOOST_TEST(!fast.pass);
    BOOST_TEST(fast.value == 0.03, boost::test_tools::tolerance(1e-12));
    people[2].speed = 0.43;  // below the range
    BOOST_TEST(!speedsInRanges(people).pass);
    people[2].speed = std::nullopt;  // not measured
    BOOST_TEST(!speedsInRanges(people).pass);
    BOOST_TEST(!speedsInRanges({}).pass);
}

BOOST_AUTO_TEST_CASE(rimea7_crossing_time_interpolates) {
    BOOST_TEST(*crossingTime(1.0, 4.0, 2.0, 6.0, 5.0) == 1.5);
    BOOST_TEST(*crossingTime(1.0, 4.0, 2.0, 5.0, 5.0) == 2.0);
    BOOST_TEST(!crossingTime(1.0, 5.0, 2.0, 6.0, 5.0).has_value(), "already past the line");
    BOOST_TEST(!crossingTime(1.0, 3.0, 2.0, 4.0, 5.0).has_value(), "not yet at the line");
}

BOOST_AUTO_TEST_CASE(rimea10_everyone_by_its_allocated_exit) {
    std::vector<ExitRecord> people = {{0, "main", std::string("main")}, {1, "secondary", std::string("secondary")}};
    BOOST_TEST(routeAllocation(people).pass);
    BOOST_TEST(routeAllocation(people).value == 0.0);
    people[1].used = "main";  // took the other exit
    BOOST_TEST(!routeAllocation(people).pass);
    BOOST_TEST(routeAllocation(people).value == 1.0);
    people[1].used = std::nullopt;  // did not leave
    BOOST_TEST(!routeAllocation(people).pass);
    BOOST_TEST(!routeAllocation({}).pass);
}

BOOST_AUTO_TEST_CASE(max_flow_specific_flow_and_limit) {
    // 100 people out at 1 person per second through 1 m: 1 P/(m s); through 0.5 m: 2.
    std::vector<double> times;
    for (int k = 99; k >= 0; --k) times.push_back(10.0 + k);  // unsorted on purpose
    BOOST_TEST(*specificFlow(times, 10, 90, 1.0) == 1.0);
    BOOST_TEST(*specificFlow(times, 10, 90, 0.5) == 2.0);
    BOOST_TEST(!specificFlow(times, 10, 101, 1.0).has_value(), "fewer people out than the last counted");
    BOOST_TEST(!specificFlow({5.0, 5.0}, 1, 2, 1.0).has_value(), "no time between them");
    BOOST_TEST(maximumFlow(1.33).pass);
    BOOST_TEST(maximumFlow(1.0).pass);
    BOOST_TEST(!maximumFlow(1.34).pass);
    BOOST_TEST(!maximumFlow(std::nullopt).pass);
}
