// CrowdHealth tests — SocialForcesAvoidance's SIMD pair loop (issue 20): its exponential
// against std::exp, the whole agent force against the scalar pair force summed in list order,
// for every combination of the model's switches and lists of every length modulo the lane count,
// and its generic, AVX2 and AVX-512 builds against each other and against their own terms added
// in list order, bit for bit.
#define BOOST_TEST_MODULE policies_social_forces_simd
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "SocialForcesAvoidance.h"
#include "SocialForcesSimd.h"

#include <cmath>
#include <cstring>
#include <random>

using namespace ch;

namespace {

double relativeError(double got, double want) { return std::abs(got - want) / std::abs(want); }

/// exp of four arguments through simd::expNonPositive (in the first four lanes; the others 0).
simd::DV exp4(double a, double b, double c, double d) {
    simd::DV x = simd::splat(0.0);
    x[0] = a, x[1] = b, x[2] = c, x[3] = d;
    return simd::expNonPositive(x);
}

}  // namespace

BOOST_AUTO_TEST_CASE(exp_matches_std_exp_to_about_one_ulp) {
    // Dense random arguments over the whole range, and the social force's usual one (−b/σ for b up
    // to ~10 m, σ = 0.3 m: [−35, 0]). glibc's exp is within an ulp of e^x; ours within about one
    // more (the table's 2^{j/16} and the last multiply-add each round once).
    constexpr double kBound = 3e-16;  // 1.35 ulp at 1 (the largest seen: 2.2e-16 = 1 ulp)
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> wide(-708.0, 0.0), usual(-35.0, 0.0);
    double worst = 0;
    for (int k = 0; k < 200000; ++k) {
        const double x[4] = {wide(rng), usual(rng), usual(rng), -std::ldexp(usual(rng), -30)};
        const simd::DV e = exp4(x[0], x[1], x[2], x[3]);
        for (int l = 0; l < 4; ++l) worst = std::max(worst, relativeError(e[l], std::exp(x[l])));
    }
    BOOST_TEST_MESSAGE("largest relative error " << worst);
    BOOST_TEST(worst < kBound);
    // Where rounding to K = round(16x / ln 2) changes (halfway points, and the doubles either side),
    // and at K·ln 2/16 itself (r ≈ 0: the table's entry alone), for every K of the range: all 16
    // table entries, every exponent.
    constexpr double kLn2Over16 = 0.69314718055994530942 / 16;
    double worstEdge = 0;
    for (int k = -16342; k <= 0; ++k) {  // (K − 0.5)·ln 2/16 ≥ −708
        const double x = (k - 0.5) * kLn2Over16, at = k * kLn2Over16;
        const simd::DV e = exp4(x, std::nextafter(x, 0.0), std::nextafter(x, -1.0), at);
        worstEdge = std::max({worstEdge, relativeError(e[0], std::exp(x)),
                              relativeError(e[1], std::exp(std::nextafter(x, 0.0))),
                              relativeError(e[2], std::exp(std::nextafter(x, -1.0))), relativeError(e[3], std::exp(at))});
    }
    BOOST_TEST_MESSAGE("largest relative error at the edges of the reduction " << worstEdge);
    BOOST_TEST(worstEdge < kBound);
    const simd::DV ends = exp4(0.0, -0.0, -708.0, -709.0);
    BOOST_TEST(ends[0] == 1.0);
    BOOST_TEST(ends[1] == 1.0);
    BOOST_TEST(relativeError(ends[2], std::exp(-708.0)) < kBound);
    BOOST_TEST(ends[3] == 0.0);  // below −708: 0 (e^−709 ≈ 1.2e-308, the edge of the normal range)
    // Just above −708, where 2^m is smallest (m = −1022): still normal numbers, still accurate.
    for (double x = -708.0; x < -707.0; x += 1.0 / 64) BOOST_TEST(relativeError(exp4(x, 0, 0, 0)[0], std::exp(x)) < kBound);
}

BOOST_AUTO_TEST_CASE(exp_table_holds_the_nearest_doubles) {
    // 2^{j/16} in long double (64-bit significand) rounded to double: the nearest double, unless
    // one of them lay within 2^-64 of a halfway point (none does; the table was made with 50 digits).
    for (int j = 0; j < 16; ++j) BOOST_TEST(simd::kExp2Sixteenths[j] == static_cast<double>(std::exp2l(j / 16.0L)), "j = " << j);
}

namespace {

/// A crowd of n + 1 agents round agent 0 (a few in contact with it, some beyond range 5 m), and
/// SocialForcesAvoidance with the given switches: returns acceleration() and the scalar reference,
/// Σ_j w_j pairForce(R_j, s_j) in list order, divided by the mass.
/// With `atRange`, the first four neighbours sit at exactly the range, 5 m (|(3, 4)| = 5 exactly).
std::pair<Vec2, Vec2> forceAndReference(int n, bool relative, bool cutoff, bool atRest, std::uint64_t seed,
                                        bool atRange = false) {
    test::Frame f;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    f.add(Vec2(0, 0), Vec2(10, 3), atRest ? Vec2(0, 0) : Vec2(1.1, 0.2));
    if (atRange)
        for (const Vec2& p : {Vec2(3, 4), Vec2(-5, 0), Vec2(0, -5), Vec2(4, -3)}) f.add(p, Vec2(u(rng), 9), Vec2(u(rng), u(rng)));
    for (int k = 0; k < n; ++k) {
        // Most within 5 m, one in five in contact (closer than 0.6 m), a few beyond 5 m.
        const double r = k % 5 == 0 ? 0.1 + 0.45 * std::abs(u(rng)) : 0.7 + 5.0 * std::abs(u(rng));
        const double a = 3.2 * u(rng);
        f.add(Vec2(r * std::cos(a), r * std::sin(a)), Vec2(10 * u(rng), 10 * u(rng)), Vec2(u(rng), u(rng)));
    }
    f.agents.mass[0] = 1.3;
    auto sf = test::make("SocialForcesAvoidance",
                         {{"range", 5}, {"otherVelocity", relative ? 1 : 0}, {"contactCutoff", cutoff ? 1 : 0}});
    auto& force = dynamic_cast<SocialForcesAvoidance&>(*sf);
    const StepContext ctx = f.context();
    force.prepare(ctx);
    const test::OwnedQuery q = f.query(0);
    const Vec2 got = force.acceleration(q, ctx);

    // The reference: the scalar pair force (pairForce with the other's speed and direction) and
    // the field-of-view weight, summed in list order.
    Vec2 heading = normalisedOrZero(q.velocity);
    if (heading.squaredNorm() == 0) heading = normalisedOrZero(q.prefVelocity);
    const double cosFov = std::cos(100.0 * kPi / 180.0);
    Vec2 sum(0, 0);
    for (const NeighbourAgent& nb : q.agents) {
        const std::size_t j = static_cast<std::size_t>(nb.index);
        const double d = nb.distance();
        if (d > 5.0 || (cutoff && d <= q.radius + f.agents.radius[j])) continue;
        Vec2 fj;
        if (relative) {
            // (v_β − v_α)Δt as a speed along a direction: the same step up to rounding.
            const Vec2 s = 2.0 * (f.agents.vel[j] - q.velocity);
            fj = force.pairForce(-nb.offset, s.norm() / 2.0, normalisedOrZero(s));
        } else {
            fj = force.pairForce(-nb.offset, f.agents.vel[j].norm(), normalisedOrZero(f.agents.prefVel[j]));
        }
        const bool inView = heading.squaredNorm() == 0 || heading.dot(nb.offset) >= cosFov * d;
        sum += (inView ? 1.0 : 0.5) * fj;
    }
    return {got, sum / 1.3};
}

}  // namespace

BOOST_AUTO_TEST_CASE(simd_force_equals_scalar_pair_sum) {
    // Lists of every length modulo 8 (the lanes) and a long one; each switch combination.
    for (int n : {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 15, 16, 17, 57})
        for (bool relative : {false, true})
            for (bool cutoff : {false, true})
                for (bool atRest : {false, true}) {
                    const auto [got, want] = forceAndReference(n, relative, cutoff, atRest, 100 + n);
                    BOOST_TEST_CONTEXT("n " << n << " relative " << relative << " cutoff " << cutoff << " at rest "
                                            << atRest) {
                        BOOST_TEST(std::isfinite(got.x()));
                        BOOST_TEST(std::isfinite(got.y()));
                        const double scale = std::max(1e-300, want.norm());
                        BOOST_TEST((got - want).norm() <= 1e-13 * scale);
                        if (n >= 4) BOOST_TEST(want.norm() > 0);  // the comparison is not 0 == 0
                    }
                }
}

BOOST_AUTO_TEST_CASE(every_pair_loop_build_gives_the_same_bits) {
    // The generic (SSE2), AVX2 and AVX-512 builds of the pair loop do the same operations lane by
    // lane and sum in list order: bit for bit the same force, for every list length modulo the
    // lanes (2, 4 and 8) and every switch. Builds this CPU cannot run are skipped (and said so).
    const int best = SocialForcesAvoidance::pairLoopPath();
    BOOST_TEST(!SocialForcesAvoidance::setPairLoopPath(3));  // no such build
    BOOST_TEST(!SocialForcesAvoidance::setPairLoopPath(-1));
    BOOST_TEST(SocialForcesAvoidance::pairLoopPath() == best);
    int compared = 0;
    for (int path : {1, 2}) {
        if (!SocialForcesAvoidance::setPairLoopPath(path)) {
            BOOST_TEST_MESSAGE("pair-loop build " << path << " not run: this CPU lacks it");
            continue;
        }
        ++compared;
        for (int n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 15, 16, 17, 23, 24, 25, 57, 80})
            for (bool relative : {false, true})
                for (bool cutoff : {false, true})
                    for (bool atRest : {false, true}) {
                        BOOST_REQUIRE(SocialForcesAvoidance::setPairLoopPath(path));
                        // Odd lengths also with four neighbours at exactly the range (the ≤ test).
                        const bool atRange = n % 2 == 1;
                        const Vec2 got = forceAndReference(n, relative, cutoff, atRest, 500 + n, atRange).first;
                        BOOST_REQUIRE(SocialForcesAvoidance::setPairLoopPath(0));
                        const Vec2 generic = forceAndReference(n, relative, cutoff, atRest, 500 + n, atRange).first;
                        BOOST_TEST_CONTEXT("build " << path << " n " << n << " relative " << relative << " cutoff "
                                                    << cutoff << " at rest " << atRest) {
                            BOOST_TEST(std::memcmp(&got, &generic, sizeof got) == 0);
                            if (n >= 4) BOOST_TEST(generic.norm() > 0);  // not 0 == 0
                        }
                    }
    }
    BOOST_TEST_MESSAGE("builds compared with the generic one: " << compared);
    BOOST_TEST(SocialForcesAvoidance::setPairLoopPath(best));
}

namespace {

/// Agent 0's SocialForcesAvoidance acceleration (mass 1, no walls: the pair loop's sum itself)
/// among the agents at `places` with velocities `vels` (agent 0 first), with the given switches.
Vec2 pairSum(const std::vector<Vec2>& places, const std::vector<Vec2>& vels, bool relative, bool cutoff) {
    test::Frame f;
    for (std::size_t k = 0; k < places.size(); ++k) f.add(places[k], places[k] + Vec2(10, 3), vels[k]);
    f.agents.mass[0] = 1.0;
    auto sf = test::make("SocialForcesAvoidance",
                         {{"range", 5}, {"otherVelocity", relative ? 1 : 0}, {"contactCutoff", cutoff ? 1 : 0}});
    const StepContext ctx = f.context();
    sf->prepare(ctx);
    const test::OwnedQuery q = f.query(0);
    return dynamic_cast<SocialForcesAvoidance&>(*sf).acceleration(q, ctx);
}

}  // namespace

BOOST_AUTO_TEST_CASE(every_build_adds_the_pair_terms_in_list_order) {
    // The force of a whole list equals, bit for bit, the terms of its neighbours one at a time
    // (each computed by the same build in a list of one) added in list order from +0: in every
    // build, whatever its lanes and blocks. (The comparison with the scalar pair force above has
    // a tolerance, so it cannot see the order of the additions.)
    const int best = SocialForcesAvoidance::pairLoopPath();
    for (int path : {0, 1, 2}) {
        if (!SocialForcesAvoidance::setPairLoopPath(path)) {
            BOOST_TEST_MESSAGE("pair-loop build " << path << " not run: this CPU lacks it");
            continue;
        }
        for (int n : {2, 3, 5, 8, 9, 17, 24, 25, 50})
            for (bool relative : {false, true})
                for (bool cutoff : {false, true}) {
                    std::mt19937_64 rng(900 + n);
                    std::uniform_real_distribution<double> u(-1.0, 1.0);
                    std::vector<Vec2> places = {Vec2(0, 0)}, vels = {Vec2(1.1, 0.2)};
                    for (int k = 0; k < n; ++k) {
                        // Pairs of almost opposite neighbours: their terms nearly cancel, so the
                        // order of the additions shows in the last bits.
                        const double r = 0.5 + 4.0 * std::abs(u(rng)), a = 3.2 * u(rng);
                        const Vec2 p(r * std::cos(a), r * std::sin(a));
                        places.push_back(k % 2 == 0 ? p : Vec2(-places.back() * (1.0 + 1e-3 * u(rng))));
                        vels.push_back(Vec2(u(rng), u(rng)));
                    }
                    const Vec2 whole = pairSum(places, vels, relative, cutoff);
                    double fx = 0, fy = 0;
                    for (int k = 1; k <= n; ++k) {
                        const Vec2 term = pairSum({places[0], places[static_cast<std::size_t>(k)]},
                                                  {vels[0], vels[static_cast<std::size_t>(k)]}, relative, cutoff);
                        fx += term.x();
                        fy += term.y();
                    }
                    const Vec2 inOrder(fx, fy);
                    BOOST_TEST_CONTEXT("build " << path << " n " << n << " relative " << relative << " cutoff " << cutoff) {
                        BOOST_TEST(whole.norm() > 0);
                        BOOST_TEST(std::memcmp(&whole, &inOrder, sizeof whole) == 0);
                    }
                }
    }
    BOOST_TEST(SocialForcesAvoidance::setPairLoopPath(best));
}
