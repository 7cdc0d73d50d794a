// core/rank_index.h: RankIndex::countBelow(x) is the number of values below x — what
// std::lower_bound gives on the values sorted — for every x at, between, beside, below and above
// the values, on spread, crowded, negative, zero, infinite and subnormal values, and with its
// storage reused from set to set.
#define BOOST_TEST_MODULE core_rank_index
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/rank_index.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <vector>

using namespace ch;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Every query a caller could make of `v`: each value, its neighbours one ulp away, the midpoints
/// of consecutive values, far below, far above, ±∞ and NaN. Checks countBelow against
/// std::lower_bound on a sorted copy. Returns the mismatches.
std::size_t mismatches(const RankIndex& index, const std::vector<double>& v) {
    std::vector<double> expected = v;
    std::sort(expected.begin(), expected.end());
    std::vector<double> queries = {-kInf, kInf, -1e300, 1e300, 0.0, -0.0, std::nan("")};
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const double x = expected[i];
        queries.push_back(x);
        queries.push_back(std::nextafter(x, kInf));
        queries.push_back(std::nextafter(x, -kInf));
        if (i + 1 < expected.size() && std::isfinite(x) && std::isfinite(expected[i + 1]))
            queries.push_back(x + (expected[i + 1] - x) / 2);
    }
    std::size_t wrong = 0;
    for (const double x : queries) {
        const std::size_t want = static_cast<std::size_t>(std::lower_bound(expected.begin(), expected.end(), x) - expected.begin());
        if (index.countBelow(x) != want) ++wrong;
    }
    BOOST_TEST_REQUIRE(index.size() == expected.size());
    return wrong;
}

std::size_t check(const std::vector<double>& v) {
    RankIndex index;
    index.assign(v);
    return mismatches(index, v);
}

}  // namespace

BOOST_AUTO_TEST_CASE(counts_below_spread_distances_as_lower_bound) {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> metres(0.0, 300.0);
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{17}, std::size_t{5000},
                                std::size_t{20011}}) {
        std::vector<double> v(n);
        for (double& x : v) x = metres(rng);
        BOOST_TEST(check(v) == 0u, n << " uniform distances");
    }
}

BOOST_AUTO_TEST_CASE(counts_below_crowded_and_special_values_as_lower_bound) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> wide(-1e6, 1e6);
    std::uniform_int_distribution<int> pick(0, 9);
    const double tiny = std::numeric_limits<double>::denorm_min();
    std::vector<double> v(4000);
    for (double& x : v) {
        switch (pick(rng)) {
            case 0: x = -1.0; break;
            case 1: x = 0.0; break;
            case 2: x = -0.0; break;
            case 3: x = kInf; break;
            case 4: x = -kInf; break;
            case 5: x = tiny * pick(rng); break;
            case 6: x = -tiny * pick(rng); break;
            default: x = wide(rng);
        }
    }
    BOOST_TEST(check(v) == 0u, "mixed signs and specials");
    // A queue packed in front of a door, with a few people far behind it: most values share a
    // handful of buckets (searched, not scanned).
    std::vector<double> packed(3000);
    std::uniform_real_distribution<double> near(2.0, 2.0 + 1e-6);
    for (double& x : packed) x = near(rng);
    packed[10] = 250.0, packed[20] = 180.0, packed[30] = kInf;
    BOOST_TEST(check(packed) == 0u, "values within 1e-6 and three outliers");
    // Every finite value the same (no spread to divide by), with and without infinities.
    std::vector<double> same(777, 3.25);
    BOOST_TEST(check(same) == 0u, "all equal");
    same[5] = kInf, same[6] = -kInf;
    BOOST_TEST(check(same) == 0u, "all equal but two infinities");
    BOOST_TEST(check(std::vector<double>(50, kInf)) == 0u, "all +inf");
    // A spread of a few subnormals (its inverse overflows).
    BOOST_TEST(check({tiny, 2 * tiny, tiny, 3 * tiny, 0.0}) == 0u, "subnormal spread");
    // Sorted and reversed inputs, with repeats.
    std::vector<double> up(1000);
    for (std::size_t i = 0; i < up.size(); ++i) up[i] = std::floor(static_cast<double>(i) / 3) - 150.0;
    BOOST_TEST(check(up) == 0u, "sorted with repeats");
    std::reverse(up.begin(), up.end());
    BOOST_TEST(check(up) == 0u, "reversed with repeats");
}

BOOST_AUTO_TEST_CASE(storage_is_reused_across_sets) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> metres(-50.0, 50.0);
    RankIndex index;
    for (const std::size_t n : {std::size_t{3000}, std::size_t{500}, std::size_t{0}, std::size_t{8000}, std::size_t{1}}) {
        std::vector<double> v(n);
        for (double& x : v) x = metres(rng);
        index.assign(v);  // storage left over from a longer or shorter set
        BOOST_TEST(mismatches(index, v) == 0u, n << " values");
    }
}

BOOST_AUTO_TEST_CASE(a_set_given_in_parts_counts_as_the_whole) {
    // Navigation gathers each exit's distances on every thread apart and indexes the parts at once:
    // every split (empty parts, one value, the extremes alone in a part, crowded values spread over
    // the parts) must count as the values together.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> metres(0.0, 120.0);
    std::uniform_int_distribution<int> cut(0, 4);
    RankIndex index;
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{9}, std::size_t{2500}}) {
        std::vector<double> v(n);
        for (double& x : v) x = metres(rng);
        if (n > 8)
            for (std::size_t k = 0; k < n; k += 3) v[k] = 40.0;  // a crowded bucket, sorted and searched
        for (int split = 0; split < 5; ++split) {
            // Parts of random lengths, some empty; split 4 puts the smallest and the largest value
            // each alone in a part of its own, last.
            std::vector<double> w = v;
            std::vector<std::vector<double>> parts(5);
            if (split == 4 && n > 1) {
                std::sort(w.begin(), w.end());
                parts[3] = {w.back()};
                parts[4] = {w.front()};
                w = std::vector<double>(w.begin() + 1, w.end() - 1);
                std::shuffle(w.begin(), w.end(), rng);
            }
            std::size_t at = 0;
            for (int p = 0; p < 3 && at < w.size(); ++p) {
                const std::size_t len = std::min(w.size() - at, static_cast<std::size_t>(cut(rng)) * w.size() / 4);
                parts[static_cast<std::size_t>(p)].assign(w.begin() + static_cast<std::ptrdiff_t>(at), w.begin() + static_cast<std::ptrdiff_t>(at + len));
                at += len;
            }
            parts[2].insert(parts[2].end(), w.begin() + static_cast<std::ptrdiff_t>(at), w.end());
            std::vector<std::span<const double>> spans;
            for (const auto& p : parts) spans.emplace_back(p);
            index.assign(spans);
            BOOST_TEST(mismatches(index, v) == 0u, n << " values, split " << split);
        }
    }
}
