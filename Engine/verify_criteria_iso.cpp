// crowdhealth verify — the ISO 20414 / NIST criteria and the Kolmogorov–Smirnov test (see
// verify_criteria_iso.h).
#include "verify_criteria_iso.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace chverify {

namespace {

/// A parameter as short as it is exact to 4 digits: 10, 0.4, 3.689.
std::string g(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The untruncated CDF.
double rawCdf(const Reference& r, double x) {
    switch (r.kind) {
        case Reference::Kind::Uniform:
            if (x <= r.a) return 0;
            if (x >= r.b) return 1;
            return (x - r.a) / (r.b - r.a);
        case Reference::Kind::Normal: return 0.5 * std::erfc(-(x - r.a) / (r.b * std::sqrt(2.0)));
        case Reference::Kind::Lognormal:
            if (x <= 0) return 0;
            return 0.5 * std::erfc(-(std::log(x) - r.a) / (r.b * std::sqrt(2.0)));
    }
    return kNaN;
}

/// Stephens' effective sample size factor √n + 0.12 + 0.11/√n.
double stephens(std::size_t n) {
    const double s = std::sqrt(static_cast<double>(n));
    return s + 0.12 + 0.11 / s;
}

}  // namespace

double Reference::cdf(double x) const {
    if (x <= lo) return 0;
    if (x >= hi) return 1;
    const double f0 = rawCdf(*this, lo), f1 = rawCdf(*this, hi);
    return (rawCdf(*this, x) - f0) / (f1 - f0);
}

std::string Reference::describe() const {
    std::string s;
    switch (kind) {
        case Kind::Uniform: return "uniform(" + g(a) + ", " + g(b) + ")";
        case Kind::Normal: s = "normal(" + g(a) + ", " + g(b) + ")"; break;
        case Kind::Lognormal: s = "lognormal(mu " + g(a) + ", sigma " + g(b) + ")"; break;
    }
    if (lo > -1e300 || hi < 1e300)
        s += " in [" + (lo > -1e300 ? g(lo) : std::string("-inf")) + ", " + (hi < 1e300 ? g(hi) : std::string("inf")) + "]";
    return s;
}

double ksStatistic(std::vector<double> sample, const Reference& ref) {
    if (sample.empty()) return kNaN;
    std::sort(sample.begin(), sample.end());
    const double n = static_cast<double>(sample.size());
    double d = 0;
    for (std::size_t i = 0; i < sample.size(); ++i) {
        const double f = ref.cdf(sample[i]);
        d = std::max({d, static_cast<double>(i + 1) / n - f, f - static_cast<double>(i) / n});
    }
    return d;
}

double ksCriticalValue(std::size_t n, double alpha) {
    if (n == 0) return kNaN;
    return std::sqrt(-0.5 * std::log(alpha / 2)) / stephens(n);
}

double ksPValue(double d, std::size_t n) {
    if (n == 0 || !(d >= 0)) return kNaN;
    const double lambda = stephens(n) * d;
    if (lambda < 0.2) return 1;  // the series converges slowly there; Q is 1 to 1e-9
    double q = 0;
    for (int k = 1; k <= 100; ++k) {
        const double term = std::exp(-2.0 * k * k * lambda * lambda);
        q += (k % 2 ? 2 : -2) * term;
        if (term < 1e-12) break;
    }
    return std::clamp(q, 0.0, 1.0);
}

Check ksNotRejected(const std::vector<double>& sample, const Reference& ref, const std::string& what, double alpha) {
    if (sample.empty()) return {false, kNaN, "no " + what + " measured"};
    const double d = ksStatistic(sample, ref), crit = ksCriticalValue(sample.size(), alpha);
    const bool pass = d <= crit;
    return {pass, d,
            what + " vs " + ref.describe() + ": D = " + fixedText(d, 3) + (pass ? " <= " : " > ") + fixedText(crit, 3) +
                " (n = " + std::to_string(sample.size()) + ", " + fixedText(100 * alpha, 0) + " %; p = " +
                fixedText(ksPValue(d, sample.size()), 2) + ")"};
}

Check corridorSpeed(std::optional<double> seconds, double distance, double target, double tolerance) {
    if (!seconds || !(*seconds > 0)) return {false, kNaN, "never arrived"};
    const double v = distance / *seconds;
    const bool pass = std::abs(v - target) <= tolerance;
    return {pass, v, fixedText(distance, 1) + " m in " + fixedText(*seconds, 1) + " s: " + fixedText(v, 3) + " m/s"};
}

Check premovementDistribution(const std::vector<StartRecord>& people, const std::vector<double>& appeared,
                              const std::vector<double>& drawn, const Reference& ref, double early, double alpha,
                              double tolerance) {
    if (people.empty()) return {false, kNaN, "nobody to check"};
    if (appeared.size() != people.size() || drawn.size() != people.size())
        return {false, kNaN, "appearance or drawn times missing"};
    const Check starts = premovementStarts(people, early);
    std::vector<double> measured;
    for (std::size_t i = 0; i < people.size(); ++i)
        if (people[i].start) measured.push_back(*people[i].start - appeared[i]);
    Check c = ksNotRejected(measured, ref, "start times", alpha);
    const Check draws = ksNotRejected(drawn, ref, "draws", alpha);
    c.detail += "; the draws: D = " + fixedText(draws.value, 3);
    if (!c.pass && !draws.pass && c.value <= draws.value + tolerance) {
        c.pass = true;
        c.detail += ", rejected themselves; the start times within " + fixedText(tolerance, 2) + " of them";
    }
    c.pass = c.pass && starts.pass;
    c.detail = starts.detail + "; " + c.detail;
    return c;
}

Check speedDistribution(const std::vector<std::optional<double>>& speeds, const Reference& ref, double alpha) {
    if (speeds.empty()) return {false, kNaN, "nobody to check"};
    std::vector<double> measured;
    for (const auto& v : speeds)
        if (v) measured.push_back(*v);
    Check c = ksNotRejected(measured, ref, "free walking speeds", alpha);
    if (measured.size() != speeds.size()) {
        c.pass = false;
        c.detail = std::to_string(speeds.size() - measured.size()) + " of " + std::to_string(speeds.size()) +
                   " not measured; " + c.detail;
    }
    return c;
}

Check risingCrossingTimes(const std::vector<std::optional<double>>& times, const std::vector<int>& counts) {
    if (times.size() < 2 || counts.size() != times.size()) return {false, kNaN, "fewer than two counts measured"};
    Check c{true, kNaN, ""};
    std::string list, first;
    for (std::size_t k = 0; k < times.size(); ++k) {
        list += (k ? ", " : "") + std::to_string(counts[k]) + ": " + (times[k] ? fixedText(*times[k], 1) + " s" : "gridlock");
        if (!times[k]) {
            c.pass = false;
            if (first.empty()) first = "gridlock against " + std::to_string(counts[k]);
            continue;
        }
        if (k == 0 || !times[k - 1]) continue;
        const double rise = *times[k] - *times[k - 1];
        if (!(c.value <= rise)) c.value = rise;  // the smallest rise (NaN at first)
        if (!(rise > 0)) {
            c.pass = false;
            if (first.empty())
                first = "no rise from " + std::to_string(counts[k - 1]) + " to " + std::to_string(counts[k]) + " opposite";
        }
    }
    c.detail = "crossing time by opposite count: " + list + (first.empty() ? "" : "; " + first);
    return c;
}

Check groupArrivesTogether(const std::vector<std::optional<double>>& arrivals, double maxSpread) {
    if (arrivals.empty()) return {false, std::nan(""), "nobody to check"};
    std::size_t missing = 0;
    double first = 0, last = 0;
    bool any = false;
    for (const std::optional<double>& t : arrivals) {
        if (!t) {
            ++missing;
            continue;
        }
        first = any ? std::min(first, *t) : *t;
        last = any ? std::max(last, *t) : *t;
        any = true;
    }
    if (missing > 0)
        return {false, any ? last - first : std::nan(""),
                std::to_string(missing) + " of " + std::to_string(arrivals.size()) + " did not arrive"};
    const double spread = last - first;
    return {spread <= maxSpread, spread,
            "arrivals from " + fixedText(first, 1) + " to " + fixedText(last, 1) + " s: spread " + fixedText(spread, 1) +
                (spread <= maxSpread ? " <= " : " > ") + fixedText(maxSpread, 0) + " s"};
}

}  // namespace chverify
