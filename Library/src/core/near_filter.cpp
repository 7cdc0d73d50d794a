// CrowdHealth — nearEntries: the entries of a neighbour list within a distance, as a bit mask.
#include "crowdhealth/core/near_filter.h"
#include "crowdhealth/core/cpu_features.h"

#include <atomic>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_NEAR_X86 1
#include <immintrin.h>
#endif

#if defined(__GNUC__) && !defined(__clang__)
// x·x + y·y rounded twice, as NeighbourAgent::distanceSquared() is (the margin covers it anyway).
#define CH_NEAR_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define CH_NEAR_NO_CONTRACT
#endif

namespace ch {

namespace {

static_assert(sizeof(NeighbourAgent) == 24 && offsetof(NeighbourAgent, offset) == 0,
              "nearEntries reads x, y as the first two of each entry's three 8-byte words");

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
/// Eight entries (192 bytes: three 64-byte loads) per step; two permutes each put the eight x and
/// the eight y in order (x of entry l is word 3l, y word 3l + 1; the index words are never used).
/// The last, partial group loads with masks (masked-off words are not read, so no fault past the
/// list's end).
__attribute__((target("avx512f"))) CH_NEAR_NO_CONTRACT
std::uint64_t nearAvx512(const NeighbourAgent* e, std::size_t count, double bound2) {
    const double* w = reinterpret_cast<const double*>(e);
    const __m512d b = _mm512_set1_pd(widened(bound2));
    const __m512i xAB = _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0);
    const __m512i xC = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13);
    const __m512i yAB = _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0);
    const __m512i yC = _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14);
    std::uint64_t mask = 0;
    for (std::size_t k = 0; k < count; k += 8) {
        const std::size_t left = count - k < 8 ? count - k : 8;
        const std::size_t words = 3 * left;  // 3..24
        const double* p = w + 3 * k;
        __m512d A, B, C;
        if (left == 8) {
            A = _mm512_loadu_pd(p);
            B = _mm512_loadu_pd(p + 8);
            C = _mm512_loadu_pd(p + 16);
        } else {
            const auto m = [&](std::size_t from) {
                const std::size_t n = words > from ? (words - from > 8 ? 8 : words - from) : 0;
                return static_cast<__mmask8>((1u << n) - 1u);
            };
            A = _mm512_maskz_loadu_pd(m(0), p);
            B = _mm512_maskz_loadu_pd(m(8), p + 8);
            C = _mm512_maskz_loadu_pd(m(16), p + 16);
        }
        const __m512d x = _mm512_permutex2var_pd(_mm512_permutex2var_pd(A, xAB, B), xC, C);
        const __m512d y = _mm512_permutex2var_pd(_mm512_permutex2var_pd(A, yAB, B), yC, C);
        const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(x, x), _mm512_mul_pd(y, y));
        const unsigned live = (1u << left) - 1u;
        const unsigned near = _mm512_cmp_pd_mask(d2, b, _CMP_LE_OQ) & live;
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
