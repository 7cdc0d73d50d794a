// crowdhealth verify — the pass criteria (see verify_criteria.h).
#include "verify_criteria.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace chverify {

std::string fixedText(double v, int decimals) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}

namespace {


constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

Check arrivalTime(std::optional<double> seconds, double lo, double hi) {
    if (!seconds) return {false, kNaN, "never arrived"};
    const bool pass = *seconds >= lo && *seconds <= hi;
    return {pass, *seconds, "arrived after " + fixedText(*seconds, 1) + " s"};
}

Check premovementStarts(const std::vector<StartRecord>& people, double early) {
    if (people.empty()) return {false, kNaN, "nobody to check"};
    Check c{true, 0, ""};
    std::size_t ok = 0;
    std::string first;
    double mostEarly = 0;
    for (const StartRecord& p : people) {
        if (!p.start) {
            c.pass = false;
            if (first.empty()) first = "agent " + std::to_string(p.id) + " never moved";
            continue;
        }
        const double d = *p.start - p.due;
        c.value = std::max(c.value, d);
        mostEarly = std::max(mostEarly, -d);
        if (d < -early) {
            c.pass = false;
            if (first.empty()) first = "agent " + std::to_string(p.id) + " started " + fixedText(-d, 1) + " s early";
        } else {
            ++ok;
        }
    }
    c.detail = std::to_string(ok) + "/" + std::to_string(people.size()) + " started on time, largest delay " +
               fixedText(c.value, 1) + " s" + (first.empty() ? "" : "; " + first);
    return c;
}

Check cornerPassage(std::size_t arrived, std::size_t total, double maxPenetration, double threshold) {
    const bool all = total > 0 && arrived == total;
    const bool walls = maxPenetration <= threshold;
    return {all && walls, maxPenetration,
            std::to_string(arrived) + "/" + std::to_string(total) + " round, deepest wall overlap " +
                fixedText(maxPenetration * 100, 1) + " cm"};
}

Check speedsInRanges(const std::vector<SpeedRecord>& people, double tolerance) {
    if (people.empty()) return {false, kNaN, "nobody to check"};
    Check c{true, 0, ""};
    std::size_t ok = 0;
    std::string first;
    for (const SpeedRecord& p : people) {
        if (!p.speed) {
            c.pass = false;
            if (first.empty()) first = "agent " + std::to_string(p.id) + " not measured";
            continue;
        }
        const double outside = std::max({0.0, p.lo - *p.speed, *p.speed - p.hi});
        c.value = std::max(c.value, outside);
        if (outside > tolerance) {
            c.pass = false;
            if (first.empty())
                first = "agent " + std::to_string(p.id) + " (" + p.group + ") " + fixedText(*p.speed, 2) + " m/s not in " +
                        fixedText(p.lo, 2) + "-" + fixedText(p.hi, 2);
        } else {
            ++ok;
        }
    }
    c.detail = std::to_string(ok) + "/" + std::to_string(people.size()) + " in range" + (first.empty() ? "" : "; " + first);
    return c;
}

std::optional<double> crossingTime(double t0, double x0, double t1, double x1, double line) {
    if (!(x0 < line && x1 >= line)) return std::nullopt;
    return t0 + (t1 - t0) * (line - x0) / (x1 - x0);
}

Check routeAllocation(const std::vector<ExitRecord>& people) {
    if (people.empty()) return {false, kNaN, "nobody to check"};
    std::size_t wrong = 0, stayed = 0;
    std::string first;
    for (const ExitRecord& p : people) {
        if (p.used && *p.used == p.allocated) continue;
        ++wrong;
        if (!p.used) ++stayed;
        if (first.empty())
            first = "agent " + std::to_string(p.id) + (p.used ? " left by " + *p.used : std::string(" did not leave")) +
                    ", allocated " + p.allocated;
    }
    Check c{wrong == 0, static_cast<double>(wrong), ""};
    c.detail = std::to_string(people.size() - wrong) + "/" + std::to_string(people.size()) + " by their exit";
    if (stayed) c.detail += ", " + std::to_string(stayed) + " still inside";
    if (!first.empty()) c.detail += "; " + first;
    return c;
}

std::optional<double> specificFlow(std::vector<double> exitTimes, std::size_t first, std::size_t last, double width) {
    if (first < 1 || last <= first || exitTimes.size() < last || width <= 0) return std::nullopt;
    std::sort(exitTimes.begin(), exitTimes.end());
    const double dt = exitTimes[last - 1] - exitTimes[first - 1];
    if (dt <= 0) return std::nullopt;
    return static_cast<double>(last - first) / dt / width;
}

Check maximumFlow(std::optional<double> flow, double limit) {
    if (!flow) return {false, kNaN, "too few people left to measure a flow"};
    return {*flow <= limit, *flow, "specific flow " + fixedText(*flow, 2) + " P/(m s)"};
}

}  // namespace chverify
