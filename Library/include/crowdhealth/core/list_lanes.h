// CrowdHealth — eight neighbour-list entries as AVX-512 lanes (issue 20): the loader shared by the
// loops that read lists eight entries at a time (core/near_filter.cpp, Policies/PairSums.cpp).
// Only in GCC builds for x86-64 (CH_LIST_LANES is then defined); the functions are compiled for
// AVX-512F and may be called only from functions compiled for it, on CPUs that have it.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_LIST_LANES 1

#include "crowdhealth/core/neighbours.h"

#include <cstddef>
#include <immintrin.h>

namespace ch::lanes {

static_assert(sizeof(NeighbourAgent) == 24 && offsetof(NeighbourAgent, offset) == 0 &&
                  offsetof(NeighbourAgent, index) == 16,
              "an entry is three 8-byte words: x, y, then the index in the third word's low half");

/// Entries e[0 .. left) as lanes 0 .. left−1; lanes from `left` on hold 0.
struct Entries8 {
    __m512d x, y;   ///< the offsets' components
    __m256i index;  ///< the agent indices (only when asked for; else undefined)
    __mmask8 live;  ///< lanes below `left`
};

/// Loads e[0 .. left), 1 ≤ left ≤ 8: three 64-byte loads (masked for a partial group: nothing
/// past the list is read), then two permutes per column put x, y and the index words in lane order
/// (x of entry l is word 3l, y word 3l + 1, the index word 3l + 2).
template <bool WithIndex>
[[gnu::always_inline]] __attribute__((target("avx512f"))) inline Entries8 load8(const NeighbourAgent* e, std::size_t left) {
    const double* p = reinterpret_cast<const double*>(e);
    __m512d A, B, C;
    if (left >= 8) {
        A = _mm512_loadu_pd(p);
        B = _mm512_loadu_pd(p + 8);
        C = _mm512_loadu_pd(p + 16);
        left = 8;
    } else {
        const std::size_t words = 3 * left;  // 3 .. 21
        const auto m = [&](std::size_t from) {
            const std::size_t n = words > from ? (words - from > 8 ? 8 : words - from) : 0;
            return static_cast<__mmask8>((1u << n) - 1u);
        };
        A = _mm512_maskz_loadu_pd(m(0), p);
        B = _mm512_maskz_loadu_pd(m(8), p + 8);
        C = _mm512_maskz_loadu_pd(m(16), p + 16);
    }
    Entries8 out;
    const __m512i xAB = _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0);
    const __m512i xC = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13);
    const __m512i yAB = _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0);
    const __m512i yC = _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14);
    out.x = _mm512_permutex2var_pd(_mm512_permutex2var_pd(A, xAB, B), xC, C);
    out.y = _mm512_permutex2var_pd(_mm512_permutex2var_pd(A, yAB, B), yC, C);
    if constexpr (WithIndex) {
        const __m512i iAB = _mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0);
        const __m512i iC = _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15);
        const __m512i words = _mm512_castpd_si512(_mm512_permutex2var_pd(_mm512_permutex2var_pd(A, iAB, B), iC, C));
        // The low half of each word (the masked form: GCC 12 warns that the plain one's undefined
        // pass-through "may be used uninitialized").
        out.index = _mm512_maskz_cvtepi64_epi32(0xff, words);
    }
    out.live = static_cast<__mmask8>((1u << left) - 1u);
    return out;
}

}  // namespace ch::lanes

#endif
