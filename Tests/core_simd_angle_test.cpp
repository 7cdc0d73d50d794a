// CrowdHealth tests — simd::angleOf (Library/include/crowdhealth/core/simd.h), the vectorised
// atan2(y, x) for y ≥ 0 that the health layer uses for each pedestrian's turn per step: against
// std::atan2 over the whole plane's upper half, at the edges of its argument reduction, and on the
// turns between two unit headings; its table against long-double atan.
#define BOOST_TEST_MODULE core_simd_angle
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/simd.h"

#include <cmath>
#include <random>

// simd::DV passes by value to the test's helpers: no call crosses an ABI boundary.
#pragma GCC diagnostic ignored "-Wpsabi"

using namespace ch;

namespace {

/// About two ulp (an ulp is 1.1e-16 to 2.2e-16 of the result; the largest error seen, 4.4e-16,
/// is two ulp of a result just above a power of two).
constexpr double kBound = 5e-16;

double relativeError(double got, double want) {
    if (want == 0) return got == 0 ? 0.0 : 1.0;
    return std::abs(got - want) / std::abs(want);
}

/// The largest relative error of angleOf over the four lanes (y[l], x[l]) against std::atan2.
double worstOf(const double (&y)[4], const double (&x)[4]) {
    simd::DV vy, vx;
    for (int l = 0; l < 4; ++l) vy[l] = y[l], vx[l] = x[l];
    const simd::DV a = simd::angleOf(vy, vx);
    double worst = 0;
    for (int l = 0; l < 4; ++l) worst = std::max(worst, relativeError(a[l], std::atan2(y[l], x[l])));
    return worst;
}

}  // namespace

BOOST_AUTO_TEST_CASE(angle_table_holds_the_nearest_doubles) {
    for (int k = 0; k <= 8; ++k) BOOST_TEST(simd::kAtanEighths[k] == static_cast<double>(std::atan(k / 8.0L)), "k = " << k);
}

BOOST_AUTO_TEST_CASE(angle_matches_std_atan2_over_the_upper_half_plane) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0), e(-30.0, 30.0);
    double worst = 0;
    for (int n = 0; n < 200000; ++n) {
        // Points of every direction and of very different magnitudes.
        const double y[4] = {std::abs(u(rng)), std::abs(u(rng)) * std::exp2(e(rng)), std::abs(u(rng)), std::abs(u(rng)) * 1e-9};
        const double x[4] = {u(rng), u(rng) * std::exp2(e(rng)), u(rng) * 1e-9, u(rng)};
        worst = std::max(worst, worstOf(y, x));
    }
    BOOST_TEST_MESSAGE("largest relative error " << worst);
    BOOST_TEST(worst < kBound);
}

BOOST_AUTO_TEST_CASE(angle_is_accurate_at_the_edges_of_its_reduction) {
    // Where the nearest eighth changes (u = (k + ½)/8 and the doubles either side), at each eighth
    // itself, at u = 1 (y = |x|: the swap), and for x of either sign.
    double worst = 0;
    for (int k = 0; k < 8; ++k)
        for (const double sign : {1.0, -1.0}) {
            const double h = (k + 0.5) / 8;
            const double y[4] = {h, std::nextafter(h, 0.0), std::nextafter(h, 1.0), k / 8.0};
            const double x[4] = {sign, sign, sign, sign};
            worst = std::max(worst, worstOf(y, x));
            const double yy[4] = {1.0, sign > 0 ? 3.0 : 0.7, std::nextafter(1.0, 2.0), std::nextafter(1.0, 0.0)};
            const double xx[4] = {sign, 3.0 * sign, sign, sign};
            worst = std::max(worst, worstOf(yy, xx));
            // The mirrors, y > |x|: the ratio is |x|/y.
            const double my[4] = {1.0, 1.0, 1.0, 1.0};
            const double mx[4] = {sign * y[0], sign * y[1], sign * y[2], sign * y[3]};
            worst = std::max(worst, worstOf(my, mx));
        }
    BOOST_TEST_MESSAGE("largest relative error at the edges " << worst);
    BOOST_TEST(worst < kBound);
    // The axes: exact where std::atan2 is (0, and π/2, π as doubles).
    simd::DV y = {0.0, 2.0, 0.0, 0.0}, x = {3.0, 0.0, -3.0, 0.0};
    const simd::DV a = simd::angleOf(y, x);
    BOOST_TEST(a[0] == 0.0);
    BOOST_TEST(a[1] == std::atan2(2.0, 0.0));
    BOOST_TEST(a[2] == std::atan2(0.0, -3.0));
    BOOST_TEST(a[3] == 0.0);  // x = y = 0: 0, as std::atan2(0, +0)
}

BOOST_AUTO_TEST_CASE(angle_series_alone_is_within_about_one_ulp) {
    // u < 1/16: the nearest eighth is 0, no table entry; the series alone, with its last terms
    // mattering most at the top of the interval (v¹³/13 is 2.7e-16 of v at 1/16).
    double worst = 0;
    for (int n = 0; n < 4000; ++n) {
        const double u0 = 0.0624 + n * 2.5e-8;  // up to just below 1/16
        const double y[4] = {u0, u0 * 0.99, u0 * 0.999, u0 * 0.5};
        const double x[4] = {1.0, 1.0, 1.0, 1.0};
        worst = std::max(worst, worstOf(y, x));
    }
    BOOST_TEST_MESSAGE("largest relative error of the series alone " << worst);
    BOOST_TEST(worst < 2.5e-16);
}

BOOST_AUTO_TEST_CASE(angle_gives_the_turn_between_unit_headings) {
    // The health layer's use: |θ| = atan2(|h₀ × h₁|, h₀ · h₁) for unit headings h₀, h₁; turns from
    // 1e-12 rad to nearly π, either way round.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> dir(-3.14159, 3.14159), logTurn(-12.0, 0.497);
    double worst = 0;
    for (int n = 0; n < 100000; ++n) {
        double y[4], x[4];
        for (int l = 0; l < 4; ++l) {
            const double a0 = dir(rng), turn = (l % 2 ? -1 : 1) * std::pow(10.0, logTurn(rng));
            const double h0x = std::cos(a0), h0y = std::sin(a0), h1x = std::cos(a0 + turn), h1y = std::sin(a0 + turn);
            y[l] = std::abs(h0x * h1y - h0y * h1x);
            x[l] = h0x * h1x + h0y * h1y;
        }
        worst = std::max(worst, worstOf(y, x));
    }
    BOOST_TEST_MESSAGE("largest relative error on turns " << worst);
    BOOST_TEST(worst < kBound);
}
