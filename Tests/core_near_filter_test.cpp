// CrowdHealth tests — nearEntries (crowdhealth/core/near_filter.h), the first pass of UMANS'
// post-clamp contact over a neighbour list (issue 20): every entry within the bound is kept (the
// contact's exact test then decides), entries well beyond it are not, bits past the count are 0,
// and the scalar and AVX-512 builds give the same masks.
#define BOOST_TEST_MODULE core_near_filter
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/near_filter.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

using namespace ch;

namespace {

NeighbourAgent entry(double x, double y, int index) {
    NeighbourAgent e;
    e.offset = decltype(e.offset)(x, y);
    e.index = index;
    return e;
}

/// Checks nearEntries over e[0, count) against the definition with the build in use.
void checkAgainstDefinition(const std::vector<NeighbourAgent>& e, std::size_t count, double bound2) {
    const std::uint64_t mask = nearEntries(e.data(), count, bound2);
    for (std::size_t l = 0; l < 64; ++l) {
        const bool set = (mask >> l) & 1u;
        if (l >= count) {
            BOOST_TEST_REQUIRE(!set, "bit " << l << " set past count " << count);
            continue;
        }
        const double d2 = e[l].distanceSquared();
        // Kept: everything within the bound (ties included). Dropped: beyond the widened bound.
        if (d2 <= bound2) BOOST_TEST_REQUIRE(set, "entry " << l << " of " << count << " within the bound dropped");
        if (d2 > bound2 * (1 + 0x1p-39)) BOOST_TEST_REQUIRE(!set, "entry " << l << " of " << count << " far beyond kept");
    }
}

/// The builds this CPU runs (0 always; 1 with AVX-512).
std::vector<int> paths() {
    std::vector<int> p{0};
    const int was = nearEntriesPath();
    if (setNearEntriesPath(1)) p.push_back(1);
    setNearEntriesPath(was);
    return p;
}

struct RestorePath {
    int was = nearEntriesPath();
    ~RestorePath() { setNearEntriesPath(was); }
};

}  // namespace

BOOST_AUTO_TEST_CASE(keeps_every_entry_within_the_bound_for_every_count) {
    RestorePath restore;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> coord(-5.0, 5.0);
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(setNearEntriesPath(path));
        for (int trial = 0; trial < 40; ++trial) {
            // 72 entries, the last 8 far away: a count below 64 must not read them as near.
            std::vector<NeighbourAgent> e;
            for (int l = 0; l < 64; ++l) e.push_back(entry(coord(rng), coord(rng), l));
            for (int l = 64; l < 72; ++l) e.push_back(entry(0.0, 0.0, l));
            for (std::size_t count = 0; count <= 64; ++count)
                for (const double bound : {0.0, 0.6, 1.3, 3.0, 7.5})
                    checkAgainstDefinition(e, count, bound * bound);
        }
    }
}

BOOST_AUTO_TEST_CASE(ties_and_the_neighbours_of_the_bound) {
    // Entries exactly at the bound (d² = bound², exact in doubles), one ulp inside and outside,
    // in every lane position of a group of eight and across groups.
    RestorePath restore;
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(setNearEntriesPath(path));
        const double r = 0.75;  // r² = 0.5625 exactly
        for (std::size_t at = 0; at < 64; ++at) {
            std::vector<NeighbourAgent> e(64, entry(4.0, 0.0, 0));
            e[at] = entry(0.45, 0.6, 1);  // 0.45² + 0.6² rounds to 0.5625 or next to it
            const std::uint64_t mask = nearEntries(e.data(), 64, e[at].distanceSquared());
            BOOST_TEST_REQUIRE(mask == (std::uint64_t{1} << at), "tie at " << at << " path " << path);
            e[at] = entry(std::nextafter(r, 0.0), 0.0, 1);
            BOOST_TEST_REQUIRE(nearEntries(e.data(), 64, r * r) == (std::uint64_t{1} << at));
            e[at] = entry(1.0, 0.0, 1);
            BOOST_TEST_REQUIRE(nearEntries(e.data(), 64, r * r) == 0u);
        }
        // An infinite bound keeps every entry; an empty list none.
        std::vector<NeighbourAgent> e(13, entry(1e100, -3e100, 0));
        BOOST_TEST_REQUIRE(nearEntries(e.data(), 13, INFINITY) == (std::uint64_t{1} << 13) - 1);
        BOOST_TEST_REQUIRE(nearEntries(e.data(), 0, INFINITY) == 0u);
    }
}

BOOST_AUTO_TEST_CASE(builds_agree_bit_for_bit) {
    RestorePath restore;
    if (!setNearEntriesPath(1)) {
        BOOST_TEST_MESSAGE("no AVX-512 on this CPU: one build only");
        return;
    }
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> coord(-2.0, 2.0);
    for (int trial = 0; trial < 200; ++trial) {
        std::vector<NeighbourAgent> e;
        for (int l = 0; l < 64; ++l) e.push_back(entry(coord(rng), coord(rng), l));
        for (std::size_t count = 0; count <= 64; ++count) {
            const double b2 = e[count % 64].distanceSquared();  // ties with some entry
            setNearEntriesPath(0);
            const std::uint64_t generic = nearEntries(e.data(), count, b2);
            setNearEntriesPath(1);
            BOOST_TEST_REQUIRE(nearEntries(e.data(), count, b2) == generic);
        }
    }
}
