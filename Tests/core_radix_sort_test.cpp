// core/radix_sort.h: sortDoubles puts doubles in std::sort's order — negative, zero of both signs,
// positive, infinite, subnormal, repeated — for lengths on both sides of its std::sort cut-off,
// and reuses its working storage.
#define BOOST_TEST_MODULE core_radix_sort
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/radix_sort.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

using namespace ch;

namespace {

/// Equal as std::sort leaves them: the same values at every place (a zero's sign may differ).
void checkSortedLikeStd(std::vector<double> v, const char* what) {
    std::vector<double> expected = v;
    std::sort(expected.begin(), expected.end());
    std::vector<std::uint64_t> keys, scratch;
    sortDoubles(v, keys, scratch);
    BOOST_TEST_REQUIRE(v.size() == expected.size(), what);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < v.size(); ++i)
        if (!(v[i] == expected[i])) ++wrong;
    BOOST_TEST(wrong == 0u, what << ": " << wrong << " of " << v.size() << " places differ");
    // Not a value's bits changed on the way through the keys (beyond a zero's sign).
    std::vector<std::uint64_t> in, out;
    for (double x : expected) in.push_back(std::bit_cast<std::uint64_t>(x == 0 ? 0.0 : x));
    for (double x : v) out.push_back(std::bit_cast<std::uint64_t>(x == 0 ? 0.0 : x));
    BOOST_TEST((in == out), what);
}

}  // namespace

BOOST_AUTO_TEST_CASE(random_distances_sort_as_std_sort) {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> metres(0.0, 300.0);
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{255}, std::size_t{256}, std::size_t{257},
                                std::size_t{5000}, std::size_t{20011}}) {
        std::vector<double> v(n);
        for (double& x : v) x = metres(rng);
        checkSortedLikeStd(v, "uniform distances");
    }
}

BOOST_AUTO_TEST_CASE(negative_zero_infinite_and_subnormal_values_sort_as_std_sort) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> wide(-1e6, 1e6);
    std::uniform_int_distribution<int> pick(0, 9);
    const double inf = std::numeric_limits<double>::infinity();
    const double tiny = std::numeric_limits<double>::denorm_min();
    std::vector<double> v(4000);
    for (double& x : v) {
        switch (pick(rng)) {
            case 0: x = -1.0; break;  // the "unknown" distance
            case 1: x = 0.0; break;
            case 2: x = -0.0; break;
            case 3: x = inf; break;
            case 4: x = -inf; break;
            case 5: x = tiny * pick(rng); break;
            case 6: x = -tiny * pick(rng); break;
            default: x = wide(rng);
        }
    }
    checkSortedLikeStd(v, "mixed signs and specials");
    // Keys that agree in their upper bytes (values close together): the skipped passes.
    std::uniform_real_distribution<double> close(1.0, 1.0 + 1e-9);
    std::vector<double> w(3000);
    for (double& x : w) x = close(rng);
    checkSortedLikeStd(w, "values within 1e-9");
    // Already sorted and reversed inputs.
    std::vector<double> up(1000);
    for (std::size_t i = 0; i < up.size(); ++i) up[i] = static_cast<double>(i) - 500.0;
    checkSortedLikeStd(up, "sorted");
    std::reverse(up.begin(), up.end());
    checkSortedLikeStd(up, "reversed");
    // All equal: every pass skipped.
    checkSortedLikeStd(std::vector<double>(777, 3.25), "all equal");
}

BOOST_AUTO_TEST_CASE(working_storage_is_reused_across_calls) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> metres(-50.0, 50.0);
    std::vector<std::uint64_t> keys, scratch;
    for (const std::size_t n : {std::size_t{3000}, std::size_t{500}, std::size_t{8000}}) {
        std::vector<double> v(n);
        for (double& x : v) x = metres(rng);
        std::vector<double> expected = v;
        std::sort(expected.begin(), expected.end());
        sortDoubles(v, keys, scratch);  // storage left over from a longer or shorter call
        BOOST_TEST((v == expected), n << " values");
    }
}
