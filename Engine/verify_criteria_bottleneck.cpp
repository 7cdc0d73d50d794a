// crowdhealth verify — the criteria of the bottleneck tests (verify_criteria_bottleneck.h).
#include "verify_criteria_bottleneck.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace chverify {

namespace {
std::string fmt(double v, int decimals = 2) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}
std::string fmtFlow(const std::optional<double>& f) { return f ? fmt(*f) + " P/s" : std::string("no flow"); }

/// The mean of the experimental flows at a width; nullopt when there are none.
std::optional<double> meanOf(const std::vector<double>& v) {
    if (v.empty()) return std::nullopt;
    double s = 0;
    for (double x : v) s += x;
    return s / static_cast<double>(v.size());
}

/// The simulated flow at `width` (0 when not measured); nullopt when the width was not simulated.
std::optional<double> simulatedAt(const std::vector<WidthFlow>& simulated, double width) {
    for (const WidthFlow& w : simulated)
        if (std::abs(w.width - width) < 1e-9) return w.flow.value_or(0.0);
    return std::nullopt;
}
}  // namespace

std::optional<double> passageFlow(std::vector<double> exitTimes, std::size_t first, std::size_t last) {
    if (first < 1 || last <= first || exitTimes.size() < last) return std::nullopt;
    std::sort(exitTimes.begin(), exitTimes.end());
    const double dt = exitTimes[last - 1] - exitTimes[first - 1];
    if (!(dt > 0)) return std::nullopt;
    return static_cast<double>(last - first) / dt;
}

std::optional<double> peakMovingMean(const std::vector<double>& samples, std::size_t window) {
    if (samples.empty() || window == 0) return std::nullopt;
    const std::size_t w = std::min(window, samples.size());
    double sum = 0;
    for (std::size_t k = 0; k < w; ++k) sum += samples[k];
    double best = sum;
    for (std::size_t k = w; k < samples.size(); ++k) {
        sum += samples[k] - samples[k - w];
        best = std::max(best, sum);
    }
    return best / static_cast<double>(w);
}

Check longerIsSlower(std::optional<double> flowShort, std::optional<double> flowLong) {
    Check c;
    c.value = std::numeric_limits<double>::quiet_NaN();
    if (!flowShort || !flowLong) {
        c.detail = "12b: flow short " + fmtFlow(flowShort) + ", long " + fmtFlow(flowLong) + ": not measured";
        return c;
    }
    c.value = *flowLong - *flowShort;
    c.pass = *flowLong < *flowShort;
    c.detail = "12b: flow through 5 m " + fmtFlow(flowLong) + (c.pass ? " < " : " not < ") + fmtFlow(flowShort) +
               " through 0.2 m";
    return c;
}

Check jamOnlyBeforeFirst(std::optional<double> peakFirst, std::optional<double> peakSecond, double jam) {
    Check c;
    c.value = peakSecond ? *peakSecond : std::numeric_limits<double>::quiet_NaN();
    if (!peakFirst || !peakSecond) {
        c.detail = "12c: densities not measured";
        return c;
    }
    const bool jamFirst = *peakFirst > jam, jamSecond = *peakSecond > jam;
    c.pass = jamFirst && !jamSecond;
    c.detail = "12c: peak density before 1st door " + fmt(*peakFirst) + ", before 2nd " + fmt(*peakSecond) +
               " P/m2 (jam > " + fmt(jam) + ")";
    if (!jamFirst) c.detail += ": no jam before the 1st";
    if (jamSecond) c.detail += ": jam before the 2nd";
    return c;
}

Check flowRisesWithWidth(std::vector<WidthFlow> series) {
    Check c;
    c.value = std::numeric_limits<double>::quiet_NaN();
    std::sort(series.begin(), series.end(), [](const WidthFlow& a, const WidthFlow& b) { return a.width < b.width; });
    std::string list;
    for (const WidthFlow& w : series) list += (list.empty() ? "" : ", ") + fmt(w.width, 1) + " m " + fmtFlow(w.flow);
    c.detail = "12d: " + list;
    if (series.size() < 2) return c;
    double smallest = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < series.size(); ++k)
        if (!series[k].flow) return c;
    for (std::size_t k = 1; k < series.size(); ++k) smallest = std::min(smallest, *series[k].flow - *series[k - 1].flow);
    c.value = smallest;
    c.pass = smallest > 0;
    if (!c.pass) c.detail += ": does not rise";
    return c;
}

const std::vector<MeasuredWidth>& kretz2006() {
    static const std::vector<MeasuredWidth> data = {
        {0.4, {0.88, 0.90}},       {0.5, {1.01, 1.04}},       {0.6, {1.12}},
        {0.7, {1.22, 1.25}},       {0.8, {1.39, 1.42, 1.46}}, {0.9, {1.53, 1.58, 1.63}},
        {1.0, {1.71, 1.81, 1.88, 2.02}}, {1.2, {2.03, 2.11, 2.29}},
    };
    return data;
}

std::optional<double> flowRmse(const std::vector<WidthFlow>& simulated, const std::vector<MeasuredWidth>& data) {
    double sum = 0;
    std::size_t n = 0;
    for (const MeasuredWidth& d : data) {
        const std::optional<double> m = meanOf(d.flows);
        if (!m) continue;
        const std::optional<double> s = simulatedAt(simulated, d.width);
        if (!s) continue;
        sum += (*s - *m) * (*s - *m);
        ++n;
    }
    if (n == 0) return std::nullopt;
    return std::sqrt(sum / static_cast<double>(n));
}

std::optional<double> meanFlowRatio(const std::vector<WidthFlow>& simulated, const std::vector<MeasuredWidth>& data) {
    double sum = 0;
    std::size_t n = 0;
    for (const MeasuredWidth& d : data) {
        const std::optional<double> m = meanOf(d.flows);
        if (!m || !(*m > 0)) continue;
        const std::optional<double> s = simulatedAt(simulated, d.width);
        if (!s) continue;
        sum += *s / *m;
        ++n;
    }
    if (n == 0) return std::nullopt;
    return sum / static_cast<double>(n);
}

Check allSubcases(const std::vector<Check>& parts) {
    Check c;
    c.value = 0;
    std::string failing, passing;
    for (const Check& p : parts) {
        std::string& to = p.pass ? passing : failing;
        to += (to.empty() ? "" : "; ") + p.detail;
        if (!p.pass) c.value += 1;
    }
    c.pass = !parts.empty() && c.value == 0;
    c.detail = failing.empty() ? passing : passing.empty() ? failing : failing + "; " + passing;
    if (parts.empty()) c.detail = "no sub-case measured";
    return c;
}

}  // namespace chverify
