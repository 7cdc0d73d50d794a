// crowdhealth verify — the pass criteria of the evacuation family (RiMEA 8, 9, 11, 14, 15 and ISO
// dynamic exit availability) as plain functions of measured values, no simulation inside, so that
// each can be unit-tested and mutated on its own (Tests/verify_evacuation_test.cpp). The tests:
// verify_tests_evacuation.cpp and docs/verification/evacuation.md.
#pragma once

#include "verify_criteria.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace chverify {

/// RiMEA 8: the evacuation times (s) of runs whose parameter rises from the first to the last
/// (e.g. preferred speeds 0.5, 0.75, 1.0 m/s) fall strictly at every step. A run in which not
/// everyone left (nullopt) fails. Value: the first time over the last (how much the parameter's
/// range changes the time); NaN when a time is missing. Fails on fewer than two runs.
Check timesDecrease(const std::vector<std::optional<double>>& times);

/// RiMEA 9: the evacuation time with fewer exits over the time with all of them (s / s) lies in
/// [lo, hi] (RiMEA: about 2 with two of four exits; JuPedSim accepts 1.6-2.4). A run in which
/// not everyone left (nullopt) fails. Value: the ratio (NaN when a time is missing).
Check evacuationTimeRatio(std::optional<double> allExits, std::optional<double> fewerExits, double lo = 1.6,
                          double hi = 2.4);

/// RiMEA 11: everyone left (nearer + farther == total), more than half of them by the nearer exit,
/// and at least one by the farther. Value: the share by the nearer exit (%). Fails when total is 0.
Check nearerExitMajority(std::size_t nearer, std::size_t farther, std::size_t total);

/// RiMEA 15: the time round the corner lies between the times of the two straight corridors
/// (inclusive; whichever of them is shorter). A missing time fails. Value: where the corner time
/// lies between the two, (corner - short) / (long - short): in [0, 1] passes; NaN when a time is
/// missing or the straight times are equal.
Check cornerBetweenStraights(std::optional<double> shortStraight, std::optional<double> corner,
                             std::optional<double> longStraight);

/// One person of the dynamic-exits test: the exit it left by and when (nullopt: it did not leave
/// by an exit).
struct ExitTime {
    std::int64_t id = 0;
    std::optional<std::string> exit;
    double time = 0;
};
/// ISO 20414 / NIST dynamic exit availability: nobody left by the exit `closed` later than
/// `closeTime` + `grace` (s; the grace covers the step in which the closing applies), and everyone
/// left by some exit. Value: the number of people out by the closed exit after closeTime + grace
/// (0 passes). Fails on an empty list.
Check closedExitUnused(const std::vector<ExitTime>& people, const std::string& closed, double closeTime, double grace);

}  // namespace chverify
