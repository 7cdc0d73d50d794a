// The reference curves and errors of the fundamental-diagram tests
// (Engine/verify_criteria_fundamental.h): Weidmann's and the SFPE/IMO values as published
// (shared/reference/VERIFICATION.md), each error just inside and outside a known value, and the
// lattice the crowds start on. docs/verification/fundamental.md lists the mutations they catch.
#define BOOST_TEST_MODULE verify_fundamental
#include <boost/test/unit_test.hpp>

#include "verify_criteria_fundamental.h"

#include <cmath>

using namespace chverify;

BOOST_AUTO_TEST_CASE(weidmann_speeds_as_published) {
    // VERIFICATION.md: ρ 0.5 → 1.30 m/s; 1 → 1.06; 2 → 0.61; 3 → 0.33; 4 → 0.16; 5 → 0.04.
    const double rho[] = {0.5, 1, 2, 3, 4, 5}, v[] = {1.30, 1.06, 0.61, 0.33, 0.16, 0.04};
    for (int k = 0; k < 6; ++k) BOOST_TEST(std::abs(weidmannSpeed(rho[k]) - v[k]) < 0.006, "rho " << rho[k]);
    BOOST_TEST(weidmannSpeed(0) == 1.34);
    BOOST_TEST(weidmannSpeed(5.4) == 0.0);
    BOOST_TEST(weidmannSpeed(6) == 0.0, "0 beyond rho_max, not negative");
    BOOST_TEST(weidmannSpeed(5.39) > 0.0);
    // Largest specific flow 1.22 P/(m·s) at about 1.75 P/m².
    double best = 0, at = 0;
    for (double r = 0.5; r < 5; r += 0.01)
        if (r * weidmannSpeed(r) > best) best = r * weidmannSpeed(r), at = r;
    BOOST_TEST(std::abs(best - 1.22) < 0.01);
    BOOST_TEST(std::abs(at - 1.75) < 0.06);
}

BOOST_AUTO_TEST_CASE(sfpe_line_and_imo_table) {
    // SFPE: Fs = 1.40 (1 − 0.266 D) D, peak ≈ 1.32 at D ≈ 1.9; 0 once the speed would be negative.
    BOOST_TEST(std::abs(sfpeSpecificFlow(1.9) - 1.4 * (1 - 0.266 * 1.9) * 1.9) < 1e-12);
    BOOST_TEST(std::abs(sfpeSpecificFlow(1.88) - 1.32) < 0.01);
    BOOST_TEST(sfpeSpecificFlow(3.75) > 0.0);
    BOOST_TEST(sfpeSpecificFlow(3.77) == 0.0);
    BOOST_TEST(sfpeSpecificFlow(0) == 0.0);
    // IMO: the rows themselves, halfway between two rows, and 0.32 from 3.5 on.
    BOOST_TEST(imoSpecificFlow(0) == 0.0);
    BOOST_TEST(std::abs(imoSpecificFlow(0.5) - 0.65) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(1.9) - 1.3) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(3.2) - 0.65) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(3.5) - 0.32) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(1.2) - 0.975) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(3.35) - 0.485) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(6) - 0.32) < 1e-12);
    BOOST_TEST(std::abs(imoSpecificFlow(0.25) - 0.325) < 1e-12);
}

BOOST_AUTO_TEST_CASE(weidmann_error_is_the_rmse_at_the_measured_density) {
    // On the curve: 0. Each point 0.1 m/s above: 0.1. Weidmann is read at the measured density,
    // not at the one set.
    std::vector<FdPoint> on = {{1, 2, weidmannSpeed(2), true}, {3, 3, weidmannSpeed(3), true}};
    BOOST_TEST(weidmannError(on).value < 1e-12);
    BOOST_TEST(weidmannError(on).pass);
    std::vector<FdPoint> above = {{1, 1, weidmannSpeed(1) + 0.1, true}, {2, 2, weidmannSpeed(2) - 0.1, true}};
    BOOST_TEST(std::abs(weidmannError(above).value - 0.1) < 1e-12);
    // 0.3 and 0.4 off: sqrt((0.09 + 0.16) / 2).
    std::vector<FdPoint> two = {{1, 1, weidmannSpeed(1) + 0.3, true}, {4, 4, weidmannSpeed(4) - 0.4, true}};
    BOOST_TEST(std::abs(weidmannError(two).value - std::sqrt(0.125)) < 1e-12);
    BOOST_TEST(weidmannError(two).detail.find("-0.40") != std::string::npos, weidmannError(two).detail);
    // A point nobody was measured at does not count; none at all: no value.
    two.push_back({6, 0, 5.0, false});
    BOOST_TEST(std::abs(weidmannError(two).value - std::sqrt(0.125)) < 1e-12);
    const Check none = weidmannError({{1, 0, 0, false}});
    BOOST_TEST(!none.pass);
    BOOST_TEST(std::isnan(none.value));
    BOOST_TEST(!weidmannError({}).pass);
}

BOOST_AUTO_TEST_CASE(sfpe_error_is_the_rmse_of_density_times_speed) {
    // At 1.9 P/m² and 1.3/1.9 m/s the flow is the table's 1.3: no error; 0.2 m/s more: 0.38.
    std::vector<FdPoint> on = {{2, 1.9, 1.3 / 1.9, true}};
    BOOST_TEST(sfpeError(on).value < 1e-12);
    std::vector<FdPoint> off = {{2, 1.9, 1.3 / 1.9 + 0.2, true}};
    BOOST_TEST(std::abs(sfpeError(off).value - 0.38) < 1e-12);
    // Above 3.5 P/m² the table's 0.32: a model at 5 P/m² and 0.064 m/s meets it.
    std::vector<FdPoint> dense = {{5, 5, 0.064, true}, {0.5, 0.5, 1.3, true}};
    BOOST_TEST(sfpeError(dense).value < 1e-12);
    BOOST_TEST(sfpeError(dense).detail.find("peak flow 0.65") != std::string::npos, sfpeError(dense).detail);
    BOOST_TEST(!sfpeError({{1, 0, 0, false}}).pass);
    BOOST_TEST(std::isnan(sfpeError({}).value));
}

BOOST_AUTO_TEST_CASE(lattice_keeps_bodies_apart_and_inside) {
    const double L = 8, W = 3, r = 0.2;
    for (double rho : {0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0}) {
        const std::size_t n = static_cast<std::size_t>(std::lround(rho * L * W));
        const auto p = corridorLattice(n, L, W, r);
        BOOST_TEST(p.size() == n, "rho " << rho);
        for (const auto& [x, y] : p) {
            BOOST_TEST(x >= -0.5 * L);
            BOOST_TEST(x < 0.5 * L);
            BOOST_TEST(std::abs(y) <= 0.5 * W - r + 1e-12);
        }
        // 6 P/m² in a 3 m corridor still fits 0.4 m bodies without overlap.
        BOOST_TEST(smallestSpacing(p, L) >= 2 * r, "rho " << rho << ": " << smallestSpacing(p, L));
    }
    // More than fits: the spacing falls below a body and smallestSpacing says so.
    BOOST_TEST(smallestSpacing(corridorLattice(200, L, W, r), L) < 2 * r);
    // A corridor one body wide: one row on the axis, evenly spaced across the period.
    const auto row = corridorLattice(20, 20, 2 * r, r);
    BOOST_TEST(row.size() == 20u);
    for (const auto& [x, y] : row) BOOST_TEST(y == 0.0);
    BOOST_TEST(std::abs(smallestSpacing(row, 20) - 1.0) < 1e-12);
    // The period counts: two bodies at the ends of the corridor are neighbours.
    BOOST_TEST(std::abs(smallestSpacing({{-3.9, 0}, {3.9, 0}}, 8) - 0.2) < 1e-12);
    BOOST_TEST(corridorLattice(5, L, 0.3, r).empty(), "narrower than a body");
    BOOST_TEST(corridorLattice(0, L, W, r).empty());
}
