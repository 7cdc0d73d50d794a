// crowdhealth verify — criteria of the evacuation family (verify_criteria_evacuation.h).
#include "verify_criteria_evacuation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace chverify {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v, int decimals = 1) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(decimals);
    s << v;
    return s.str();
}
}  // namespace

Check timesDecrease(const std::vector<std::optional<double>>& times) {
    Check c;
    c.value = kNaN;
    if (times.size() < 2) {
        c.detail = "fewer than two runs";
        return c;
    }
    std::string list;
    bool missing = false;
    for (const auto& t : times) {
        list += (list.empty() ? "" : " / ") + (t ? num(*t) + " s" : std::string("not all out"));
        missing = missing || !t;
    }
    if (missing) {
        c.detail = "times " + list + ": not everyone left";
        return c;
    }
    c.value = *times.front() / *times.back();
    c.pass = true;
    for (std::size_t k = 1; k < times.size(); ++k)
        if (!(*times[k] < *times[k - 1])) c.pass = false;
    c.detail = "times " + list + (c.pass ? ": falling" : ": not falling at every step");
    return c;
}

Check evacuationTimeRatio(std::optional<double> allExits, std::optional<double> fewerExits, double lo, double hi) {
    Check c;
    c.value = kNaN;
    if (!allExits || !fewerExits) {
        c.detail = std::string("not everyone left with ") + (!allExits ? "all exits" : "fewer exits");
        return c;
    }
    c.value = *fewerExits / *allExits;
    c.pass = c.value >= lo && c.value <= hi;
    c.detail = num(*fewerExits) + " s / " + num(*allExits) + " s = " + num(c.value, 2) + (c.pass ? " in " : " outside ") +
               "[" + num(lo, 1) + ", " + num(hi, 1) + "]";
    return c;
}

Check nearerExitMajority(std::size_t nearer, std::size_t farther, std::size_t total) {
    Check c;
    c.value = kNaN;
    if (total == 0) {
        c.detail = "nobody";
        return c;
    }
    c.value = 100.0 * static_cast<double>(nearer) / static_cast<double>(total);
    const bool allOut = nearer + farther == total;
    c.pass = allOut && 2 * nearer > total && farther > 0;
    c.detail = std::to_string(nearer) + " nearer, " + std::to_string(farther) + " farther of " + std::to_string(total);
    if (!allOut) c.detail += ": not everyone left";
    else if (2 * nearer <= total) c.detail += ": not a majority by the nearer exit";
    else if (farther == 0) c.detail += ": nobody by the farther exit";
    return c;
}

Check cornerBetweenStraights(std::optional<double> shortStraight, std::optional<double> corner,
                             std::optional<double> longStraight) {
    Check c;
    c.value = kNaN;
    if (!shortStraight || !corner || !longStraight) {
        c.detail = std::string("not everyone left in the ") +
                   (!shortStraight ? "short straight" : !corner ? "corner" : "long straight") + " corridor";
        return c;
    }
    const double lo = std::min(*shortStraight, *longStraight), hi = std::max(*shortStraight, *longStraight);
    if (*longStraight != *shortStraight) c.value = (*corner - *shortStraight) / (*longStraight - *shortStraight);
    c.pass = *corner >= lo && *corner <= hi;
    c.detail = "straight " + num(*shortStraight) + " s, corner " + num(*corner) + " s, straight " + num(*longStraight) +
               " s" + (c.pass ? "" : ": corner outside");
    return c;
}

Check closedExitUnused(const std::vector<ExitTime>& people, const std::string& closed, double closeTime, double grace) {
    Check c;
    c.value = kNaN;
    if (people.empty()) {
        c.detail = "nobody";
        return c;
    }
    std::size_t out = 0, before = 0, late = 0;
    std::int64_t firstLate = 0;
    double lateTime = 0;
    for (const ExitTime& p : people) {
        if (!p.exit) continue;
        ++out;
        if (*p.exit != closed) continue;
        if (p.time <= closeTime + grace) ++before;
        else if (late++ == 0) firstLate = p.id, lateTime = p.time;
    }
    c.value = static_cast<double>(late);
    c.pass = late == 0 && out == people.size();
    c.detail = std::to_string(out) + "/" + std::to_string(people.size()) + " out, " + std::to_string(before) + " by " +
               closed + " before it closed";
    if (late > 0) c.detail += ", " + std::to_string(late) + " after (first: agent " + std::to_string(firstLate) +
                              " at " + num(lateTime, 2) + " s)";
    return c;
}

}  // namespace chverify
