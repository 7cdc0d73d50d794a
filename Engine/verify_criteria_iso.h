// crowdhealth verify — the pass criteria of the ISO 20414 / NIST TN 1822 tests (corridor speed,
// premovement distributions, demographics, counter-flow) as plain functions of measured values, and
// the one-sample Kolmogorov–Smirnov test they use (Tests/verify_iso_test.cpp;
// docs/verification/iso.md).
#pragma once

#include "verify_criteria.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace chverify {

/// A distribution a sample is tested against: uniform in [a, b], normal with mean a and standard
/// deviation b, or lognormal with a = mu and b = sigma of the natural log — truncated to
/// [lo, hi] as `<Draw>` truncates it (the CDF renormalised over the window).
struct Reference {
    enum class Kind { Uniform, Normal, Lognormal } kind = Kind::Uniform;
    double a = 0, b = 1;
    double lo = -1e300, hi = 1e300;
    /// P(X <= x) of the (truncated) distribution.
    double cdf(double x) const;
    /// "uniform(10, 100)", "normal(55, 15) in [10, 100]", "lognormal(mu 3.689, sigma 0.4)"
    std::string describe() const;
};

/// The Kolmogorov–Smirnov statistic D = sup |F_n(x) − F(x)| of `sample` (any order) against
/// `ref`: the largest of i/n − F(x_(i)) and F(x_(i)) − (i−1)/n over the sorted sample. NaN for an
/// empty sample.
double ksStatistic(std::vector<double> sample, const Reference& ref);

/// The critical value of D for a sample of n at significance `alpha` (two-sided): Stephens'
/// (1970) form c(α) / (√n + 0.12 + 0.11/√n), c(α) = √(−ln(α/2)/2) (1.358 at 5 %); within 0.1 % of
/// the exact table value from n = 10 on (n = 10: 0.409, n = 100: 0.134).
double ksCriticalValue(std::size_t n, double alpha = 0.05);

/// The p-value of D for a sample of n: the Kolmogorov distribution's tail Q(λ) =
/// 2 Σ (−1)^(k−1) exp(−2k²λ²) at λ = (√n + 0.12 + 0.11/√n)·D (Stephens), clamped to [0, 1].
double ksPValue(double d, std::size_t n);

/// A sample drawn from `ref`: D does not exceed the critical value at `alpha` (the KS test does
/// not reject). Value: D. Fails on an empty sample. `what` names the sample in the detail.
Check ksNotRejected(const std::vector<double>& sample, const Reference& ref, const std::string& what,
                    double alpha = 0.05);

/// ISO/NIST corridor: one person walked `distance` m in `seconds` (nullopt: never arrived); its
/// speed distance/seconds lies within `tolerance` of `target` (1.0 ± 0.05 m/s). Value: the speed.
Check corridorSpeed(std::optional<double> seconds, double distance, double target = 1.0, double tolerance = 0.05);

/// ISO/NIST premovement: every person starts walking (StartRecord as RiMEA 5: due = appearance +
/// drawn premovement) no earlier than `early` s before it is due, everyone starts, and the measured
/// premovement times (start − appearance: `appeared[i]` of `people[i]`) pass the KS test against
/// `ref` at `alpha`. The seed's draws (`drawn`, the premovement times the people were given) are a
/// sample too, and a KS test rejects `alpha` of correct samples: when the draws themselves are
/// rejected, the start times pass if their D exceeds the draws' D by at most `tolerance` (the
/// simulation added no more than a start-up delay to a sample that was unlucky already). Value: D
/// of the start times. Fails when anyone is early or never started, the sizes differ or the list
/// is empty.
Check premovementDistribution(const std::vector<StartRecord>& people, const std::vector<double>& appeared,
                              const std::vector<double>& drawn, const Reference& ref, double early = 0.1,
                              double alpha = 0.05, double tolerance = 0.02);

/// ISO/NIST demographics: every person's free walking speed was measured (nullopt: not) and the
/// speeds pass the KS test against `ref` (N(1.2, 0.2) m/s). Value: D.
Check speedDistribution(const std::vector<std::optional<double>>& speeds, const Reference& ref, double alpha = 0.05);

/// ISO/NIST counter-flow: the crossing times (s) of the same crowd against more and more opposite
/// agents (in that order) increase strictly; a crowd that did not cross (nullopt: gridlock before
/// the end of the run) fails. Value: the smallest increase from one count to the next (s).
/// `counts` labels the steps in the detail (same size as `times`).
/// ISO/NIST groups: every member of the group arrived (nullopt: did not) and the first and the last
/// arrivals lie within `maxSpread` s. Value: the spread (s). Fails when anyone did not arrive, or
/// the list is empty.
Check groupArrivesTogether(const std::vector<std::optional<double>>& arrivals, double maxSpread);

Check risingCrossingTimes(const std::vector<std::optional<double>>& times, const std::vector<int>& counts);

}  // namespace chverify
