// The criteria of the bottleneck tests of `crowdhealth verify` (Engine/verify_criteria_bottleneck.h:
// RiMEA 12 a-d, validation against Kretz et al. 2006), each just inside and just outside its
// bounds, and on the inputs that must fail. docs/verification/bottleneck.md lists the mutations of
// verify_criteria_bottleneck.cpp these cases catch.
#define BOOST_TEST_MODULE verify_bottleneck
#include <boost/test/unit_test.hpp>

#include "verify_criteria_bottleneck.h"

#include <cmath>

using namespace chverify;

BOOST_AUTO_TEST_CASE(passage_flow_from_the_first_to_the_last_person) {
    // 12 people, one every 0.5 s from t = 1 s, unsorted: from the 2nd (1.5 s) to the 10th (5.5 s).
    std::vector<double> t;
    for (int k = 11; k >= 0; --k) t.push_back(1.0 + 0.5 * k);
    const auto f = passageFlow(t, 2, 10);
    BOOST_REQUIRE(f);
    BOOST_TEST(*f == 8.0 / 4.0, boost::test_tools::tolerance(1e-12));
    // The last person counted must have left.
    BOOST_TEST(passageFlow(t, 2, 12).has_value());
    BOOST_TEST(!passageFlow(t, 2, 13).has_value());
    // Nobody between, or all at one instant: no flow.
    BOOST_TEST(!passageFlow(t, 5, 5).has_value());
    BOOST_TEST(!passageFlow({3.0, 3.0, 3.0}, 1, 3).has_value());
    BOOST_TEST(!passageFlow(t, 0, 3).has_value());
}

BOOST_AUTO_TEST_CASE(peak_moving_mean) {
    const std::vector<double> s = {0, 1, 5, 5, 1, 0};
    BOOST_TEST(*peakMovingMean(s, 2) == 5.0);
    BOOST_TEST(*peakMovingMean(s, 3) == 11.0 / 3.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(*peakMovingMean(s, 1) == 5.0);
    // A window longer than the series: the mean of the whole series.
    BOOST_TEST(*peakMovingMean(s, 100) == 2.0);
    // The window slides to the end: a peak in the last samples counts.
    BOOST_TEST(*peakMovingMean({0, 0, 0, 4, 4}, 2) == 4.0);
    BOOST_TEST(!peakMovingMean({}, 3).has_value());
    BOOST_TEST(!peakMovingMean(s, 0).has_value());
}

BOOST_AUTO_TEST_CASE(rimea12b_longer_is_slower) {
    const Check ok = longerIsSlower(1.50, 1.49);
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 1.49 - 1.50, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(!longerIsSlower(1.50, 1.50).pass);
    BOOST_TEST(!longerIsSlower(1.50, 1.51).pass);
    BOOST_TEST(!longerIsSlower(std::nullopt, 1.0).pass);
    BOOST_TEST(!longerIsSlower(1.0, std::nullopt).pass);
}

BOOST_AUTO_TEST_CASE(rimea12c_jam_only_before_the_first_door) {
    const Check ok = jamOnlyBeforeFirst(3.0, 2.17);
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 2.17);
    BOOST_TEST(!jamOnlyBeforeFirst(3.0, 2.18).pass, "a jam before the second door");
    BOOST_TEST(!jamOnlyBeforeFirst(2.17, 1.0).pass, "no jam before the first: the set-up did not make one");
    BOOST_TEST(jamOnlyBeforeFirst(2.18, 1.0).pass);
    BOOST_TEST(!jamOnlyBeforeFirst(std::nullopt, 1.0).pass);
    BOOST_TEST(!jamOnlyBeforeFirst(3.0, std::nullopt).pass);
    BOOST_TEST(jamOnlyBeforeFirst(1.5, 0.5, 1.0).pass, "the threshold is a parameter");
}

BOOST_AUTO_TEST_CASE(rimea12d_flow_rises_with_width) {
    const Check ok = flowRisesWithWidth({{1.2, 2.0}, {0.8, 1.4}, {1.0, 1.7}});  // any order
    BOOST_TEST(ok.pass);
    BOOST_TEST(ok.value == 0.3, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(flowRisesWithWidth({{0.8, 1.4}, {1.0, 1.41}, {1.2, 1.42}}).pass);
    BOOST_TEST(!flowRisesWithWidth({{0.8, 1.4}, {1.0, 1.4}, {1.2, 2.0}}).pass, "equal flows do not rise");
    BOOST_TEST(!flowRisesWithWidth({{0.8, 1.4}, {1.0, 1.7}, {1.2, 1.69}}).pass);
    BOOST_TEST(!flowRisesWithWidth({{0.8, 1.8}, {1.0, 1.7}, {1.2, 1.9}}).pass, "the narrowest door must be the slowest");
    BOOST_TEST(!flowRisesWithWidth({{0.8, std::nullopt}, {1.0, 1.7}, {1.2, 2.0}}).pass);
    BOOST_TEST(!flowRisesWithWidth({{1.0, 1.7}}).pass);
    BOOST_TEST(!flowRisesWithWidth({}).pass);
}

BOOST_AUTO_TEST_CASE(kretz_data_as_published) {
    const auto& d = kretz2006();
    BOOST_TEST(d.size() == 8u);
    std::size_t runs = 0;
    for (const auto& w : d) runs += w.flows.size();
    BOOST_TEST(runs == 20u);
    BOOST_TEST(d.front().width == 0.4);
    BOOST_TEST(d.back().width == 1.2);
    BOOST_TEST(d[6].flows.size() == 4u);  // 1.0 m: 1.71, 1.81, 1.88, 2.02
}

BOOST_AUTO_TEST_CASE(flow_rmse_against_the_mean_per_width) {
    const std::vector<MeasuredWidth> data = {{0.5, {1.0, 1.2}}, {1.0, {2.0}}};
    // Exactly the means: 0.
    BOOST_TEST(*flowRmse({{0.5, 1.1}, {1.0, 2.0}}, data) == 0.0, boost::test_tools::tolerance(1e-12));
    // Off by +0.3 and -0.4: sqrt((0.09 + 0.16) / 2).
    BOOST_TEST(*flowRmse({{0.5, 1.4}, {1.0, 1.6}}, data) == std::sqrt(0.125), boost::test_tools::tolerance(1e-12));
    // No flow counts as 0: the error is the whole mean.
    BOOST_TEST(*flowRmse({{0.5, std::nullopt}, {1.0, 2.0}}, data) == std::sqrt(1.1 * 1.1 / 2), boost::test_tools::tolerance(1e-12));
    // Only the widths both have (a quick run); none in common: nothing.
    BOOST_TEST(*flowRmse({{1.0, 2.5}}, data) == 0.5, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(!flowRmse({{0.7, 2.5}}, data).has_value());
    BOOST_TEST(!flowRmse({}, data).has_value());
    // Ratio: mean over the widths of simulated / measured.
    BOOST_TEST(*meanFlowRatio({{0.5, 2.2}, {1.0, 2.0}}, data) == 1.5, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(*meanFlowRatio({{0.5, std::nullopt}, {1.0, 2.0}}, data) == 0.5, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(rimea12_all_subcases) {
    Check a{true, 0, "a ok"}, b{false, 1, "b bad"}, c{true, 0, "c ok"};
    const Check all = allSubcases({a, c});
    BOOST_TEST(all.pass);
    BOOST_TEST(all.value == 0.0);
    const Check one = allSubcases({a, b, c});
    BOOST_TEST(!one.pass);
    BOOST_TEST(one.value == 1.0);
    BOOST_TEST(one.detail.rfind("b bad", 0) == 0, "the failing sub-case comes first");
    BOOST_TEST(allSubcases({b, b}).value == 2.0);
    BOOST_TEST(!allSubcases({}).pass);
}
