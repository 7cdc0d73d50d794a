// CrowdHealth — nearEntries: the entries of a neighbour list within a distance, as a bit mask.
#include "crowdhealth/core/near_filter.h"
#include "crowdhealth/core/cpu_features.h"

#include <atomic>
#include <cstring>

#include "crowdhealth/core/list_lanes.h"
#ifdef CH_LIST_LANES
#define CH_NEAR_X86 1
#endif

#if defined(__GNUC__) && !defined(__clang__)
// x·x + y·y rounded twice, as NeighbourAgent::distanceSquared() is (the margin covers it anyway).
#define CH_NEAR_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define CH_NEAR_NO_CONTRACT
#endif

namespace ch {

namespace {

/// bound2 plus a relative 2^-40 (a few hundred ulp: more than any rounding difference between
/// two evaluations of x·x + y·y), +inf and NaN kept (NaN then sets no bit: callers pass none).
double widened(double bound2) { return bound2 + bound2 * 0x1p-40; }

CH_NEAR_NO_CONTRACT
std::uint64_t nearScalar(const NeighbourAgent* e, std::size_t count, double bound2) {
    const double b = widened(bound2);
    std::uint64_t mask = 0;
    for (std::size_t l = 0; l < count; ++l) {
        double xy[2];
        std::memcpy(xy, &e[l].offset, sizeof xy);
        if (xy[0] * xy[0] + xy[1] * xy[1] <= b) mask |= std::uint64_t{1} << l;
    }
    return mask;
}

#ifdef CH_NEAR_X86
/// Eight entries per step (crowdhealth/core/list_lanes.h: the last, partial group is loaded with
/// masks, so nothing past the list's end is read).
__attribute__((target("avx512f"))) CH_NEAR_NO_CONTRACT
std::uint64_t nearAvx512(const NeighbourAgent* e, std::size_t count, double bound2) {
    const __m512d b = _mm512_set1_pd(widened(bound2));
    std::uint64_t mask = 0;
    for (std::size_t k = 0; k < count; k += 8) {
        const lanes::Entries8 g = lanes::load8<false>(e + k, count - k);
        const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(g.x, g.x), _mm512_mul_pd(g.y, g.y));
        const unsigned near = _mm512_cmp_pd_mask(d2, b, _CMP_LE_OQ) & g.live;
        mask |= static_cast<std::uint64_t>(near) << k;
    }
    return mask;
}
#endif

bool cpuRuns(int path) {
#ifdef CH_NEAR_X86
    if (path == 1) return cpu::hasAvx512();  // uses F only; the same test as the other AVX-512 loops
#endif
    return path == 0;
}

std::atomic<int> gPath{cpuRuns(1) ? 1 : 0};

}  // namespace

std::uint64_t nearEntries(const NeighbourAgent* e, std::size_t count, double bound2) {
#ifdef CH_NEAR_X86
    if (gPath.load(std::memory_order_relaxed) == 1) return nearAvx512(e, count, bound2);
#endif
    return nearScalar(e, count, bound2);
}

int nearEntriesPath() { return gPath.load(); }

bool setNearEntriesPath(int path) {
    if (!cpuRuns(path)) return false;
    gPath.store(path);
    return true;
}

}  // namespace ch
