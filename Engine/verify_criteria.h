// crowdhealth verify — the pass criteria of the verification tests as plain functions of measured
// values (no simulation inside), so that each can be unit-tested and mutated on its own
// (Tests/verify_criteria_test.cpp). The tests themselves: verify.cpp and docs/verification.md.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace chverify {

/// `v` with `decimals` digits after the point ("%.*f"): the numbers of every detail text.
std::string fixedText(double v, int decimals);

/// The outcome of one criterion on one run: whether it holds, the value the report shows (in the
/// test's unit; NaN when there is none) and a short explanation ("12/12 in range", "agent 3
/// started 4.1 s late").
struct Check {
    bool pass = false;
    double value = 0;
    std::string detail;
};

/// RiMEA 1: the single person's arrival time (s) lies in [lo, hi] (RiMEA: 26–34 s for 40 m at
/// 1.33 m/s). No arrival at all (nullopt) fails.
Check arrivalTime(std::optional<double> seconds, double lo = 26.0, double hi = 34.0);

/// One person of RiMEA 5: when it was due to start (its appearance + premovement, s) and when it
/// was first seen to move (nullopt: never).
struct StartRecord {
    std::int64_t id = 0;
    double due = 0;
    std::optional<double> start;
};
/// RiMEA 5: every person starts moving at its own time: nobody earlier than `early` s before it
/// is due (one coarse step of observation), and everyone at some time. A late start is not a
/// failure (someone standing in the way can hold a person up: RiMEA asks only that people start
/// at their own times); the value is the largest delay start − due (s), which the report shows.
/// Fails when anyone starts early or never moved, or the list is empty.
Check premovementStarts(const std::vector<StartRecord>& people, double early = 0.1);

/// RiMEA 6: everyone got round the corner (all `total` left by the exit) and no body overlapped
/// a wall deeper than `threshold` m at any step. Value: the largest penetration (m).
Check cornerPassage(std::size_t arrived, std::size_t total, double maxPenetration, double threshold);

/// One person of RiMEA 7: its group's speed range (m/s) and its measured free walking speed
/// (nullopt: not measured — it never crossed both lines).
struct SpeedRecord {
    std::int64_t id = 0;
    std::string group;
    double lo = 0, hi = 0;
    std::optional<double> speed;
};
/// RiMEA 7: every measured speed lies in its group's range, widened by `tolerance` m/s for the
/// measurement. Value: the largest distance (m/s) of a speed outside its range (0 when all are
/// inside). Fails when a speed is missing, or the list is empty.
Check speedsInRanges(const std::vector<SpeedRecord>& people, double tolerance = 0.02);

/// The crossing time (s) of a line x = `line` between two observations (t0, x0) and (t1, x1),
/// linearly interpolated; nullopt when the segment does not cross it (x0 < line <= x1).
std::optional<double> crossingTime(double t0, double x0, double t1, double x1, double line);

/// One person of RiMEA 10: the exit allocated to it and the exit it left by (nullopt: it did not
/// leave by an exit).
struct ExitRecord {
    std::int64_t id = 0;
    std::string allocated;
    std::optional<std::string> used;
};
/// RiMEA 10: everyone left, each by its allocated exit. Value: the number of people who did not
/// (0 passes). Fails on an empty list.
Check routeAllocation(const std::vector<ExitRecord>& people);

/// The specific flow (P/(m·s)) between the `first`-th and the `last`-th person out (1-based,
/// times sorted or not): (last − first) / (t_last − t_first) / width. nullopt when fewer than
/// `last` people left or the times coincide.
std::optional<double> specificFlow(std::vector<double> exitTimes, std::size_t first, std::size_t last, double width);
/// ISO 20414 / NIST maximum flow: the specific flow does not exceed `limit` (1.33 P/(m·s), the
/// IMO maximum for doors). No flow measured (nullopt) fails.
Check maximumFlow(std::optional<double> flow, double limit = 1.33);

}  // namespace chverify
