// The ISO 20414 / NIST criteria of `crowdhealth verify` and the Kolmogorov–Smirnov test they use
// (Engine/verify_criteria_iso.h): the KS statistic on samples whose D is known by hand, the critical
// values against the exact table, the p-value at the critical value, each criterion just inside and
// just outside its bounds, and the inputs that must fail. docs/verification/iso.md lists the
// mutations of verify_criteria_iso.cpp these cases catch.
#define BOOST_TEST_MODULE verify_iso
#include <boost/test/unit_test.hpp>

#include "verify_criteria_iso.h"

#include <algorithm>
#include <cmath>

using namespace chverify;
namespace tt = boost::test_tools;

namespace {
const Reference kUnit{Reference::Kind::Uniform, 0, 1};
const Reference kStdNormal{Reference::Kind::Normal, 0, 1};

/// The n quantiles (i − 0.5)/n of `ref` (bisection on its CDF): a sample as close to `ref` as n
/// points can be (D = 0.5/n).
std::vector<double> quantiles(const Reference& ref, std::size_t n, double lo, double hi) {
    std::vector<double> x;
    for (std::size_t i = 0; i < n; ++i) {
        const double p = (static_cast<double>(i) + 0.5) / static_cast<double>(n);
        double a = lo, b = hi;
        for (int k = 0; k < 200; ++k) {
            const double m = 0.5 * (a + b);
            (ref.cdf(m) < p ? a : b) = m;
        }
        x.push_back(0.5 * (a + b));
    }
    return x;
}
}  // namespace

BOOST_AUTO_TEST_CASE(ks_statistic_of_samples_known_by_hand) {
    // {0.1, 0.4, 0.7} against U(0, 1): the largest gap is 1 − 0.7 above the last point.
    BOOST_TEST(ksStatistic({0.1, 0.4, 0.7}, kUnit) == 0.3, tt::tolerance(1e-12));
    // Any order.
    BOOST_TEST(ksStatistic({0.7, 0.1, 0.4}, kUnit) == 0.3, tt::tolerance(1e-12));
    // Below a point counts too: {0.9} is 0.9 above the empirical CDF's 0 just before it.
    BOOST_TEST(ksStatistic({0.9}, kUnit) == 0.9, tt::tolerance(1e-12));
    // {−1, 1} against N(0, 1): Φ(1) − 1/2 = 0.341345.
    BOOST_TEST(ksStatistic({-1, 1}, kStdNormal) == 0.3413447, tt::tolerance(1e-6));
    // {1, e} against lognormal(0, 1) is {0, 1} against N(0, 1): 1/2 at the first point.
    BOOST_TEST(ksStatistic({1, std::exp(1.0)}, Reference{Reference::Kind::Lognormal, 0, 1}) == 0.5, tt::tolerance(1e-12));
    // The n quantiles give 0.5/n.
    BOOST_TEST(ksStatistic(quantiles(kUnit, 100, 0, 1), kUnit) == 0.005, tt::tolerance(1e-9));
    BOOST_TEST(std::isnan(ksStatistic({}, kUnit)));
}

BOOST_AUTO_TEST_CASE(reference_cdfs_with_and_without_truncation) {
    BOOST_TEST(kUnit.cdf(0.25) == 0.25, tt::tolerance(1e-12));
    BOOST_TEST(Reference({Reference::Kind::Uniform, 10, 100}).cdf(55) == 0.5, tt::tolerance(1e-12));
    BOOST_TEST(kStdNormal.cdf(1.96) == 0.9750021, tt::tolerance(1e-6));
    // N(0, 1) truncated to [0, inf): (Φ(1) − 1/2) / (1/2).
    BOOST_TEST(Reference({Reference::Kind::Normal, 0, 1, 0, 1e300}).cdf(1) == 0.6826895, tt::tolerance(1e-6));
    BOOST_TEST(Reference({Reference::Kind::Normal, 0, 1, 0, 1e300}).cdf(-0.5) == 0.0);
    // Lognormal(mu, sigma): the median is e^mu; truncated at e^mu from above, e^mu is the top.
    const Reference logn{Reference::Kind::Lognormal, 3.689, 0.4};
    BOOST_TEST(logn.cdf(std::exp(3.689)) == 0.5, tt::tolerance(1e-12));
    BOOST_TEST(logn.cdf(0) == 0.0);
    BOOST_TEST(Reference({Reference::Kind::Lognormal, 3.689, 0.4, 0, std::exp(3.689)}).cdf(std::exp(3.689) * 0.999) < 1.0);
    BOOST_TEST(Reference({Reference::Kind::Lognormal, 3.689, 0.4, 0, std::exp(3.689)}).cdf(std::exp(3.689)) == 1.0);
    BOOST_TEST(logn.describe() == "lognormal(mu 3.689, sigma 0.4)");
    BOOST_TEST(Reference({Reference::Kind::Normal, 55, 15, 10, 100}).describe() == "normal(55, 15) in [10, 100]");
}

BOOST_AUTO_TEST_CASE(ks_critical_values_match_the_exact_table) {
    // Exact two-sided critical values (Massey 1951; Miller 1956): n = 10: 0.40925, n = 20: 0.29408
    // at 5 %; n = 10 at 1 %: 0.48893. The asymptotic 1.358/√100 = 0.1358 for n = 100.
    BOOST_TEST(ksCriticalValue(10) == 0.40925, tt::tolerance(0.002));
    BOOST_TEST(ksCriticalValue(20) == 0.29408, tt::tolerance(0.002));
    BOOST_TEST(ksCriticalValue(10, 0.01) == 0.48893, tt::tolerance(0.005));
    BOOST_TEST(ksCriticalValue(100) == 0.1340, tt::tolerance(0.002));
    BOOST_TEST(ksCriticalValue(100) < 1.358 / 10);
    BOOST_TEST(std::isnan(ksCriticalValue(0)));
    // At the critical value the p-value is the significance.
    BOOST_TEST(ksPValue(ksCriticalValue(100), 100) == 0.05, tt::tolerance(0.01));
    BOOST_TEST(ksPValue(ksCriticalValue(37, 0.01), 37) == 0.01, tt::tolerance(0.01));
    // The Kolmogorov distribution's tail: Q(0.5) = 0.9639, Q(1) = 0.2700 (λ = (√n + 0.12 + 0.11/√n)·D).
    BOOST_TEST(ksPValue(0.5 / (10 + 0.12 + 0.011), 100) == 0.9639, tt::tolerance(1e-3));
    BOOST_TEST(ksPValue(1.0 / (10 + 0.12 + 0.011), 100) == 0.2700, tt::tolerance(1e-3));
    BOOST_TEST(ksPValue(0.01, 100) == 1.0);
    BOOST_TEST(ksPValue(0.5, 100) < 1e-9);
}

BOOST_AUTO_TEST_CASE(ks_not_rejected_just_inside_and_just_outside_the_critical_value) {
    // The 100 quantiles of U(0, 1) have D = 0.005; shifted by s, D = 0.005 + s. Critical 0.13405.
    const double crit = ksCriticalValue(100);
    auto shifted = [](double s) {
        std::vector<double> x = quantiles(kUnit, 100, 0, 1);
        for (double& v : x) v += s;
        return x;
    };
    const Check in = ksNotRejected(shifted(crit - 0.005 - 0.001), kUnit, "x");
    BOOST_TEST(in.pass, in.detail);
    BOOST_TEST(in.value == crit - 0.001, tt::tolerance(1e-6));
    const Check out = ksNotRejected(shifted(crit - 0.005 + 0.001), kUnit, "x");
    BOOST_TEST(!out.pass, out.detail);
    BOOST_TEST(!ksNotRejected({}, kUnit, "x").pass);
}

BOOST_AUTO_TEST_CASE(corridor_speed_within_1_0_plus_minus_0_05) {
    BOOST_TEST(corridorSpeed(40.0, 40).pass);
    BOOST_TEST(corridorSpeed(40.0, 40).value == 1.0);
    BOOST_TEST(corridorSpeed(38.1, 40).pass);   // 1.0499 m/s
    BOOST_TEST(!corridorSpeed(38.0, 40).pass);  // 1.0526
    BOOST_TEST(corridorSpeed(42.1, 40).pass);   // 0.9501
    BOOST_TEST(!corridorSpeed(42.2, 40).pass);  // 0.9479
    BOOST_TEST(!corridorSpeed(std::nullopt, 40).pass);
    BOOST_TEST(std::isnan(corridorSpeed(std::nullopt, 40).value));
}

namespace {
/// 100 people appearing at `appeared`, due at appearance + the quantiles of U(10, 100), starting
/// `delay` s after they are due.
struct Starts {
    std::vector<StartRecord> people;
    std::vector<double> appeared;
    std::vector<double> drawn;  ///< the premovement times given
};
Starts uniformStarts(double appeared, double delay) {
    Starts s;
    s.drawn = quantiles(Reference{Reference::Kind::Uniform, 10, 100}, 100, 10, 100);
    const std::vector<double> pm = quantiles(Reference{Reference::Kind::Uniform, 10, 100}, 100, 10, 100);
    for (std::size_t i = 0; i < pm.size(); ++i) {
        s.people.push_back({static_cast<std::int64_t>(i), appeared + pm[i], appeared + pm[i] + delay});
        s.appeared.push_back(appeared);
    }
    return s;
}
}  // namespace

BOOST_AUTO_TEST_CASE(premovement_starts_follow_the_distribution_none_early) {
    const Reference u{Reference::Kind::Uniform, 10, 100};
    // On time (a step late): passes. The start is measured from the appearance.
    Starts s = uniformStarts(20, 0.1);
    Check c = premovementDistribution(s.people, s.appeared, s.drawn, u);
    BOOST_TEST(c.pass, c.detail);
    BOOST_TEST(c.value < 0.01);
    // Late by 11 s each: D = 0.005 + 11/90 = 0.127, not rejected; by 12.5 s: 0.144, rejected.
    s = uniformStarts(0, 11);
    BOOST_TEST(premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    s = uniformStarts(0, 12.5);
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    // One person early by more than the tolerance fails, even with the distribution met.
    s = uniformStarts(0, 0);
    s.people[40].start = s.people[40].due - 0.2;
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    s.people[40].start = s.people[40].due - 0.05;
    BOOST_TEST(premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    // Someone who never started fails.
    s.people[40].start.reset();
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    // Inputs that must fail.
    BOOST_TEST(!premovementDistribution({}, {}, {}, u).pass);
    s = uniformStarts(0, 0);
    s.appeared.pop_back();
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    s = uniformStarts(0, 0);
    s.drawn.pop_back();
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
}

BOOST_AUTO_TEST_CASE(unlucky_draws_let_start_times_pass_within_the_tolerance_of_their_d) {
    // Draws 12.5 s above the quantiles (D = 0.144: rejected themselves, as 5 % of correct samples
    // are); people starting when due have the draws' D: pass; starting 1.5 s later (D + 0.0167):
    // pass; 2.5 s later (D + 0.028, over 0.02): fail.
    const Reference u{Reference::Kind::Uniform, 10, 100};
    auto unlucky = [](double delay) {
        Starts s = uniformStarts(0, 12.5 + delay);
        for (double& d : s.drawn) d += 12.5;
        for (StartRecord& p : s.people) p.due += 12.5;
        return s;
    };
    Starts s = unlucky(0);
    Check c = premovementDistribution(s.people, s.appeared, s.drawn, u);
    BOOST_TEST(c.pass, c.detail);
    BOOST_TEST(c.value > ksCriticalValue(100));
    s = unlucky(1.5);
    BOOST_TEST(premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    s = unlucky(2.5);
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    // Lucky draws give no such allowance: draws on the quantiles, start times 12.5 s late; draws
    // 10.35 s off (D = 0.120, not rejected) and start times 1.35 s later still (D = 0.135).
    s = uniformStarts(0, 12.5);
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
    s = uniformStarts(0, 10.35 + 1.35);
    for (double& d : s.drawn) d += 10.35;
    for (StartRecord& p : s.people) p.due += 10.35;
    BOOST_TEST(!premovementDistribution(s.people, s.appeared, s.drawn, u).pass);
}

BOOST_AUTO_TEST_CASE(speeds_follow_the_normal_distribution) {
    const Reference n{Reference::Kind::Normal, 1.2, 0.2, 0, 1e300};
    std::vector<std::optional<double>> v;
    for (double x : quantiles(n, 100, 0, 3)) v.push_back(x);
    const Check ok = speedDistribution(v, n);
    BOOST_TEST(ok.pass, ok.detail);
    BOOST_TEST(ok.value == 0.005, tt::tolerance(1e-6));
    // Every speed 0.06 m/s slow: D ≈ 0.005 + φ(0)·0.3 = 0.124 passes; 0.07 m/s: 0.143 fails.
    auto slowed = [&](double dv) {
        std::vector<std::optional<double>> w;
        for (const auto& x : v) w.push_back(*x - dv);
        return w;
    };
    BOOST_TEST(speedDistribution(slowed(0.06), n).pass);
    BOOST_TEST(!speedDistribution(slowed(0.07), n).pass);
    // One speed not measured fails.
    auto missing = v;
    missing[3].reset();
    BOOST_TEST(!speedDistribution(missing, n).pass);
    BOOST_TEST(!speedDistribution({}, n).pass);
}

BOOST_AUTO_TEST_CASE(crossing_times_rise_strictly_with_the_counter_flow) {
    const std::vector<int> counts = {0, 10, 50, 100};
    const Check ok = risingCrossingTimes({50.0, 55.0, 70.0, 90.0}, counts);
    BOOST_TEST(ok.pass, ok.detail);
    BOOST_TEST(ok.value == 5.0, "the value is the smallest rise");
    BOOST_TEST(risingCrossingTimes({50.0, 50.01, 70.0, 90.0}, counts).pass);
    BOOST_TEST(!risingCrossingTimes({50.0, 50.0, 70.0, 90.0}, counts).pass);  // no rise
    BOOST_TEST(!risingCrossingTimes({50.0, 55.0, 54.0, 90.0}, counts).pass);  // a fall
    BOOST_TEST(risingCrossingTimes({50.0, 55.0, 54.0, 90.0}, counts).value == -1.0, tt::tolerance(1e-12));
    const Check jam = risingCrossingTimes({50.0, 55.0, 70.0, std::nullopt}, counts);
    BOOST_TEST(!jam.pass);
    BOOST_TEST(jam.detail.find("gridlock against 100") != std::string::npos, jam.detail);
    BOOST_TEST(!risingCrossingTimes({50.0}, {0}).pass);
    BOOST_TEST(!risingCrossingTimes({50.0, 60.0}, counts).pass);
}

BOOST_AUTO_TEST_CASE(a_group_arrives_together_within_the_spread) {
    using O = std::optional<double>;
    Check c = groupArrivesTogether({O(40.0), O(45.0), O(49.9)}, 10);
    BOOST_TEST(c.pass, c.detail);
    BOOST_TEST(c.value == 9.9, boost::test_tools::tolerance(1e-9));
    c = groupArrivesTogether({O(49.9), O(40.0), O(50.1)}, 10);  // order does not matter
    BOOST_TEST(!c.pass, c.detail);
    BOOST_TEST(c.value == 10.1, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(groupArrivesTogether({O(40.0), O(50.0)}, 10).pass, "the bound itself passes");
    BOOST_TEST(!groupArrivesTogether({O(50.0), O(40.0), O(45.0)}, 9).pass, "the latest arrival need not come last");
    c = groupArrivesTogether({O(40.0), std::nullopt, O(41.0)}, 10);
    BOOST_TEST(!c.pass, "someone did not arrive");
    BOOST_TEST(c.detail.find("1 of 3 did not arrive") != std::string::npos, c.detail);
    BOOST_TEST(!groupArrivesTogether({}, 10).pass, "nobody to check");
}
