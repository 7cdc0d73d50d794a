// CrowdHealth — per-step neighbour lists.
#include "crowdhealth/core/neighbours.h"
#include "crowdhealth/core/cpu_features.h"

#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/world.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#define CH_NL_X86 1
#define CH_NL_AVX2 __attribute__((target("avx2")))
#define CH_NL_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl")))
// No fused multiply-add in the vector gathers: dx·dx + dy·dy must round like the scalar path's
// (the generic x86-64 build has no FMA), or a point at exactly r could be in one list and not the
// other. (GCC's intrinsics are vector-extension arithmetic, which it contracts where allowed.)
#define CH_NL_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#endif

namespace ch {

namespace {

/// Gather paths (NeighbourLists::gatherPath): 0 generic (forEachCandidate, a branch-free append
/// per candidate), 1 AVX2 (the distance test four candidates at a time), 2 AVX-512 (eight at a
/// time, the selected entries compressed and written three registers at once).
/// Entries a path may write past the end of a list (the buffer is opened with this much slack).
constexpr std::size_t kGatherSlack = 8;

/// Writes a list entry at `at`: the whole entry (streamed lists) or the index alone (stored lists,
/// whose offsets are computed where they are read).
inline void put(NeighbourAgent* list, std::size_t at, double dx, double dy, int j) {
    NeighbourAgent& e = list[at];
    e.offset.x() = dx;
    e.offset.y() = dy;
    e.index = j;
}
inline void put(int* list, std::size_t at, double, double, int j) { list[at] = j; }
/// Whether a gather writes whole entries (else indices alone).
template <class Entry>
constexpr bool kWhole = std::is_same_v<Entry, NeighbourAgent>;

/// The generic gather: the scalar branch-free append (every candidate is written at `count`, which
/// advances only for the others within r), over any grid.
template <class Entry>
std::size_t gatherGeneric(const PointGrid& grid, const Vec2& p, double r, int self, Entry* list) {
    std::size_t count = 0;
    const double r2 = r * r;
    grid.forEachCandidate(p, r, [&](int j, const Vec2& d, double d2) {
        put(list, count, d.x(), d.y(), j);
        count += static_cast<std::size_t>((d2 <= r2) & (j != self));
    });
    return count;
}

/// Rows of cells a query may span before a gather falls back to forEachCandidate (a list
/// radius of 64 cells; the lists' grids have cells of half or a quarter of it).
constexpr int kMaxRuns = 64;
using Run = PointGrid::Run;

/// The branch-free append of candidates [k0, k1) of a plane grid's order (x, y, index as
/// PointGrid::sortedX, sortedY, order) to `list` at `count`: the scalar gather, and the tails of the
/// vector ones.
template <class Entry>
inline void appendScalar(const double* xs, const double* ys, const int* idx, int k0, int k1, const Vec2& p, double r2,
                         int self, Entry* list, std::size_t& count) {
    for (int k = k0; k < k1; ++k) {
        const Vec2 d = Vec2(xs[k], ys[k]) - p;
        const int j = idx[k];
        put(list, count, d.x(), d.y(), j);
        count += static_cast<std::size_t>((d.squaredNorm() <= r2) & (j != self));
    }
}

/// The same append over the runs of PointGrid::rowRuns (plane grids).
template <class Entry>
std::size_t gatherRuns(const PointGrid& grid, const Run* runs, int nRuns, const Vec2& p, double r, int self,
                       Entry* list) {
    std::size_t count = 0;
    for (int q = 0; q < nRuns; ++q)
        appendScalar(grid.sortedX().data(), grid.sortedY().data(), grid.order().data(), runs[q].begin, runs[q].end, p,
                     r * r, self, list, count);
    return count;
}

#ifdef CH_NL_X86
/// AVX2: per row run (PointGrid::rowRun), the offsets and the distance test four lanes at a time,
/// then the branch-free append lane by lane; the run's last < 4 candidates as in gatherGeneric.
template <class Entry>
CH_NL_AVX2 CH_NL_NO_CONTRACT
std::size_t gatherAvx2(const PointGrid& grid, const Run* runs, int nRuns, const Vec2& p, double r, int self,
                       Entry* list) {
    const double* xs = grid.sortedX().data();
    const double* ys = grid.sortedY().data();
    const int* idx = grid.order().data();
    const double r2 = r * r;
    const __m256d px = _mm256_set1_pd(p.x()), py = _mm256_set1_pd(p.y()), r2v = _mm256_set1_pd(r2);
    std::size_t count = 0;
    for (int q = 0; q < nRuns; ++q) {
        const int k0 = runs[q].begin, k1 = runs[q].end;
        int k = k0;
        for (; k + 4 <= k1; k += 4) {
            const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(xs + k), px);
            const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(ys + k), py);
            const __m256d d2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
            const unsigned in = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(d2, r2v, _CMP_LE_OQ)));
            alignas(32) double ax[4], ay[4];
            _mm256_store_pd(ax, dx);
            _mm256_store_pd(ay, dy);
            for (int l = 0; l < 4; ++l) {
                const int j = idx[k + l];
                put(list, count, ax[l], ay[l], j);
                count += ((in >> l) & 1u) & static_cast<unsigned>(j != self);
            }
        }
        appendScalar(xs, ys, idx, k, k1, p, r2, self, list, count);
    }
    return count;
}

/// Where AVX-512 entry field q of eight entries (24 quadwords: offset x, offset y, index per
/// entry) comes from: 3·e + f ← field f of lane e.
struct Interleave {
    std::array<long long, 24> fromXY;  ///< for permutex2var over (x, y): e or 8 + e; 0 for index fields
    std::array<long long, 24> fromIndex;  ///< e for index fields
    std::array<unsigned char, 3> indexLanes;  ///< per output register, the lanes that take an index
};
constexpr Interleave makeInterleave() {
    Interleave t{};
    for (int q = 0; q < 24; ++q) {
        const int e = q / 3, f = q % 3;
        t.fromXY[q] = f == 0 ? e : f == 1 ? 8 + e : 0;
        t.fromIndex[q] = f == 2 ? e : 0;
        if (f == 2) t.indexLanes[q / 8] = static_cast<unsigned char>(t.indexLanes[q / 8] | (1u << (q % 8)));
    }
    return t;
}
constexpr Interleave kInterleave = makeInterleave();

/// AVX-512: per row run, eight candidates at a time (the run's tail by masked loads): the lanes
/// within r and not self are compressed to the front of the x, y and index registers, interleaved
/// into eight 24-byte entries by two permutes per register, stored whole (three 64-byte stores)
/// and `count` advances by their number; index lists store the compressed indices alone. The
/// stores may run up to kGatherSlack entries past the list's end; entries past `count` are
/// overwritten by the next list or never read.
template <class Entry>
CH_NL_AVX512 CH_NL_NO_CONTRACT
std::size_t gatherWide(const PointGrid& grid, const Run* runs, int nRuns, const Vec2& p, double r, int self,
                       Entry* list) {
    const double* xs = grid.sortedX().data();
    const double* ys = grid.sortedY().data();
    const int* idx = grid.order().data();
    const __m512d px = _mm512_set1_pd(p.x()), py = _mm512_set1_pd(p.y()), r2v = _mm512_set1_pd(r * r);
    const __m256i selfv = _mm256_set1_epi32(self);
    __m512i fromXY[3], fromIndex[3];
    if constexpr (kWhole<Entry>)
        for (int v = 0; v < 3; ++v) {
            fromXY[v] = _mm512_loadu_si512(kInterleave.fromXY.data() + 8 * v);
            fromIndex[v] = _mm512_loadu_si512(kInterleave.fromIndex.data() + 8 * v);
        }
    std::size_t count = 0;
    for (int q = 0; q < nRuns; ++q) {
        const int k0 = runs[q].begin, k1 = runs[q].end;
        for (int k = k0; k < k1; k += 8) {
            const int left = k1 - k;
            const __mmask8 live = left >= 8 ? __mmask8(0xff) : static_cast<__mmask8>((1u << left) - 1u);
            const __m512d dx = _mm512_sub_pd(_mm512_maskz_loadu_pd(live, xs + k), px);
            const __m512d dy = _mm512_sub_pd(_mm512_maskz_loadu_pd(live, ys + k), py);
            const __m256i j = _mm256_maskz_loadu_epi32(live, idx + k);
            const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy));
            const __mmask8 take = static_cast<__mmask8>(_mm512_mask_cmp_pd_mask(live, d2, r2v, _CMP_LE_OQ) &
                                                        _mm256_cmpneq_epi32_mask(j, selfv));
            if constexpr (kWhole<Entry>) {
                const __m512d cx = _mm512_maskz_compress_pd(take, dx);
                const __m512d cy = _mm512_maskz_compress_pd(take, dy);
                const __m512d ci =
                    _mm512_castsi512_pd(_mm512_maskz_cvtepu32_epi64(0xff, _mm256_maskz_compress_epi32(take, j)));
                double* to = reinterpret_cast<double*>(list + count);
                for (int v = 0; v < 3; ++v) {
                    const __m512d xy = _mm512_permutex2var_pd(cx, fromXY[v], cy);
                    _mm512_storeu_pd(to + 8 * v,
                                     _mm512_mask_permutexvar_pd(xy, kInterleave.indexLanes[v], fromIndex[v], ci));
                }
            } else {
                _mm256_storeu_si256(reinterpret_cast<__m256i*>(list + count), _mm256_maskz_compress_epi32(take, j));
            }
            count += static_cast<std::size_t>(__builtin_popcount(take));
        }
    }
    return count;
}
#endif

/// The gather path in use: the best this CPU runs, found once when the program starts.
std::atomic<int> gGatherPath{cpu::bestBuild()};

template <class Entry>
std::size_t gatherRunsOn(int path, const PointGrid& grid, const Run* runs, int nRuns, const Vec2& p, double r,
                         int self, Entry* list) {
#ifdef CH_NL_X86
    switch (path) {
    case 2: return gatherWide(grid, runs, nRuns, p, r, self, list);
    case 1: return gatherAvx2(grid, runs, nRuns, p, r, self, list);
    default: break;
    }
#endif
    (void)path;
    return gatherRuns(grid, runs, nRuns, p, r, self, list);
}

}  // namespace

int NeighbourLists::gatherPath() { return gGatherPath.load(); }

bool NeighbourLists::setGatherPath(int path) {
    if (!cpu::runsBuild(path)) return false;
    gGatherPath.store(path);
    return true;
}

NeighbourLists::Slice NeighbourLists::slice(int thread, const Place& at, std::size_t count, std::size_t segments) {
    // Blocks double up to 64 MiB: 65,536 of them per thread would be 4 TiB of lists.
    constexpr std::size_t kMax16 = std::numeric_limits<std::uint16_t>::max();
    constexpr std::size_t kMax32 = std::numeric_limits<std::uint32_t>::max();
    if (static_cast<std::size_t>(thread) > kMax16 || at.block > kMax16 || at.begin > kMax32 || count > kMax32 ||
        segments > kMax32)
        throw std::length_error("neighbour lists: more threads, blocks or entries than a slice can address");
    return Slice{static_cast<std::uint32_t>(at.begin), static_cast<std::uint32_t>(count),
                 static_cast<std::uint32_t>(segments), static_cast<std::uint16_t>(thread),
                 static_cast<std::uint16_t>(at.block)};
}

const PointGrid& NeighbourLists::prepareGrid(const std::vector<Vec2>& positions, const PointGrid& stepGrid,
                                             const World& world, const std::vector<int>& group,
                                             const std::vector<double>& rangeOfGroup) {
    // Long ranges (social forces: 5 m) search a finer grid of their own. With cells as wide as
    // the range, the query disc's bounding box covers 3 × 3 cells, (2r + c)² = 9r² of area for a
    // disc of πr²: 2.9 candidates per neighbour, each written to the list (branch-free append).
    // With cells of r/4 it covers (2.25r)², 1.6 candidates per neighbour, for one more counting
    // sort of the positions per step. Lists then follow that grid's visit order: the same
    // neighbours, summed in another order (docs/performance.md, issue 20). Short ranges (SPH,
    // contact: ~1 m) keep the step's grid and its order; so do periodic worlds.
    double reach = 0;
    for (double r : rangeOfGroup) reach = std::max(reach, r);
    group_ = &group;
    rangeOfGroup_ = rangeOfGroup;
    if (!world.periodic() && reach >= kFineGridFrom && !positions.empty()) {
        fine_.build(positions, reach / kFineGridCells);
        return fine_;
    }
    return stepGrid;
}

template <class Open>
std::size_t NeighbourLists::gatherAgents(const PointGrid& grid, const Vec2& p, double r, int self, Open&& open) const {
    // The runs of order() to scan (plane grids, at most kMaxRuns rows), found once for both the
    // room to ask for (every candidate plus what a vector gather may write past its last entry)
    // and the gather; else (a torus, a huge radius) forEachCandidate.
    Run runs[kMaxRuns];
    int nRuns = 0;
    std::size_t candidates = 0;
    if (!grid.periodic() && grid.rowRuns(p, r, runs, kMaxRuns, nRuns, candidates))
        return gatherRunsOn(gGatherPath.load(std::memory_order_relaxed), grid, runs, nRuns, p, r, self,
                            open(candidates + kGatherSlack));
    return gatherGeneric(grid, p, r, self, open(grid.candidateCount(p, r)));
}

void NeighbourLists::build(const std::vector<Vec2>& positions, const PointGrid& stepGrid, const World& world,
                           const std::vector<int>& group, const std::vector<double>& rangeOfGroup) {
    const std::size_t n = positions.size();
    streaming_ = false;
    const PointGrid& grid = prepareGrid(positions, stepGrid, world, group, rangeOfGroup);
    gridUsed_ = &grid;  // offset() reads these
    positions_ = &positions;
    periodic_ = world.periodic();
    const int threads = std::max(1, omp_get_max_threads());
    if (buffers_.size() < static_cast<std::size_t>(threads)) {
        buffers_.resize(static_cast<std::size_t>(threads));
        scratch_.resize(static_cast<std::size_t>(threads));
    }
    slices_.resize(n);

#pragma omp parallel num_threads(threads) if (parallelNeighbourLoop(n))
    {
        const int t = omp_get_thread_num();
        BlockBuffer<int>& out = buffers_[static_cast<std::size_t>(t)];
        std::vector<int>& near = scratch_[static_cast<std::size_t>(t)];
        out.clear();
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const double r = rangeOfGroup[static_cast<std::size_t>(group[i])];
            // The segments first, so that the room asked for covers both lists: the agents' list,
            // then the segments written over whatever the gather wrote past its last entry.
            world.segmentsNear(positions[i], r, near);
            Place at;
            int* list = nullptr;
            const std::size_t count = gatherAgents(grid, positions[i], r, static_cast<int>(i), [&](std::size_t most) {
                return list = out.open(at, most + near.size());
            });
            std::copy(near.begin(), near.end(), list + count);
            out.close(at, count + near.size());
            slices_[i] = slice(t, at, count, near.size());
        }
    }
}

void NeighbourLists::bind(const std::vector<Vec2>& positions, const PointGrid& stepGrid, const World& world,
                          const std::vector<int>& group, const std::vector<double>& rangeOfGroup) {
    gridUsed_ = &prepareGrid(positions, stepGrid, world, group, rangeOfGroup);
    positions_ = &positions;
    world_ = &world;
    periodic_ = world.periodic();
    streaming_ = true;
    // No stored lists (size() = 0) until the next build(); the buffers keep their blocks.
    slices_.clear();
}

std::span<const NeighbourAgent> NeighbourLists::agents(std::size_t i, std::vector<NeighbourAgent>& scratch) const {
    const std::span<const int> list = indices(i);
    if (scratch.size() < list.size()) scratch.resize(std::max(list.size(), 2 * scratch.size()));
    NeighbourAgent* out = scratch.data();
    if (periodic_) {
        for (std::size_t k = 0; k < list.size(); ++k) out[k] = NeighbourAgent{offset(i, list[k]), list[k]};
        return {out, list.size()};
    }
    // The plane's offsets, p_j − p_i, exactly as the gather computed them from the grid's copy.
    const Vec2* p = positions_->data();
    const Vec2 pi = p[i];
    for (std::size_t k = 0; k < list.size(); ++k) {
        const int j = list[k];
        out[k] = NeighbourAgent{p[static_cast<std::size_t>(j)] - pi, j};
    }
    return {out, list.size()};
}

void NeighbourLists::gather(std::size_t i, Scratch& scratch, std::span<const NeighbourAgent>& agents,
                            std::span<const int>& segments) const {
    const Vec2& p = (*positions_)[i];
    const double r = rangeOfGroup_[static_cast<std::size_t>((*group_)[i])];
    const std::size_t count = gatherAgents(*gridUsed_, p, r, static_cast<int>(i), [&](std::size_t most) {
        // Grows to the largest list of the run; resize() writes only the new entries.
        if (scratch.agents.size() < most) scratch.agents.resize(std::max(most, 2 * scratch.agents.size()));
        return scratch.agents.data();
    });
    agents = {scratch.agents.data(), count};
    world_->segmentsNear(p, r, scratch.segments);
    segments = {scratch.segments.data(), scratch.segments.size()};
}

}  // namespace ch
