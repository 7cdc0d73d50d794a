// CrowdHealth — the dense crowd's pair sums, scalar and AVX-512 builds (see PairSums.h).
#include "PairSums.h"

#include "crowdhealth/core/cpu_features.h"
#include "crowdhealth/core/list_lanes.h"

#include <atomic>
#include <cmath>
#include <cstdint>

#ifdef CH_LIST_LANES
#define CH_PAIRS_X86 1
#define CH_PAIRS_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl")))
#endif

#if defined(__GNUC__) && !defined(__clang__)
// Every product and sum rounded on its own in both builds (no fused multiply-add), so that a
// pair's term has the same bits whichever build computed it.
#define CH_PAIRS_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define CH_PAIRS_NO_CONTRACT
#endif

namespace ch::pairs {

namespace {

static_assert(sizeof(Vec2) == 16, "the AVX-512 build reads v_j as the words 2j and 2j + 1 of the column");

/// Entry k of a list as the sums read it: offset (x, y) and agent index j.
struct Entry {
    double x, y;
    std::size_t j;
};
/// The whole entries of a list.
struct WholeEntries {
    const NeighbourAgent* e;
    Entry operator[](std::size_t k) const {
        return {e[k].offset.x(), e[k].offset.y(), static_cast<std::size_t>(e[k].index)};
    }
};
/// A stored list by index: the offsets p_j − p_i computed here (IndexList).
struct IndexedEntries {
    const int* idx;
    const Vec2* p;
    Vec2 origin;
    Entry operator[](std::size_t k) const {
        const std::size_t j = static_cast<std::size_t>(idx[k]);
        return {p[j].x() - origin.x(), p[j].y() - origin.y(), j};
    }
};

/// SPH, the reference: one pair after the other, each skipped or added as the model says.
template <class List>
CH_PAIRS_NO_CONTRACT Vec2 sphScalar(const SphInput& in, const List& list) {
    double ax = 0, ay = 0;
    for (std::size_t k = 0; k < in.count; ++k) {
        const Entry nb = list[k];
        const double x = nb.x, y = nb.y;
        const double d2 = x * x + y * y;  // NeighbourAgent::distanceSquared()
        if (d2 >= in.h2) continue;
        const double r = std::sqrt(d2);
        if (r < 1e-12) continue;
        const std::size_t j = nb.j;
        const double rhoJ = in.density[j];
        if (!(rhoJ > 0)) continue;
        if (in.pushes) {
            const double spiky = r >= in.h ? 0.0 : in.cS * (in.h - r) * (in.h - r);
            const double s = in.mass[j] * (in.pressureI + in.pressure[j]) / (2.0 * rhoJ) * spiky;
            ax += s * (-x / r);
            ay += s * (-y / r);
        }
        if (in.viscosity > 0) {
            const double laplacian = r >= in.h ? 0.0 : in.cV * (in.h - r);
            const double t = in.viscosity * in.mass[j] / rhoJ * laplacian;
            ax += t * (in.velocity[j].x() - in.velocityI.x());
            ay += t * (in.velocity[j].y() - in.velocityI.y());
        }
    }
    return {ax, ay};
}

/// SPH's density, the reference (SPH::prepare's loop over the list through forEachNeighbour: an
/// entry at exactly h adds m_j · 0, which changes no sum, so it is skipped here).
template <class List>
CH_PAIRS_NO_CONTRACT double densityScalar(const DensityInput& in, const List& list) {
    double rho = in.start;
    for (std::size_t k = 0; k < in.count; ++k) {
        const Entry nb = list[k];
        const double r2 = nb.x * nb.x + nb.y * nb.y;
        if (!(r2 < in.h2)) continue;
        const double d = in.h2 - r2;
        rho += in.mass[nb.j] * (in.c6 * d * d * d);
    }
    return rho;
}

/// ContactForces' agent springs, the reference (ContactForces::prepare's loop over the list).
template <class List>
CH_PAIRS_NO_CONTRACT Vec2 contactScalar(const ContactInput& in, const List& list) {
    double ax = 0, ay = 0;
    for (std::size_t k = 0; k < in.count; ++k) {
        const Entry nb = list[k];
        const double x = nb.x, y = nb.y;
        const double d2 = x * x + y * y;
        if (!(d2 <= in.reach2)) continue;
        const double reach = in.radiusI + in.radius[nb.j];
        if (d2 >= reach * reach) continue;  // no overlap: no square root needed
        const double r = std::sqrt(d2);
        const double overlap = reach - r;
        if (overlap > 0 && r > 1e-12) {
            const double f = in.stiffness * overlap;
            ax += f * (-x / r);
            ay += f * (-y / r);
        }
    }
    return {ax, ay};
}

#ifdef CH_PAIRS_X86
/// column[stride · index] in every live lane of g (0 in the others): the hardware gather. (Eight
/// scalar loads put together measured the same, within the noise, at 10k and 100k agents.)
CH_PAIRS_AVX512 [[gnu::always_inline]] inline __m512d column8(const double* column, const lanes::Entries8& g, int stride = 1) {
    const __m256i index = stride == 1 ? g.index : _mm256_mullo_epi32(g.index, _mm256_set1_epi32(stride));
    return _mm512_mask_i32gather_pd(_mm512_setzero_pd(), g.live, index, column, 8);
}

/// Asks for the lists that follow this one in memory, ~kPrefetchDistance bytes on: the stored
/// lists of a step lie in agent order, one after the other (core/neighbours.h), so these are the
/// next agents'. At 100k agents the lists (~30 MB) have left the caches since the previous phase
/// read them; the scalar loops' loads, one entry after the other, let the CPU's stride prefetcher
/// run ahead along them, the few wide loads of this build did not (its two sums took 1.6 times
/// the scalar builds' time at 100k agents, and less than them at 10k). As many lines as this list
/// spans, so the prefetches keep pace with the reads. A prefetch cannot fault: past the end of the
/// buffer, or for lists that lie elsewhere (tests), it does nothing but waste a slot.
constexpr std::size_t kPrefetchDistance = 1024;
CH_PAIRS_AVX512 [[gnu::always_inline]] inline void prefetchFollowing(const NeighbourAgent* e, std::size_t count) {
    // Addresses computed as integers: a pointer past the end of the list's array would be
    // undefined behaviour even unread.
    const std::uintptr_t next = reinterpret_cast<std::uintptr_t>(e + count) + kPrefetchDistance;
    const std::size_t lines = (count * sizeof(NeighbourAgent)) / 64 + 1;
    for (std::size_t l = 0; l < lines; ++l) _mm_prefetch(reinterpret_cast<const char*>(next + 64 * l), _MM_HINT_T0);
}

/// The whole entries of a list, eight at a time (lanes::load8), the next lists prefetched.
struct WholeLanes {
    const NeighbourAgent* e;
    CH_PAIRS_AVX512 void prefetch(std::size_t count) const { prefetchFollowing(e, count); }
    CH_PAIRS_AVX512 lanes::Entries8 operator()(std::size_t k, std::size_t left) const {
        return lanes::load8<true>(e + k, left);
    }
};
/// A stored list by index, eight at a time: the indices loaded, the positions gathered, the
/// offsets p_j − p_i computed in the lanes (the scalar build's subtraction, so the same bits).
struct IndexedLanes {
    const int* idx;
    const double* p;  ///< x of agent j at 2j, y at 2j + 1
    __m512d ox, oy;
    CH_PAIRS_AVX512 void prefetch(std::size_t count) const {
        const std::uintptr_t next = reinterpret_cast<std::uintptr_t>(idx + count) + kPrefetchDistance / 4;
        _mm_prefetch(reinterpret_cast<const char*>(next), _MM_HINT_T0);
    }
    CH_PAIRS_AVX512 CH_PAIRS_NO_CONTRACT lanes::Entries8 operator()(std::size_t k, std::size_t left) const {
        lanes::Entries8 g;
        g.live = left >= 8 ? __mmask8(0xff) : static_cast<__mmask8>((1u << left) - 1u);
        g.index = _mm256_maskz_loadu_epi32(g.live, idx + k);
        const __m256i twice = _mm256_add_epi32(g.index, g.index);
        g.x = _mm512_sub_pd(_mm512_mask_i32gather_pd(_mm512_setzero_pd(), g.live, twice, p, 8), ox);
        g.y = _mm512_sub_pd(_mm512_mask_i32gather_pd(_mm512_setzero_pd(), g.live, twice, p + 1, 8), oy);
        return g;
    }
};

/// SPH, eight entries per step (crowdhealth/core/list_lanes.h): the neighbours' columns gathered,
/// every term computed in the lanes with the scalar build's expression, and the lanes that fail a
/// test set to +0. The terms are then added in list order. Adding +0 leaves a sum unchanged bit for bit: the sums
/// start at +0 and a sum of doubles rounded to nearest is never −0 unless both addends are, so
/// no sum here is ever −0 and s + 0 = s.
template <class Lanes>
CH_PAIRS_AVX512 CH_PAIRS_NO_CONTRACT Vec2 sphAvx512(const SphInput& in, const Lanes& list) {
    const __m512d h = _mm512_set1_pd(in.h), h2 = _mm512_set1_pd(in.h2);
    const __m512d cS = _mm512_set1_pd(in.cS), cV = _mm512_set1_pd(in.cV);
    const __m512d pI = _mm512_set1_pd(in.pressureI), two = _mm512_set1_pd(2.0);
    const __m512d mu = _mm512_set1_pd(in.viscosity), tiny = _mm512_set1_pd(1e-12);
    const __m512d vix = _mm512_set1_pd(in.velocityI.x()), viy = _mm512_set1_pd(in.velocityI.y());
    const __m512d zero = _mm512_setzero_pd();
    const __m512i signBit = _mm512_set1_epi64(static_cast<long long>(0x8000000000000000ULL));
    const bool viscous = in.viscosity > 0;
    const double* velocity = reinterpret_cast<const double*>(in.velocity);
    alignas(64) double tx[8], ty[8], ux[8], uy[8];
    double ax = 0, ay = 0;
    list.prefetch(in.count);
    for (std::size_t k = 0; k < in.count; k += 8) {
        const std::size_t left = in.count - k < 8 ? in.count - k : 8;
        const lanes::Entries8 g = list(k, left);
        const __mmask8 live = g.live;
        const __m512d x = g.x, y = g.y;
        const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(x, x), _mm512_mul_pd(y, y));
        // The columns of every listed neighbour (masked by `live` only, so that the loads do
        // not wait for the square root or for each other).
        const __m512d rhoJ = column8(in.density, g);
        const __m512d mJ = column8(in.mass, g);
        // The scalar build's tests, NaN included: skip when d2 ≥ h², r < 1e-12 or !(ρ_j > 0).
        __mmask8 use = live & _mm512_cmp_pd_mask(d2, h2, _CMP_NGE_UQ);
        const __m512d r = _mm512_maskz_sqrt_pd(0xff, d2);
        use &= _mm512_cmp_pd_mask(r, tiny, _CMP_NLT_UQ);
        use &= _mm512_cmp_pd_mask(rhoJ, zero, _CMP_GT_OQ);
        const __mmask8 inside = _mm512_cmp_pd_mask(r, h, _CMP_NGE_UQ);  // the kernels' r >= h ? 0
        const __m512d hr = _mm512_sub_pd(h, r);
        if (in.pushes) {
            const __m512d pJ = column8(in.pressure, g);
            const __m512d spiky = _mm512_maskz_mul_pd(inside, _mm512_mul_pd(cS, hr), hr);
            const __m512d s = _mm512_mul_pd(_mm512_div_pd(_mm512_mul_pd(mJ, _mm512_add_pd(pI, pJ)), _mm512_mul_pd(two, rhoJ)),
                                            spiky);
            const __m512d nx = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(x), signBit));
            const __m512d ny = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(y), signBit));
            _mm512_store_pd(tx, _mm512_maskz_mul_pd(use, s, _mm512_div_pd(nx, r)));
            _mm512_store_pd(ty, _mm512_maskz_mul_pd(use, s, _mm512_div_pd(ny, r)));
        }
        if (viscous) {
            const __m512d vx = column8(velocity, g, 2);
            const __m512d vy = column8(velocity + 1, g, 2);
            const __m512d laplacian = _mm512_maskz_mul_pd(inside, cV, hr);
            const __m512d t = _mm512_mul_pd(_mm512_div_pd(_mm512_mul_pd(mu, mJ), rhoJ), laplacian);
            _mm512_store_pd(ux, _mm512_maskz_mul_pd(use, t, _mm512_sub_pd(vx, vix)));
            _mm512_store_pd(uy, _mm512_maskz_mul_pd(use, t, _mm512_sub_pd(vy, viy)));
        }
        // In list order, as the scalar build adds them (lanes past `left` are +0 and skipped).
        if (in.pushes && viscous) {
            for (std::size_t l = 0; l < 8; ++l) {
                ax += tx[l];
                ay += ty[l];
                ax += ux[l];
                ay += uy[l];
            }
        } else if (in.pushes) {
            for (std::size_t l = 0; l < 8; ++l) {
                ax += tx[l];
                ay += ty[l];
            }
        } else if (viscous) {
            for (std::size_t l = 0; l < 8; ++l) {
                ax += ux[l];
                ay += uy[l];
            }
        }
    }
    return {ax, ay};
}
/// SPH's density, eight entries per step, the terms added in list order as above (the sum starts
/// at m_i W(0) > 0 and every term is ≥ 0, so adding +0 for a skipped lane changes nothing).
template <class Lanes>
CH_PAIRS_AVX512 CH_PAIRS_NO_CONTRACT double densityAvx512(const DensityInput& in, const Lanes& list) {
    const __m512d h2 = _mm512_set1_pd(in.h2), c6 = _mm512_set1_pd(in.c6);
    alignas(64) double t[8];
    double rho = in.start;
    list.prefetch(in.count);
    for (std::size_t k = 0; k < in.count; k += 8) {
        const std::size_t left = in.count - k < 8 ? in.count - k : 8;
        const lanes::Entries8 g = list(k, left);
        const __m512d r2 = _mm512_add_pd(_mm512_mul_pd(g.x, g.x), _mm512_mul_pd(g.y, g.y));
        const __mmask8 use = g.live & _mm512_cmp_pd_mask(r2, h2, _CMP_LT_OQ);
        const __m512d d = _mm512_sub_pd(h2, r2);
        const __m512d w = _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(c6, d), d), d);
        _mm512_store_pd(t, _mm512_maskz_mul_pd(use, column8(in.mass, g), w));
        for (std::size_t l = 0; l < 8; ++l) rho += t[l];
    }
    return rho;
}

/// ContactForces' agent springs over the live lanes of `c` (entries already within reach2, in list
/// order): the scalar build's remaining tests and terms, the terms of the lanes that fail a test
/// set to +0 and all eight added in lane order (see sphAvx512).
CH_PAIRS_AVX512 CH_PAIRS_NO_CONTRACT [[gnu::always_inline]] inline void contactLanes(const ContactInput& in,
                                                                                  const lanes::Entries8& c,
                                                                                  double& ax, double& ay) {
    const __m512d own = _mm512_set1_pd(in.radiusI), stiffness = _mm512_set1_pd(in.stiffness);
    const __m512d tiny = _mm512_set1_pd(1e-12), zero = _mm512_setzero_pd();
    const __m512i signBit = _mm512_set1_epi64(static_cast<long long>(0x8000000000000000ULL));
    const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(c.x, c.x), _mm512_mul_pd(c.y, c.y));
    const __m512d reach = _mm512_add_pd(own, column8(in.radius, c));
    __mmask8 use = c.live & _mm512_cmp_pd_mask(d2, _mm512_mul_pd(reach, reach), _CMP_NGE_UQ);
    const __m512d r = _mm512_maskz_sqrt_pd(0xff, d2);
    const __m512d overlap = _mm512_sub_pd(reach, r);
    use &= _mm512_cmp_pd_mask(overlap, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(r, tiny, _CMP_GT_OQ);
    const __m512d f = _mm512_mul_pd(stiffness, overlap);
    const __m512d nx = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(c.x), signBit));
    const __m512d ny = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(c.y), signBit));
    alignas(64) double tx[8], ty[8];
    _mm512_store_pd(tx, _mm512_maskz_mul_pd(use, f, _mm512_div_pd(nx, r)));
    _mm512_store_pd(ty, _mm512_maskz_mul_pd(use, f, _mm512_div_pd(ny, r)));
    for (std::size_t l = 0; l < 8; ++l) {
        ax += tx[l];
        ay += ty[l];
    }
}

/// ContactForces' agent springs (issue 20). The list is read eight entries at a time and only
/// those within reach2 (the scalar build's first filter: in a dense crowd ~4 of an SPH list's
/// ~16) are kept, packed in list order into the lanes of `kept` (compressed from their group,
/// expanded after the entries already kept; the lanes not in use hold zeros, whose terms the
/// r > 1e-12 test drops anyway, and `live` covers them only at the last call). Each time eight
/// are kept, and at the end, their terms are computed and added in order. So the neighbours' radii, the square roots, the
/// divisions and the additions are spent on those entries only, and the sum is the scalar
/// build's bit for bit: the entries dropped are those whose terms it skips.
template <class Lanes>
CH_PAIRS_AVX512 CH_PAIRS_NO_CONTRACT Vec2 contactAvx512(const ContactInput& in, const Lanes& list) {
    const __m512d reach2 = _mm512_set1_pd(in.reach2);
    const __m512i iota = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
    const __m256i iota32 = _mm256_set_epi32(7, 6, 5, 4, 3, 2, 1, 0);
    lanes::Entries8 kept{_mm512_setzero_pd(), _mm512_setzero_pd(), _mm256_setzero_si256(), 0xff};
    unsigned held = 0;  // lanes of `kept` in use, from lane 0
    double ax = 0, ay = 0;
    list.prefetch(in.count);
    for (std::size_t k = 0; k < in.count; k += 8) {
        const std::size_t left = in.count - k < 8 ? in.count - k : 8;
        const lanes::Entries8 g = list(k, left);
        const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(g.x, g.x), _mm512_mul_pd(g.y, g.y));
        const __mmask8 near = g.live & _mm512_cmp_pd_mask(d2, reach2, _CMP_LE_OQ);
        if (near == 0) continue;
        const unsigned p = static_cast<unsigned>(__builtin_popcount(near));
        const __m512d x = _mm512_maskz_compress_pd(near, g.x), y = _mm512_maskz_compress_pd(near, g.y);
        const __m256i j = _mm256_maskz_compress_epi32(near, g.index);
        // The new entries into lanes held, held + 1, … (as many as fit).
        const __mmask8 into = static_cast<__mmask8>(((1u << p) - 1u) << held);
        kept.x = _mm512_mask_expand_pd(kept.x, into, x);
        kept.y = _mm512_mask_expand_pd(kept.y, into, y);
        kept.index = _mm256_mask_expand_epi32(kept.index, into, j);
        held += p;
        if (held < 8) continue;
        contactLanes(in, kept, ax, ay);  // all eight live
        // Those that did not fit, from lane 8 − (held − p) of the packed group, to lane 0.
        held -= 8;
        const unsigned from = p - held;
        const __mmask8 rest = static_cast<__mmask8>((1u << held) - 1u);
        const __m512i from64 = _mm512_add_epi64(iota, _mm512_set1_epi64(from));
        const __m256i from32 = _mm256_add_epi32(iota32, _mm256_set1_epi32(static_cast<int>(from)));
        kept.x = _mm512_maskz_permutexvar_pd(rest, from64, x);
        kept.y = _mm512_maskz_permutexvar_pd(rest, from64, y);
        kept.index = _mm256_maskz_permutexvar_epi32(rest, from32, j);
    }
    if (held > 0) {
        kept.live = static_cast<__mmask8>((1u << held) - 1u);
        contactLanes(in, kept, ax, ay);
    }
    return {ax, ay};
}
#endif

#ifdef CH_PAIRS_X86
CH_PAIRS_AVX512 IndexedLanes indexedLanes(const IndexList& b) {
    return IndexedLanes{b.indices, b.positions[0].data(), _mm512_set1_pd(b.origin.x()), _mm512_set1_pd(b.origin.y())};
}
#endif

bool cpuRuns(int path) {
#ifdef CH_PAIRS_X86
    if (path == 1) return cpu::hasAvx512();
#endif
    return path == 0;
}

std::atomic<int> gPath{cpuRuns(1) ? 1 : 0};

}  // namespace

Vec2 sphForce(const SphInput& in) {
    const IndexList& b = in.byIndex;
#ifdef CH_PAIRS_X86
    if (gPath.load(std::memory_order_relaxed) == 1)
        return b.indices != nullptr ? sphAvx512(in, indexedLanes(b)) : sphAvx512(in, WholeLanes{in.entries});
#endif
    return b.indices != nullptr ? sphScalar(in, IndexedEntries{b.indices, b.positions, b.origin})
                                : sphScalar(in, WholeEntries{in.entries});
}

double sphDensity(const DensityInput& in) {
    const IndexList& b = in.byIndex;
#ifdef CH_PAIRS_X86
    if (gPath.load(std::memory_order_relaxed) == 1)
        return b.indices != nullptr ? densityAvx512(in, indexedLanes(b)) : densityAvx512(in, WholeLanes{in.entries});
#endif
    return b.indices != nullptr ? densityScalar(in, IndexedEntries{b.indices, b.positions, b.origin})
                                : densityScalar(in, WholeEntries{in.entries});
}

Vec2 contactForce(const ContactInput& in) {
    const IndexList& b = in.byIndex;
#ifdef CH_PAIRS_X86
    if (gPath.load(std::memory_order_relaxed) == 1)
        return b.indices != nullptr ? contactAvx512(in, indexedLanes(b)) : contactAvx512(in, WholeLanes{in.entries});
#endif
    return b.indices != nullptr ? contactScalar(in, IndexedEntries{b.indices, b.positions, b.origin})
                                : contactScalar(in, WholeEntries{in.entries});
}

int path() { return gPath.load(); }

bool setPath(int path) {
    if (!cpuRuns(path)) return false;
    gPath.store(path);
    return true;
}

}  // namespace ch::pairs
