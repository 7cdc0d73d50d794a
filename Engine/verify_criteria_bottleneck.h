// crowdhealth verify — the criteria of the bottleneck tests (RiMEA 12 a-d, validation against
// Kretz et al. 2006) as plain functions of measured values (no simulation inside), unit-tested on
// their own in Tests/verify_bottleneck_test.cpp. The tests: verify_tests_bottleneck.cpp and
// docs/verification/bottleneck.md.
#pragma once

#include "verify_criteria.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace chverify {

/// The flow (P/s) from the `first`-th to the `last`-th person out (1-based; times sorted or not):
/// (last − first) / (t_last − t_first). nullopt when fewer than `last` people left or the times
/// coincide.
std::optional<double> passageFlow(std::vector<double> exitTimes, std::size_t first, std::size_t last);

/// The largest mean of `samples` over `window` consecutive samples (a sliding window; the whole
/// series when it is shorter). nullopt for an empty series or a zero window.
std::optional<double> peakMovingMean(const std::vector<double>& samples, std::size_t window);

/// RiMEA 12b: the flow through the long bottleneck is lower than through the short one. Value:
/// flow(long) − flow(short) (P/s; negative passes). Fails when either flow is missing.
Check longerIsSlower(std::optional<double> flowShort, std::optional<double> flowLong);

/// RiMEA 12c: a jam before the first bottleneck only: the peak density (P/m²) in front of the
/// first exceeds `jam` and the peak in front of the second does not. Value: the peak density in
/// front of the second. `jam` = 2.17 P/m²: Fruin's level of service F (under 0.46 m² per person).
Check jamOnlyBeforeFirst(std::optional<double> peakFirst, std::optional<double> peakSecond, double jam = 2.17);

/// One width of RiMEA 12d or of a flow-width series: the width (m) and the flow measured (P/s;
/// nullopt: not measured — too few got through).
struct WidthFlow {
    double width = 0;
    std::optional<double> flow;
};
/// RiMEA 12d: the flow rises strictly with the width (any order in; sorted by width inside).
/// Value: the smallest rise between neighbouring widths (P/s). Fails when a flow is missing, fewer
/// than two widths are given, or the flow does not rise.
Check flowRisesWithWidth(std::vector<WidthFlow> series);

/// Experimental flows (P/s) at one width (m).
struct MeasuredWidth {
    double width = 0;
    std::vector<double> flows;
};
/// Kretz, Grünebohm & Schreckenberg 2006 (J. Stat. Mech. P10014): bottleneck flow by width, every
/// run, as in ../shared/reference/VERIFICATION.md.
const std::vector<MeasuredWidth>& kretz2006();

/// Validation: the root mean square of (simulated − mean of the experimental flows) over the
/// widths both have (P/s; a quick run simulates only some). A width the simulation has no flow
/// for (nobody, or too few, got through) counts as 0 P/s. nullopt when no width is in both.
std::optional<double> flowRmse(const std::vector<WidthFlow>& simulated, const std::vector<MeasuredWidth>& data);
/// The mean over the widths both have of simulated / mean experimental flow (missing flows count
/// as 0); nullopt as flowRmse.
std::optional<double> meanFlowRatio(const std::vector<WidthFlow>& simulated, const std::vector<MeasuredWidth>& data);

/// RiMEA 12 as one row: every sub-case's Check must pass. Value: how many fail. Detail: the
/// failing sub-cases' details first, then the others, joined by "; ". Fails on an empty list.
Check allSubcases(const std::vector<Check>& parts);

}  // namespace chverify
