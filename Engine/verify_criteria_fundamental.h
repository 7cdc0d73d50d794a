// crowdhealth verify — the reference curves and error measures of the fundamental-diagram tests
// (RiMEA 4 and 16, validation against Weidmann and the SFPE/IMO hydraulic table), as plain
// functions of measured values (no simulation inside), unit-tested in
// Tests/verify_fundamental_test.cpp. The tests: verify_tests_fundamental.cpp,
// docs/verification/fundamental.md. Constants: shared/reference/VERIFICATION.md.
#pragma once

#include "verify_criteria.h"

#include <cstddef>
#include <utility>
#include <vector>

namespace chverify {

/// Weidmann (1993): v(ρ) = v0·(1 − exp(−γ·(1/ρ − 1/ρmax))) with v0 = 1.34 m/s, γ = 1.913 P/m²,
/// ρmax = 5.4 P/m². m/s; v0 for ρ <= 0, 0 from ρmax on (the formula turns negative there).
double weidmannSpeed(double density);

/// The SFPE hydraulic model for corridors and doors: Fs = k(1 − a·ρ)·ρ with k = 1.40 m/s,
/// a = 0.266 m²/P (P/(m·s)); 0 where the speed k(1 − aρ) would be negative (ρ > 1/a).
double sfpeSpecificFlow(double density);

/// IMO MSC.1/Circ.1238's corridor table of specific flow by density — (0, 0), (0.5, 0.65),
/// (1.9, 1.3), (3.2, 0.65), (3.5, 0.32), and 0.32 beyond 3.5 ("≥ 3.5") — interpolated linearly
/// between its rows. P/(m·s).
double imoSpecificFlow(double density);
/// The rows of that table (density P/m², specific flow P/(m·s)), for the figure.
const std::vector<std::pair<double, double>>& imoTable();

/// One point of a fundamental diagram measured in one run: the density the set-up asked for, the
/// density measured in the measuring area (mean over the records) and the mean walking speed of
/// the people inside it (m/s). `measured` false: nobody was ever inside.
struct FdPoint {
    double nominal = 0;
    double density = 0;
    double speed = 0;
    bool measured = false;
};

/// Root-mean-square difference between the measured speeds and Weidmann's speed at the measured
/// density, over the measured points (m/s). Validation: `pass` says only that there was something
/// to compare (at least one measured point); value NaN otherwise. The detail names the largest
/// deviation and where.
Check weidmannError(const std::vector<FdPoint>& points);

/// Root-mean-square difference between the measured specific flows ρ·v and the IMO table at the
/// measured density, over the measured points (P/(m·s)); `pass` and NaN as weidmannError. The
/// detail gives the model's largest specific flow against the table's 1.3 P/(m·s).
Check sfpeError(const std::vector<FdPoint>& points);

/// Start positions for `count` bodies of radius `radius` in a corridor [−length/2, length/2) ×
/// [−width/2, width/2] that is periodic in x: rows along the corridor, every other row shifted by
/// half a spacing, the number of rows chosen to keep bodies farthest apart (their centres at least
/// `radius` from the walls). Returns (x, y) pairs in row order; fewer than `count` only when
/// width < 2·radius (none then).
std::vector<std::pair<double, double>> corridorLattice(std::size_t count, double length, double width, double radius);
/// The smallest centre distance of corridorLattice's positions (across the period too), m;
/// +inf for fewer than two.
double smallestSpacing(const std::vector<std::pair<double, double>>& points, double length);

}  // namespace chverify
