// CrowdHealth — crowd measures on a grid, heat map and safety verdict (see safety.h).
#include "crowdhealth/health/safety.h"

#include "crowdhealth/core/cpu_features.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/simd.h"
#include "crowdhealth/health/health.h"
#include "crowdhealth/io/output.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>

#include <omp.h>

// simd's vectors pass by value between inlined helpers only: no call crosses an ABI.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace ch {

namespace {

int cellIndex(double v, double c) { return floorToInt(v / c); }

std::string fmt(double v, int digits = 3) { return formatNumber(v, digits); }

/// The dense rectangle of the crowd field as the scatter sees it: columns x0 … x0 + nx − 1, rows
/// y0 … y0 + ny − 1. The sums of cell (x, y) sit at (y − y0)·stride + pad + (x − x0): each row has
/// `pad` slots of padding before its columns and stride − pad − nx after them, enough for every
/// agent's whole reach box (its columns beyond the rectangle land in its own row's padding, never
/// in another row, which another thread may own; the padding is never read).
struct ScatterGrid {
    int x0 = 0, y0 = 0, nx = 0, ny = 0;
    std::size_t stride = 0, pad = 0;
    /// Columns (and rows) of an agent's reach box: every cell centre within reach of an agent lies
    /// in the box of `box` columns from ceil(cx − rc) and `box` rows from ceil(cy − rc), where
    /// (cx, cy) is its place in cell units less ½ and rc the reach in cells (with a margin).
    int box = 0;
    double cellSize = 1, invCell = 1, reachCells = 0, reach2 = 0, negInvR2 = 0;
};

/// d = p − (k + ½)·c for the cells k = k0 … k0 + W − 1 of a row (or column), its square dd and
/// e = e^{dd·s} (s = −1/R²; simd::expNonPositive). `half` holds l + ½ in lane l.
template <class V>
[[gnu::always_inline]] inline void boxWeights(double p, int k0, V half, V c, V s, V& dd, V& e) {
    const V d = simd::splatAs<V>(p) - (simd::splatAs<V>(static_cast<double>(k0)) + half) * c;
    dd = d * d;
    e = simd::expNonPositive(dd * s);
}

/// Lane l of v in every lane (GCC: one permute, where a load of the lane from a vector just
/// stored would wait for the store).
template <class V>
[[gnu::always_inline]] inline V laneOf(V v, int l) {
#if defined(__GNUC__) && !defined(__clang__)
    return __builtin_shuffle(v, simd::MaskOf<V>{} + l);
#else
    return simd::splatAs<V>(v[l]);
#endif
}

/// The weights of W cells of a row added to their sums at `at`: w = wx·wy where xx + yy ≤ r2, +0
/// elsewhere; w·v is ±0 where w is +0, and adding it leaves the sum as it was.
template <class V>
[[gnu::always_inline]] inline void addWeights(double* sw, double* swx, double* swy, std::size_t at, V xx, V wx, V yy,
                                              V wy, V r2, V vx, V vy) {
    const V w = simd::sel(simd::le(xx + yy, r2), wx * wy, V{});
    V sa, sb, sd;
    std::memcpy(&sa, sw + at, sizeof sa);
    std::memcpy(&sb, swx + at, sizeof sb);
    std::memcpy(&sd, swy + at, sizeof sd);
    sa += w;
    sb += w * vx;
    sd += w * vy;
    std::memcpy(sw + at, &sa, sizeof sa);
    std::memcpy(swx + at, &sb, sizeof sb);
    std::memcpy(swy + at, &sd, sizeof sd);
}

/// Adds the Gaussian weights of agents [0, n) to the cells of rows [rowLo, rowHi] (a band; every
/// agent within reach of it, in agent order): sw += w, swx += w·v.x, swy += w·v.y, where
/// w = e^{−dx²/R²}·e^{−dy²/R²} for the centres with dx² + dy² ≤ reach², and +0 elsewhere in the
/// vectors written (which leaves a sum as it was: a sum is never −0, it starts at +0). Each cell's
/// sums are those of the agents in order whatever the bands, so the bits do not depend on how the
/// rows are shared, nor on the width of V. An agent adds to its rows within reach, each in whole
/// vectors from its first column within reach: one vector when g.box columns fit in V (the
/// default 1-m cells in eight lanes), its d² and weights then kept in registers; otherwise the
/// vectors of its own columns within reach (4 or 5 at the default cells: one vector of four lanes
/// for 4 in 5 agents). The exponentials of the columns and rows are computed lane by lane, so a
/// weight's bits do not depend on its lane. (Until issue 20's eighteenth round the columns went
/// four at a time from a buffer of d² and weights, with a skip per row: 1.2x the time in AVX2, 2x
/// in the generic build.)
template <class V>
[[gnu::always_inline]] inline void scatterBoxes(const Vec2* pos, const Vec2* vel, std::size_t n, const ScatterGrid& g,
                                                int rowLo, int rowHi, double* sw, double* swx, double* swy) {
    constexpr int W = static_cast<int>(sizeof(V) / sizeof(double));
    // The grid's numbers in locals: the sums are written through memcpy, which may alias anything,
    // so fields read through `g` would be loaded again after every store.
    const int B = g.box, chunks = (B + W - 1) / W, x0 = g.x0, y0 = g.y0;
    const std::size_t stride = g.stride, pad = g.pad;
    const double invCell = g.invCell, reachCells = g.reachCells;
    // Per agent: the columns' d² and weights, chunk by chunk, and the rows'. (Arrays of doubles
    // loaded by memcpy: a std::vector of 64-byte vectors is not 64-byte aligned.)
    std::vector<double> buffer(4 * static_cast<std::size_t>(chunks * W));
    double* const dx2 = buffer.data();
    double* const ex = dx2 + chunks * W;
    double* const dy2 = ex + chunks * W;
    double* const ey = dy2 + chunks * W;
    V iota;
    for (int l = 0; l < W; ++l) iota[l] = l + 0.5;  // lane l: column xa + l, its centre at + ½
    const V r2 = simd::splatAs<V>(g.reach2), s = simd::splatAs<V>(g.negInvR2), c = simd::splatAs<V>(g.cellSize);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec2 p = pos[i];
        // The rows and columns whose centre may lie within reach: |p − (k + ½)·c| ≤ reach, in
        // units of cells (the disc test decides): ya … yb, xa … xb, at most B of each.
        const double cy = p.y() * invCell - 0.5;
        const int ya = static_cast<int>(std::ceil(cy - reachCells)), yb = static_cast<int>(std::floor(cy + reachCells));
        if (ya > rowHi || yb < rowLo) continue;
        const double cx = p.x() * invCell - 0.5;
        const int xa = static_cast<int>(std::ceil(cx - reachCells));
        const V vx = simd::splatAs<V>(vel[i].x()), vy = simd::splatAs<V>(vel[i].y());
        const int r0 = std::max(ya, rowLo), r1 = std::min(yb, rowHi);
        const std::size_t first = static_cast<std::size_t>(r0 - y0) * stride + pad +
                                  static_cast<std::size_t>(static_cast<std::ptrdiff_t>(xa) - x0);
        if (chunks == 1) {  // the box's columns in one vector, kept in registers
            V xx, wx, yy, wy;
            boxWeights(p.x(), xa, iota, c, s, xx, wx);
            boxWeights(p.y(), ya, iota, c, s, yy, wy);
            std::size_t at = first;
            for (int r = r0; r <= r1; ++r, at += stride) {
                // Row r's d² and weight in every lane, taken from the registers.
                addWeights(sw, swx, swy, at, xx, wx, laneOf(yy, r - ya), laneOf(wy, r - ya), r2, vx, vy);
            }
            continue;
        }
        // Several vectors a row: those of this agent's columns within reach.
        const int xb = static_cast<int>(std::floor(cx + reachCells));
        const int columnChunks = (xb - xa + W) / W, rowChunks = (yb - ya + W) / W;
        for (int k = 0; k < columnChunks; ++k) {
            V xx, wx;
            boxWeights(p.x(), xa + k * W, iota, c, s, xx, wx);
            std::memcpy(dx2 + k * W, &xx, sizeof xx);
            std::memcpy(ex + k * W, &wx, sizeof wx);
        }
        for (int k = 0; k < rowChunks; ++k) {
            V yy, wy;
            boxWeights(p.y(), ya + k * W, iota, c, s, yy, wy);
            std::memcpy(dy2 + k * W, &yy, sizeof yy);
            std::memcpy(ey + k * W, &wy, sizeof wy);
        }
        std::size_t at = first;
        for (int r = r0; r <= r1; ++r, at += stride) {
            const V dyy = simd::splatAs<V>(dy2[r - ya]), wy = simd::splatAs<V>(ey[r - ya]);
            for (int k = 0; k < columnChunks; ++k) {
                V xx, wx;
                std::memcpy(&xx, dx2 + k * W, sizeof xx);
                std::memcpy(&wx, ex + k * W, sizeof wx);
                addWeights(sw, swx, swy, at + static_cast<std::size_t>(k * W), xx, wx, dyy, wy, r2, vx, vy);
            }
        }
    }
}

// Three builds of the scatter, chosen when the program starts (crowdFieldPath): two lanes in one
// SSE2 register (every x86-64 CPU and others; four lanes in two registers spilled and took 1.4x
// longer), four in one AVX2 register, eight in one AVX-512 register. The same operations lane by
// lane and no fused multiply-add (fp-contract=off: GCC would contract a·b + c where the target has
// FMA, as AVX-512F does), so all give the same bits (Tests/health_safety_grid_test.cpp compares
// them).
#if defined(__GNUC__) && !defined(__clang__)
#define CH_FIELD_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define CH_FIELD_NO_CONTRACT
#endif
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_FIELD_X86 1
#endif

CH_FIELD_NO_CONTRACT
void scatterGeneric(const Vec2* pos, const Vec2* vel, std::size_t n, const ScatterGrid& g, int rowLo, int rowHi,
                    double* sw, double* swx, double* swy) {
    scatterBoxes<simd::DV2>(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
}

#ifdef CH_FIELD_X86
__attribute__((target("avx2"))) CH_FIELD_NO_CONTRACT
void scatterAvx2(const Vec2* pos, const Vec2* vel, std::size_t n, const ScatterGrid& g, int rowLo, int rowHi,
                 double* sw, double* swx, double* swy) {
    scatterBoxes<simd::DV>(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
}

__attribute__((target("avx512f,avx512dq,avx512vl"))) CH_FIELD_NO_CONTRACT
void scatterAvx512(const Vec2* pos, const Vec2* vel, std::size_t n, const ScatterGrid& g, int rowLo, int rowHi,
                   double* sw, double* swx, double* swy) {
    scatterBoxes<simd::DV8>(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
}
#endif

/// The scatter's build in use: the best this CPU runs, found once when the program starts.
std::atomic<int> gScatterPath{cpu::bestBuild()};

void scatterRows(const Vec2* pos, const Vec2* vel, std::size_t n, const ScatterGrid& g, int rowLo, int rowHi,
                 double* sw, double* swx, double* swy) {
#ifdef CH_FIELD_X86
    switch (gScatterPath.load(std::memory_order_relaxed)) {
    case 2: return scatterAvx512(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
    case 1: return scatterAvx2(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
    default: break;
    }
#endif
    scatterGeneric(pos, vel, n, g, rowLo, rowHi, sw, swx, swy);
}
}  // namespace

const ParamTable& safetyTable() {
    static const ParamTable t = [] {
        const SafetyThresholds d;
        ParamTable table = {
            ParamSpec::real("cell_size", "m", d.cellSize, 0.25, 50,
                            "cell of the grid on which density and crowd pressure are evaluated (and of heatmap.csv)"),
            ParamSpec::real("gaussian_radius", "m", d.gaussianRadius, 0, 5,
                            "R of the Gaussian weights exp(-d^2/R^2)/(pi R^2) of Helbing et al. 2007"),
            ParamSpec::real("density_caution", "persons/m2", d.densityCaution, 0, 100,
                            "local density above which the verdict says caution (Fruin: level of service F)"),
            ParamSpec::real("density_dangerous", "persons/m2", d.densityDangerous, 0, 100,
                            "... dangerous (Still: moving crowds at risk)"),
            ParamSpec::real("density_critical", "persons/m2", d.densityCritical, 0, 100,
                            "... critical (Still: crowd collapse)"),
            ParamSpec::real("crowd_pressure", "1/s2", d.crowdPressureCritical, 0, 1e6,
                            "crowd pressure above which (where the density is above density_caution) the verdict says "
                            "dangerous (Helbing et al. 2007: crowd turbulence)"),
            ParamSpec::real("pressure_window", "s", d.pressureWindow, 0, 1e4,
                            "time constant of the time averages at each place in the crowd pressure "
                            "(density x variance in time of the local velocity)"),
            ParamSpec::real("min_duration", "s", d.minDuration, 0, 1e6,
                            "seconds a density or pressure condition must hold, anywhere, to count"),
            ParamSpec::real("dose_dangerous_fraction", "-", d.doseDangerousFraction, 0, 1,
                            "crush is dangerous once someone's dose reaches this share of the policy's injuryDose"),
            ParamSpec::real("flow_capacity", "P/(m*s)", d.flowCapacity, 0, 100,
                            "specific flow of an exit or measurement line above which (held min_duration) the "
                            "verdict says caution (IMO/SFPE: 1.33)"),
            ParamSpec::real("flow_window", "s", d.flowWindow, 0, 1e4,
                            "the specific flow compared with flow_capacity counts the crossings of this many seconds"),
        };
        // Strictly positive quantities, except min_duration (0 = one step is enough) and cell_size,
        // whose lower limit 0.25 m is itself allowed (finer cells only multiply the grid's size).
        for (ParamSpec& p : table)
            if (p.name != "min_duration" && p.name != "cell_size") p.minExclusive = true;
        return table;
    }();
    return t;
}

namespace {
constexpr double kSquareFoot = 0.09290304;  // m²
/// Fruin's walkway levels: the area per person (ft²) at which each of A…E begins.
constexpr double kFruinFeet[] = {35, 25, 15, 10, 5};

/// Fruin's level as defined: the first whose lower bound of area per person (ft²) the density's
/// area per person reaches.
char fruinLevelByArea(double density) {
    if (!(density > 0)) return 'A';
    const double feet = 1.0 / density / kSquareFoot;  // area per person, ft²
    for (int k = 0; k < 5; ++k)
        if (feet >= kFruinFeet[k]) return static_cast<char>('A' + k);
    return 'F';
}

/// bounds[k] = the largest density that fruinLevelByArea puts at level A + k or better (k = 0…4).
/// The area per person falls as the density rises, rounding included (a division by a positive
/// number is monotone), so the level is monotone in the density and these five numbers give it
/// exactly: the level is A + the count of bounds below the density. Found once by bisection over
/// the bits of the positive doubles (they order as their integer images).
struct FruinBounds {
    double bounds[5];
    FruinBounds() {
        for (int k = 0; k < 5; ++k) {
            std::uint64_t lo = 0, hi = 0x7ff0000000000000u;  // +0 (level A), +inf (level F)
            auto level = [](std::uint64_t bits) {
                double d;
                std::memcpy(&d, &bits, sizeof d);
                return fruinLevelByArea(d) - 'A';
            };
            while (hi - lo > 1) {
                const std::uint64_t mid = lo + (hi - lo) / 2;
                (level(mid) <= k ? lo : hi) = mid;
            }
            std::memcpy(&bounds[k], &lo, sizeof lo);
        }
    }
};

/// Fruin's level 0 (A) … 5 (F) of a density, as fruinLevelByArea gives it, by five comparisons
/// instead of two divisions (the safety recorder's update compares with the bounds itself). NaN
/// and densities ≤ 0 are level A.
const FruinBounds fruinBounds;  // before main (this file's constants are constexpr)

inline int fruinIndex(double density) {
    int level = 0;
    for (const double bound : fruinBounds.bounds) level += density > bound;
    return level;
}

/// The numbers of one record that every cell's update reads (SafetyRecorder::recordAt).
struct CellRecord {
    double previous = 0;  ///< the last record's time (NaN at the first)
    double dt = 0;        ///< t − previous (0 at the first record)
    double t = 0, alpha = 0;
    double minDuration = 0, pressureCritical = 0, densityCaution = 0;
    double levels[3] = {0, 0, 0};  ///< density caution, dangerous, critical
    bool withContact = false;      ///< the contact maxima count (a record with the health layer)
};

/// A block's inputs from the crowd field, lane l at index l of each.
struct BlockInput {
    const double* density = nullptr;
    const double* contact = nullptr;  ///< read only when CellRecord::withContact
    const Vec2* velocity = nullptr;
    const unsigned char* weighted = nullptr;
    const int* people = nullptr;
};

/// What a share of the cells adds up, lane by lane (each exact in any order): per condition the
/// people in the cells where it held (whole numbers in doubles, exact below 2^53) and 1 where it
/// held at all, and the largest pressure.
struct BlockTally {
    double people[4][8] = {};
    double held[4][8] = {};
    double maxPressure[8] = {};
};

/// The mask of V's comparisons (simd.h: all-ones lanes, or an AVX-512 mask register).
template <class V>
using LaneMask = decltype(simd::lt(V{}, V{}));

/// Bits [0, W) of `bits` as a mask of V (bit l: lane l).
template <class V>
[[gnu::always_inline]] inline LaneMask<V> lanesOf(unsigned bits) {
    using M = LaneMask<V>;
    if constexpr (sizeof(M) == 1) {  // AVX-512: a mask register
        return static_cast<M>(bits);
    } else {
        M m;
        for (int l = 0; l < static_cast<int>(sizeof(V) / sizeof(double)); ++l)
            m[l] = -static_cast<std::int64_t>((bits >> l) & 1u);
        return m;
    }
}

/// One record's update of the cells of a block (SafetyRecorder::CellBlock), the lanes of `mask`
/// only (all of them when Full), in vectors V of two, four or eight lanes: a cell's maxima, the
/// runs of Fruin's levels, the seconds above the density levels, the time averages of the crowd
/// pressure and the seconds above its level. Each lane is the operations of the update one cell at
/// a time that it replaced (issue 20), in the same order with the same roundings and no fused
/// multiply-add (the builds below), so a cell holds the same bits whatever its lane and the
/// build. std::max(a, b) is written sel(lt(a, b), b, a).
template <class V, bool Full, class Block>
[[gnu::always_inline]] inline void updateCells(Block& b, const BlockInput& in, unsigned mask, const CellRecord& r,
                                               BlockTally& tally) {
    using simd::eq;
    using simd::le;
    using simd::lt;
    using simd::sel;
    using M = LaneMask<V>;
    using Index = simd::MaskOf<V>;  // 64-bit integers, one per lane
    constexpr int W = static_cast<int>(sizeof(V) / sizeof(double));
    const auto load = [](const double* p) {
        V v;
        std::memcpy(&v, p, sizeof v);
        return v;
    };
    const auto put = [](double* p, V v) { std::memcpy(p, &v, sizeof v); };
    const V dt = simd::splatAs<V>(r.dt), zero = V{}, one = simd::splatAs<V>(1.0);
    const M all = simd::allLanes(V{});
    // A cell's runs and averages go on where it was evaluated at the previous record (`previous`
    // is NaN at the first record, equal to no time; later records have dt > 0).
    const V previous = simd::splatAs<V>(r.previous), now = simd::splatAs<V>(r.t);
    Index even, odd;  // the x and y of W interleaved Vec2s
    for (int l = 0; l < W; ++l) even[l] = 2 * l, odd[l] = 2 * l + 1;
    for (int at = 0; at < 8; at += W) {
        const M on = Full ? all : lanesOf<V>(mask >> at);
        // Field p of the block set to v in the lanes of m (and of the mask), the others as they were;
        // in every lane of the mask (setAll).
        const auto store = [&](double* p, V v, M m) { put(p + at, sel(Full ? m : M(m & on), v, load(p + at))); };
        const auto setAll = [&](double* p, V v) { put(p + at, Full ? v : sel(on, v, load(p + at))); };
        // A condition held in the lanes of m: its people and that it held, in the tally.
        const auto count = [&](int c, M m, V people) {
            put(tally.people[c] + at, load(tally.people[c] + at) + sel(m, people, zero));
            put(tally.held[c] + at, sel(m, one, load(tally.held[c] + at)));
        };
        const V d = load(in.density + at);
        const V maxD = load(b.maxDensity + at);
        setAll(b.maxDensity, sel(lt(maxD, d), d, maxD));
        if (r.withContact) {
            const V c = load(in.contact + at), maxC = load(b.maxContact + at);
            setAll(b.maxContact, sel(lt(maxC, c), c, maxC));
        }
        // Fruin's levels: how long each has held here without a break (a cell missed by a record
        // — nobody within reach — starts again). The runs never grow with the level (each level's
        // run holds whenever a worse one's does), so the levels that held for minDuration are
        // B … B + m − 1, and m counts them. Level l (B = 1) or worse holds above the l-th of
        // fruinBounds' ascending bounds.
        const M continues = eq(load(b.losAt + at), previous);
        V lasted = zero;
        for (int l = 1; l <= 5; ++l) {
            const M level = lt(simd::splatAs<V>(fruinBounds.bounds[l - 1]), d);
            const V run = sel(M(level & continues), load(b.losRun[l - 1] + at) + dt, zero);
            setAll(b.losRun[l - 1], run);
            lasted += sel(M(level & le(simd::splatAs<V>(r.minDuration), run)), one, zero);
        }
        for (int l = 0; l < W; ++l)
            if (Full || ((mask >> (at + l)) & 1u)) {
                char& worst = b.worstLos[at + l];
                worst = std::max(worst, static_cast<char>('A' + static_cast<int>(lasted[l])));
            }
        setAll(b.losAt, now);
        V people;
        for (int l = 0; l < W; ++l) people[l] = static_cast<double>(in.people[at + l]);
        for (int l = 0; l < 3; ++l) {
            const M above = Full ? lt(simd::splatAs<V>(r.levels[l]), d) : M(lt(simd::splatAs<V>(r.levels[l]), d) & on);
            store(b.seconds[l], load(b.seconds[l] + at) + dt, above);
            count(l, above, people);
        }
        // Crowd pressure: the variance in time of the local velocity at this place, times the
        // local density (both averaged over the window). A cell with no agent within reach has no
        // local velocity; its averages restart when agents come back.
        V weightedLanes;
        for (int l = 0; l < W; ++l) weightedLanes[l] = in.weighted[at + l];
        const M weighted = Full ? lt(zero, weightedLanes) : M(lt(zero, weightedLanes) & on);
        const V v0 = load(reinterpret_cast<const double*>(in.velocity + at));
        const V v1 = load(reinterpret_cast<const double*>(in.velocity + at) + W);
        const V vx = __builtin_shuffle(v0, v1, even), vy = __builtin_shuffle(v0, v1, odd);
        const M sampled = eq(load(b.sampledAt + at), previous);
        const V w = sel(sampled, simd::splatAs<V>(r.alpha), one);
        const V md0 = load(b.meanDensity + at), mx0 = load(b.meanVelocityX + at), my0 = load(b.meanVelocityY + at),
                ms0 = load(b.meanSquaredSpeed + at);
        const V md = md0 + w * (d - md0);
        const V mx = mx0 + w * (vx - mx0), my = my0 + w * (vy - my0);
        const V ms = ms0 + w * ((vx * vx + vy * vy) - ms0);
        store(b.meanDensity, md, weighted);
        store(b.meanVelocityX, mx, weighted);
        store(b.meanVelocityY, my, weighted);
        store(b.meanSquaredSpeed, ms, weighted);
        store(b.sampledAt, now, weighted);
        const V spread = ms - (mx * mx + my * my);
        const V pressure = sel(weighted, md * sel(lt(zero, spread), spread, zero), zero);
        const V maxP = load(tally.maxPressure + at);
        put(tally.maxPressure + at, sel(lt(maxP, pressure), pressure, maxP));
        // Crowd turbulence is a dense-crowd phenomenon (Helbing et al. 2007 observed it at 7–9
        // persons/m²). Where people merely pass the same place in different directions at low
        // density (crossings, counter-flows), the local velocity also varies in time, so the
        // pressure counts only where the density is above Fruin's level F as well
        // (docs/crowd-health.md shows a sparse crossing that needs this gate).
        const M turbulent = M(lt(simd::splatAs<V>(r.pressureCritical), pressure) &
                              lt(simd::splatAs<V>(r.densityCaution), sel(weighted, md, md0)));
        store(b.seconds[3], load(b.seconds[3] + at) + dt, turbulent);
        count(3, turbulent, people);
    }
}

// Three builds of the cells' update, chosen with the scatter's (crowdFieldPath): two lanes in
// SSE2 registers, four in AVX2, eight in AVX-512 (GCC 12 compares 512-bit vectors of its own
// lane by lane: simd.h's mask helpers). No fused multiply-add.
template <bool Full, class Block>
CH_FIELD_NO_CONTRACT void updateCellsGeneric(Block& b, const BlockInput& in, unsigned mask, const CellRecord& r,
                                             BlockTally& tally) {
    updateCells<simd::DV2, Full>(b, in, mask, r, tally);
}

#ifdef CH_FIELD_X86
template <bool Full, class Block>
__attribute__((target("avx2"))) CH_FIELD_NO_CONTRACT void updateCellsAvx2(Block& b, const BlockInput& in,
                                                                          unsigned mask, const CellRecord& r,
                                                                          BlockTally& tally) {
    updateCells<simd::DV, Full>(b, in, mask, r, tally);
}

template <bool Full, class Block>
__attribute__((target("avx512f,avx512dq,avx512vl"))) CH_FIELD_NO_CONTRACT void updateCellsAvx512(
    Block& b, const BlockInput& in, unsigned mask, const CellRecord& r, BlockTally& tally) {
    updateCells<simd::DV8, Full>(b, in, mask, r, tally);
}
#endif

template <bool Full, class Block>
using UpdateCells = void (*)(Block&, const BlockInput&, unsigned, const CellRecord&, BlockTally&);

/// The build of the cells' update in use (crowdFieldPath).
template <bool Full, class Block>
UpdateCells<Full, Block> updateCellsBuild() {
#ifdef CH_FIELD_X86
    switch (gScatterPath.load(std::memory_order_relaxed)) {
    case 2: return &updateCellsAvx512<Full, Block>;
    case 1: return &updateCellsAvx2<Full, Block>;
    default: break;
    }
#endif
    return &updateCellsGeneric<Full, Block>;
}

}  // namespace

char fruinLevel(double density) { return static_cast<char>('A' + fruinIndex(density)); }

double fruinLowerDensity(char level) {
    // Level L (B…F) begins where the area per person drops below the lower bound of the level
    // before it.
    const int k = level - 'B';
    if (k < 0 || k > 4) return 0;
    return 1.0 / (kFruinFeet[k] * kSquareFoot);
}

double CrowdField::maxDensity() const {
    double m = 0;
    for (double d : density) m = std::max(m, d);
    return m;
}

std::size_t CrowdField::find(int x, int y) const {
    if (size() == 0) return 0;
    if (keys_.empty()) {  // the whole rectangle [ix.front(), ix.back()] × [iy.front(), iy.back()]
        if (x < ix.front() || x > ix.back() || y < iy.front() || y > iy.back()) return size();
        return static_cast<std::size_t>(y - iy.front()) * static_cast<std::size_t>(ix.back() - ix.front() + 1) +
               static_cast<std::size_t>(x - ix.front());
    }
    const std::uint64_t key = cellKey(x, y);
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    return it != keys_.end() && *it == key ? static_cast<std::size_t>(it - keys_.begin()) : size();
}

std::uint64_t CrowdField::cellKey(int x, int y) {
    // y outer, x inner, both shifted to unsigned so that the keys sort as (y, x).
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(y) ^ 0x80000000u) << 32) |
           static_cast<std::uint64_t>(static_cast<std::uint32_t>(x) ^ 0x80000000u);
}

CrowdField crowdField(const AgentStore& agents, double cellSize, double R) {
    CrowdField f;
    f.cellSize = cellSize;
    const std::size_t n = agents.size();
    if (n == 0) return f;
    const double reach = 3.0 * R;  // the weight is below e^-9 beyond
    double xmin = agents.pos[0].x(), xmax = xmin, ymin = agents.pos[0].y(), ymax = ymin;
    for (const Vec2& p : agents.pos) {
        xmin = std::min(xmin, p.x());
        xmax = std::max(xmax, p.x());
        ymin = std::min(ymin, p.y());
        ymax = std::max(ymax, p.y());
    }
    // The cells: every cell of the rectangle covering the agents (one cell of margin) while that
    // is at most kMaxDenseCells; for a crowd scattered far apart, only the cells within reach of
    // an agent (the others have no agent within reach: density 0, no local velocity).
    constexpr double kMaxDenseCells = 1 << 22;
    const double spanX = std::floor(xmax / cellSize) - std::floor(xmin / cellSize) + 3;
    const double spanY = std::floor(ymax / cellSize) - std::floor(ymin / cellSize) + 3;
    if (spanX * spanY <= kMaxDenseCells) {
        const int ix0 = cellIndex(xmin, cellSize) - 1, iy0 = cellIndex(ymin, cellSize) - 1;
        const int nx = static_cast<int>(spanX), ny = static_cast<int>(spanY);
        f.ix.resize(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
        f.iy.resize(f.ix.size());
        for (int y = 0; y < ny; ++y) {
            const std::size_t row = static_cast<std::size_t>(y) * static_cast<std::size_t>(nx);
            for (int x = 0; x < nx; ++x) {
                f.ix[row + static_cast<std::size_t>(x)] = ix0 + x;
                f.iy[row + static_cast<std::size_t>(x)] = iy0 + y;
            }
        }
    } else {
        const int k = static_cast<int>(std::ceil(reach / cellSize));
        std::vector<std::uint64_t> keys;
        keys.reserve(n * static_cast<std::size_t>((2 * k + 1) * (2 * k + 1)));
        for (const Vec2& p : agents.pos) {
            const int cx = cellIndex(p.x(), cellSize), cy = cellIndex(p.y(), cellSize);
            for (int dy = -k; dy <= k; ++dy)
                for (int dx = -k; dx <= k; ++dx) keys.push_back(CrowdField::cellKey(cx + dx, cy + dy));
        }
        std::sort(keys.begin(), keys.end());
        keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
        for (const std::uint64_t key : keys) {
            f.ix.push_back(static_cast<int>(static_cast<std::uint32_t>(key & 0xffffffffu) ^ 0x80000000u));
            f.iy.push_back(static_cast<int>(static_cast<std::uint32_t>(key >> 32) ^ 0x80000000u));
        }
    }
    const std::size_t cells = f.ix.size();
    // A whole rectangle needs no keys: find() locates its cells by row and column.
    const bool dense = cells > 0 && cells == static_cast<std::size_t>(f.ix.back() - f.ix.front() + 1) *
                                                 static_cast<std::size_t>(f.iy.back() - f.iy.front() + 1);
    if (!dense) {
        f.keys_.resize(cells);
        for (std::size_t c = 0; c < cells; ++c) f.keys_[c] = CrowdField::cellKey(f.ix[c], f.iy[c]);
    }
    f.density.assign(cells, 0.0);
    f.velocity.assign(cells, Vec2(0, 0));
    f.weighted.assign(cells, 0);
    f.people.assign(cells, 0);
    const int nx = cells > 0 ? f.ix.back() - f.ix.front() + 1 : 0;
    f.cellOfAgent.resize(n);
    // The entry of each agent's cell (entries in [0, cells)) and the count of those in entries
    // [from, to): a band of rows counts its own cells' people.
    const auto cellOf = [&](std::size_t i) {
        const Vec2& p = agents.pos[i];
        f.cellOfAgent[i] = static_cast<std::uint32_t>(f.find(cellIndex(p.x(), cellSize), cellIndex(p.y(), cellSize)));
    };
    const auto countPeople = [&](std::size_t from, std::size_t to) {
        for (std::size_t i = 0; i < n; ++i)
            if (const std::size_t c = f.cellOfAgent[i]; c >= from && c < to) ++f.people[c];
    };
    const double norm = 1.0 / (kPi * R * R), invR2 = 1.0 / (R * R);
    if (dense) {
        // Dense rectangle: each agent adds its weight to the cell centres within reach (a scatter,
        // in agent order: no query per cell). The Gaussian is separable,
        // e^{−(dx²+dy²)/R²} = e^{−dx²/R²}·e^{−dy²/R²}, and the centres lie on a lattice: per agent
        // one exponential per column and per row of its reach box (simd::expNonPositive, in vectors
        // of two to eight lanes: scatterBoxes) instead of one per cell, and a product per cell.
        // The cells counted are those of the disc test dx² + dy² ≤ reach²; the weights differ from e^{−d²/R²} in the last bits
        // (the product of two rounded exponentials, each within 3e-16). (The query per cell with
        // glibc's exp was ~8 % of a 10k-agent social-forces run, issue 20.) With several threads,
        // each owns a band of rows and walks the agents within reach of it, in agent order: the
        // sums of a cell are the same bits for any thread count.
        ScatterGrid g;
        g.x0 = f.ix.front();
        g.y0 = f.iy.front();
        g.nx = nx;
        g.ny = f.iy.back() - g.y0 + 1;
        g.cellSize = cellSize;
        g.invCell = 1.0 / cellSize;
        // The reach in cells with a margin of 1e-6 cells for rounding (the disc test decides which
        // cells count): the centres within reach of an agent lie in floor(2·rc) + 1 columns from
        // ceil(cx − rc), whose start is at least x0 − ceil(rc) (every agent lies in a column of
        // the rectangle, which has a margin of one) and whose vectors end at most box + 7 columns
        // past it.
        g.reachCells = reach * g.invCell + 1e-6;
        g.box = static_cast<int>(std::floor(2 * g.reachCells)) + 1;
        g.pad = static_cast<std::size_t>(std::ceil(g.reachCells)) + 1;
        g.stride = g.pad + static_cast<std::size_t>(nx) + static_cast<std::size_t>(g.box) + 8;
        g.reach2 = reach * reach;
        g.negInvR2 = -invR2;
        // The three sums of each slot, not initialised here: each band zeroes its own rows.
        const std::size_t sumCells = static_cast<std::size_t>(g.ny) * g.stride;
        const std::unique_ptr<double[]> sums(new double[3 * sumCells]);
        double* const sw = sums.get();
        double* const swx = sw + sumCells;
        double* const swy = swx + sumCells;
        // Two bands or more only for a crowd that shares its loops (core/parallel.h) and rows
        // enough that a band is more than its agents' reach (each band walks every agent). All of
        // a record's work on the field is in the bands (issue 20: on two threads, the agents'
        // cells, the zeroing of the sums and the densities from them, done by one thread before
        // and after the bands, left the safety grid 1.3 times as fast as on one): the agents'
        // cells in static chunks, then each band's rows alone — its people, its sums and its
        // cells' density and velocity — the same bits for any number of bands.
        const int threads = parallelNeighbourLoop(n) ? std::max(1, std::min(omp_get_max_threads(), g.ny / 8)) : 1;
#pragma omp parallel num_threads(threads) if (threads > 1)
        {
            const long count = static_cast<long>(n);
#pragma omp for schedule(static)
            for (long i = 0; i < count; ++i) cellOf(static_cast<std::size_t>(i));
            const int t = omp_get_thread_num(), bands = omp_get_num_threads();
            const int lo = g.y0 + static_cast<int>(static_cast<long>(g.ny) * t / bands);
            const int hi = g.y0 + static_cast<int>(static_cast<long>(g.ny) * (t + 1) / bands) - 1;
            const std::size_t rowLo = static_cast<std::size_t>(lo - g.y0), rows = static_cast<std::size_t>(hi - lo + 1);
            countPeople(rowLo * static_cast<std::size_t>(nx), (rowLo + rows) * static_cast<std::size_t>(nx));
            std::fill_n(sw + rowLo * g.stride, rows * g.stride, 0.0);
            std::fill_n(swx + rowLo * g.stride, rows * g.stride, 0.0);
            std::fill_n(swy + rowLo * g.stride, rows * g.stride, 0.0);
            scatterRows(agents.pos.data(), agents.vel.data(), n, g, lo, hi, sw, swx, swy);
            // Without a branch per cell (so that the loop vectorises): a cell with no weight keeps
            // density 0, velocity (0, 0) and weighted 0.
            for (std::size_t y = rowLo; y < rowLo + rows; ++y) {
                const double* const a = sw + y * g.stride + g.pad;
                const double* const b = swx + y * g.stride + g.pad;
                const double* const c = swy + y * g.stride + g.pad;
                const std::size_t to = y * static_cast<std::size_t>(nx);
                double* const density = f.density.data() + to;
                Vec2* const velocity = f.velocity.data() + to;
                unsigned char* const weighted = f.weighted.data() + to;
                for (int x = 0; x < nx; ++x) {
                    const double w = a[x];
                    const bool in = w > 0;
                    density[x] = in ? norm * w : 0.0;
                    velocity[x] = in ? Vec2(b[x] / w, c[x] / w) : Vec2(0, 0);
                    weighted[x] = in;
                }
            }
        }
        return f;
    }
    for (std::size_t i = 0; i < n; ++i) cellOf(i);
    countPeople(0, cells);
    // Cells scattered far apart: a disc query per cell.
    PointGrid grid;
    grid.build(agents.pos, 0.5 * reach);  // half-size cells: fewer candidates per disc query
    const long count = static_cast<long>(cells);
#pragma omp parallel for schedule(static) if (count >= 4096)
    for (long k = 0; k < count; ++k) {
        const std::size_t c = static_cast<std::size_t>(k);
        const Vec2 centre = f.centre(f.ix[c], f.iy[c]);
        double sw = 0;
        Vec2 swv(0, 0);
        grid.forEachWithin(centre, reach, [&](int j, const Vec2&, double d2) {
            const double w = std::exp(-d2 * invR2);
            sw += w;
            swv += w * agents.vel[static_cast<std::size_t>(j)];
        });
        if (!(sw > 0)) continue;
        f.density[c] = norm * sw;
        f.velocity[c] = swv / sw;
        f.weighted[c] = 1;
    }
    return f;
}

int crowdFieldPath() { return gScatterPath.load(); }

bool setCrowdFieldPath(int path) {
    if (!cpu::runsBuild(path)) return false;
    gScatterPath.store(path);
    return true;
}

int verdictRank(const std::string& level) {
    if (level == "critical") return 3;
    if (level == "dangerous") return 2;
    if (level == "caution") return 1;
    return 0;
}

void SafetyRecorder::record(const Simulation& sim) { recordAt(sim.agents(), sim.time(), &sim.health()); }

void SafetyRecorder::recordCrowd(const AgentStore& agents, double t) { recordAt(agents, t, nullptr); }

int SafetyRecorder::TileStore::make() {
    static_assert(std::is_trivially_destructible_v<Tile>, "tiles are freed with their blocks, not destroyed");
    static_assert(kPerBlock >= 1, "a tile must fit in a block");
    if (count_ == blocks_.size() * kPerBlock) {
        blocks_.reserve(blocks_.size() + 1);
        blocks_.push_back(bigAllocate(kHugePage));
    }
    ::new (static_cast<void*>(&(*this)[static_cast<int>(count_)])) Tile();
    return static_cast<int>(count_++);
}

SafetyRecorder::TileStore::TileStore(const TileStore& o) {
    try {
        for (std::size_t k = 0; k < o.count_; ++k) (*this)[make()] = o[static_cast<int>(k)];
    } catch (...) {
        clear();
        throw;
    }
}

void SafetyRecorder::TileStore::clear() noexcept {
    for (void* b : blocks_) bigFree(b, kHugePage);
    blocks_.clear();
    count_ = 0;
}

bool SafetyRecorder::cover(int x0, int y0, int x1, int y1) {
    if (sparse_) return false;
    const int nx0 = x0 >> kTileBits, ny0 = y0 >> kTileBits, nx1 = x1 >> kTileBits, ny1 = y1 >> kTileBits;
    if (tnx_ > 0 && nx0 >= tx0_ && ny0 >= ty0_ && nx1 < tx0_ + tnx_ && ny1 < ty0_ + tny_) return true;
    // The union with the present index and kIndexSlack tiles more on each side that grows (a
    // crowd walking away moves the rectangle a little at every step); only tile numbers move.
    int ux0 = nx0, uy0 = ny0, ux1 = nx1, uy1 = ny1;
    if (tnx_ > 0) {
        ux0 = std::min(ux0, tx0_), uy0 = std::min(uy0, ty0_);
        ux1 = std::max(ux1, tx0_ + tnx_ - 1), uy1 = std::max(uy1, ty0_ + tny_ - 1);
        if (ux0 < tx0_) ux0 -= kIndexSlack;
        if (uy0 < ty0_) uy0 -= kIndexSlack;
        if (ux1 > tx0_ + tnx_ - 1) ux1 += kIndexSlack;
        if (uy1 > ty0_ + tny_ - 1) uy1 += kIndexSlack;
    }
    const double area = (static_cast<double>(ux1) - ux0 + 1) * (static_cast<double>(uy1) - uy0 + 1);
    if (area > kMaxIndexTiles) {
        goSparse();
        return false;
    }
    const int wx = ux1 - ux0 + 1, wy = uy1 - uy0 + 1;
    std::vector<int> index(static_cast<std::size_t>(wx) * static_cast<std::size_t>(wy), -1);
    for (int y = 0; y < tny_; ++y)
        std::copy_n(tiles_.begin() + static_cast<std::ptrdiff_t>(y) * tnx_, tnx_,
                    index.begin() + static_cast<std::ptrdiff_t>(y + ty0_ - uy0) * wx + (tx0_ - ux0));
    tiles_ = std::move(index);
    tx0_ = ux0, ty0_ = uy0, tnx_ = wx, tny_ = wy;
    return true;
}

bool SafetyRecorder::makeTile(int& slot) {
    if (slot >= 0) return true;
    if (static_cast<double>(store_.size() + 1) * kTileCells > kMaxGridCells) {
        goSparse();
        return false;
    }
    slot = store_.make();
    return true;
}

void SafetyRecorder::goSparse() {
    forEachCell([&](int x, int y, const Cell& cell) { sparseCells_.emplace(std::make_pair(y, x), cell); });
    tiles_ = {};
    store_.clear();
    tnx_ = tny_ = 0;
    sparse_ = true;
}

SafetyRecorder::CellBlock::CellBlock() {
    const Cell c;
    for (int l = 0; l < kBlockCells; ++l) set(l, c);
}

SafetyRecorder::Cell SafetyRecorder::CellBlock::get(int l) const {
    // A Cell's fields (18 doubles and its worst level, 160 bytes with Vec2's alignment): get and
    // set copy each.
    static_assert(sizeof(Cell) == 160, "a field added to Cell must be added to CellBlock, get and set");
    Cell c;
    c.maxDensity = maxDensity[l];
    c.maxContact = maxContact[l];
    for (int k = 0; k < kConditions; ++k) c.seconds[k] = seconds[k][l];
    c.meanDensity = meanDensity[l];
    c.meanSquaredSpeed = meanSquaredSpeed[l];
    c.meanVelocity = Vec2(meanVelocityX[l], meanVelocityY[l]);
    c.sampledAt = sampledAt[l];
    for (int k = 0; k < 5; ++k) c.losRun[k] = losRun[k][l];
    c.losAt = losAt[l];
    c.worstLos = worstLos[l];
    return c;
}

void SafetyRecorder::CellBlock::set(int l, const Cell& c) {
    maxDensity[l] = c.maxDensity;
    maxContact[l] = c.maxContact;
    for (int k = 0; k < kConditions; ++k) seconds[k][l] = c.seconds[k];
    meanDensity[l] = c.meanDensity;
    meanSquaredSpeed[l] = c.meanSquaredSpeed;
    meanVelocityX[l] = c.meanVelocity.x();
    meanVelocityY[l] = c.meanVelocity.y();
    sampledAt[l] = c.sampledAt;
    for (int k = 0; k < 5; ++k) losRun[k][l] = c.losRun[k];
    losAt[l] = c.losAt;
    worstLos[l] = c.worstLos;
}

template <class F>
void SafetyRecorder::forEachCell(F&& f) const {
    if (sparse_) {
        for (const auto& [key, cell] : sparseCells_) f(key.second, key.first, cell);
        return;
    }
    for (int y = by0_; y <= by1_; ++y)
        for (int x = bx0_; x <= bx1_; ++x) {
            const Tile* tile = tileOf(x, y);
            if (tile != nullptr && tile->present[inTile(x, y)]) f(x, y, tile->get(inTile(x, y)));
        }
}

void SafetyRecorder::recordAt(const AgentStore& a, double t, const HealthLayer* health) {
    const double dt = lastTime_ == lastTime_ ? t - lastTime_ : 0.0;
    if (lastTime_ == lastTime_ && !(dt > 0)) return;  // already recorded at this time
    const double previous = lastTime_;  // NaN at the first record
    lastTime_ = t;
    const CrowdField f = crowdField(a, t_.cellSize, t_.gaussianRadius);
    // Weight of this sample in the time averages of the crowd pressure (1 = the first sample).
    const double alpha = std::min(1.0, dt / t_.pressureWindow);
    maxPressure_ = 0;
    const double levels[3] = {t_.densityCaution, t_.densityDangerous, t_.densityCritical};
    bool held[kConditions] = {false, false, false, false, false};
    std::size_t people[kConditions] = {0, 0, 0, 0, 0};
    // One growth of the flat grid for the whole field (it is sorted by (iy, ix)); while the cells
    // are on it (`flat`), each entry's place in it comes from its row and column, without the
    // look-up of cellAt, and the bounds of the cells evaluated grow once by the field's.
    int x0 = 0, x1 = -1;
    if (f.size() > 0 && f.keys_.empty()) {  // a whole rectangle, row by row
        x0 = f.ix.front(), x1 = f.ix.back();
    } else if (f.size() > 0) {
        x0 = x1 = f.ix[0];
        for (const int x : f.ix) x0 = std::min(x0, x), x1 = std::max(x1, x);
    }
    bool flat = f.size() > 0 && cover(x0, f.iy.front(), x1, f.iy.back());
    // The tiles of every entry, made here (serially) so that the loop below only looks them up:
    // once per run of entries in one tile (a row of the field crosses a tile in kTileSide
    // entries), in the order of the entries, so that tiles are numbered as they are met.
    for (std::size_t k = 0, last = 0; k < f.size() && flat; ++k) {
        if (k > 0 && ((f.ix[k] ^ f.ix[last]) | (f.iy[k] ^ f.iy[last])) >> kTileBits == 0) continue;
        last = k;
        flat = makeTile(tileSlot(f.ix[k], f.iy[k]));
    }
    if (flat) {
        if (bx1_ < bx0_) bx0_ = x0, bx1_ = x1, by0_ = f.iy.front(), by1_ = f.iy.back();
        bx0_ = std::min(bx0_, x0), bx1_ = std::max(bx1_, x1);
        by0_ = std::min(by0_, f.iy.front()), by1_ = std::max(by1_, f.iy.back());
    }
    // The cells: each entry writes only its own cell, and what they add up (whether a condition
    // held, how many people, the largest pressure, the cells of crushed people) is exact in any
    // order, so with several threads (the cells on the flat grid, a field of thousands of cells)
    // each takes a share of the entries and the results are the same bits.
    struct Tally {
        bool held[kConditions] = {false, false, false, false, false};
        std::size_t people[kConditions] = {0, 0, 0, 0, 0};
        double maxPressure = 0;
        std::vector<std::pair<int, int>> crushCells;  // (iy, ix) of the agents above their threshold
    };
    // Contact: the largest contact acceleration of the agents in each entry's cell (max is exact
    // in any order), folded into the cells in the loop below, which walks the grid in order (the
    // agents' order would visit the cells at random). Crush: each agent's last force
    // against its own threshold, for the heat map's seconds above it (the verdict's crush
    // reasons come from the health layer's records). A share of entries [from, to) takes the
    // agents whose cell is one of them, so that a thread reads only its own agents' accelerations
    // and writes only its own entries (issue 20: one thread did this for every agent before the
    // cells, the safety grid's largest serial part on two threads).
    std::vector<double> contact(health != nullptr ? f.size() : 0, 0.0);
    // The health layer's byte per record when it has them (the test below, without reading the
    // agent's 128-byte record).
    const unsigned char* const crushed = health != nullptr ? health->crushFlags() : nullptr;
    const auto agentsOf = [&](std::size_t from, std::size_t to, Tally& tally) {
        if (health == nullptr) return;
        const HealthLayer& h = *health;
        const std::uint32_t* const cellOf = f.cellOfAgent.data();
        for (std::size_t i = 0; i < a.size(); ++i) {
            const std::size_t k = cellOf[i];  // every agent's own cell is an entry of the field
            if (k < from || k >= to) continue;
            contact[k] = std::max(contact[k], a.contactAccel[i].norm());
            const int rec = a.record[i];
            bool above;
            if (crushed != nullptr && rec >= 0) {
                above = crushed[static_cast<std::size_t>(rec)] != 0;
            } else {
                const HealthRecord& r = h.recordOf(a, i);
                above = r.lastForce > h.params(r.policy).crushThreshold;
            }
            if (above) tally.crushCells.emplace_back(f.iy[k], f.ix[k]);
        }
    };
    // The record's numbers for the cells' update, and the field's columns (pointers to entry k
    // … k + 7 where they are a block's cells in order, else a staging copy: see below).
    CellRecord rec;
    rec.previous = previous;
    rec.dt = dt;
    rec.t = t;
    rec.alpha = alpha;
    rec.minDuration = t_.minDuration;
    rec.pressureCritical = t_.crowdPressureCritical;
    rec.densityCaution = t_.densityCaution;
    std::copy_n(levels, 3, rec.levels);
    rec.withContact = health != nullptr;
    const double* const density = f.density.data();
    const Vec2* const velocity = f.velocity.data();
    const unsigned char* const weighted = f.weighted.data();
    const int* const peopleIn = f.people.data();
    const double* const contactIn = contact.data();
    const auto direct = [&](std::size_t k) {
        return BlockInput{density + k, rec.withContact ? contactIn + k : nullptr, velocity + k, weighted + k,
                          peopleIn + k};
    };
    // Entries that are not a whole block: each in its lane of a copy, zeros in the other lanes.
    struct Staged {
        double density[kBlockCells] = {}, contact[kBlockCells] = {};
        Vec2 velocity[kBlockCells];
        unsigned char weighted[kBlockCells] = {};
        int people[kBlockCells] = {};
        Staged() {
            for (Vec2& v : velocity) v = Vec2(0, 0);
        }
        void put(int lane, std::size_t k, const BlockInput& from) {
            density[lane] = from.density[k];
            if (from.contact != nullptr) contact[lane] = from.contact[k];
            velocity[lane] = from.velocity[k];
            weighted[lane] = from.weighted[k];
            people[lane] = from.people[k];
        }
        BlockInput input() const { return BlockInput{density, contact, velocity, weighted, people}; }
    };
    const BlockInput field = direct(0);
    const auto wholeBlock = updateCellsBuild<true, CellBlock>();
    const auto someLanes = updateCellsBuild<false, CellBlock>();
    const auto fold = [](const BlockTally& lanes, Tally& tally) {
        for (int c = 0; c < 4; ++c)
            for (int l = 0; l < kBlockCells; ++l) {
                tally.held[c] = tally.held[c] || lanes.held[c][l] > 0;
                tally.people[c] += static_cast<std::size_t>(lanes.people[c][l]);
            }
        for (int l = 0; l < kBlockCells; ++l) tally.maxPressure = std::max(tally.maxPressure, lanes.maxPressure[l]);
    };
    std::vector<std::pair<int, int>> crushCells;
    auto merge = [&](Tally& tally) {
        for (int c = 0; c < kConditions; ++c) {
            held[c] = held[c] || tally.held[c];
            people[c] += tally.people[c];
        }
        maxPressure_ = std::max(maxPressure_, tally.maxPressure);
        crushCells.insert(crushCells.end(), tally.crushCells.begin(), tally.crushCells.end());
    };
    if (flat) {
        const std::size_t count = f.size();
        const int* const ix = f.ix.data();
        const int* const iy = f.iy.data();
        // The entries of one block (one row, kBlockCells aligned columns) follow each other in the
        // field (sorted by (iy, ix)); a share starts at the first entry of a block, so that no
        // block is written by two threads.
        const auto blockStart = [ix, iy, count](std::size_t k) {
            while (k > 0 && k < count && iy[k - 1] == iy[k] && (ix[k - 1] >> kBlockBits) == (ix[k] >> kBlockBits)) --k;
            return k;
        };
#pragma omp parallel if (parallelCheapLoop(count))
        {
            // The thread's share of the entries, the same for its agents and its cells.
            const std::size_t threads = static_cast<std::size_t>(omp_get_num_threads());
            const std::size_t me = static_cast<std::size_t>(omp_get_thread_num());
            const std::size_t from = blockStart(count * me / threads), to = blockStart(count * (me + 1) / threads);
            Tally tally;
            agentsOf(from, to, tally);
            BlockTally lanes;
            Tile* tile = nullptr;
            int tileX = 0, tileY = 0;
            for (std::size_t k = from; k < to;) {
                const int x = ix[k], y = iy[k];
                // The tile of the last entry while the entries stay in it (a row of the field
                // crosses a tile in kTileSide entries).
                if (tile == nullptr || ((x ^ tileX) | (y ^ tileY)) >> kTileBits != 0) {
                    tile = &store_[tileSlot(x, y)];
                    tileX = x, tileY = y;
                }
                const int c = inTile(x, y);
                CellBlock& block = tile->blocks[c >> kBlockBits];
                if ((x & (kBlockCells - 1)) == 0 && to - k >= kBlockCells && iy[k + kBlockCells - 1] == y &&
                    ix[k + kBlockCells - 1] == x + kBlockCells - 1) {  // a whole block in order
                    // The block of the same columns one row on (two blocks on in the tile, or past
                    // its last row, a prefetch wasted, never wrong): the field's next row reaches
                    // it ~100 cells later. The update is bound by the cells' memory (~1.6 MB per
                    // record at 10k agents); this took the safety grid −14 to −21 % (issue 20).
                    const char* const next = reinterpret_cast<const char*>(&block + 2);
                    for (std::size_t o = 0; o < sizeof(CellBlock); o += 64) __builtin_prefetch(next + o, 1);
                    wholeBlock(block, direct(k), 0xffu, rec, lanes);
                    std::memset(tile->present + c, 1, kBlockCells);
                    k += kBlockCells;
                    continue;
                }
                Staged staged;
                unsigned mask = 0;
                for (; k < to && iy[k] == y && (ix[k] >> kBlockBits) == (x >> kBlockBits); ++k) {
                    const int lane = ix[k] & (kBlockCells - 1);
                    staged.put(lane, k, field);
                    mask |= 1u << lane;
                    tile->present[inTile(ix[k], y)] = 1;
                }
                someLanes(block, staged.input(), mask, rec, lanes);
            }
            fold(lanes, tally);
#pragma omp critical(ch_safety_record_merge)
            merge(tally);
        }
    } else {  // the cells in the map (or none): each in lane 0 of a block
        Tally tally;
        agentsOf(0, f.size(), tally);
        BlockTally lanes;
        CellBlock one;
        for (std::size_t k = 0; k < f.size(); ++k) {
            Cell& cell = sparseCells_[{f.iy[k], f.ix[k]}];
            Staged staged;
            staged.put(0, k, field);
            one.set(0, cell);
            someLanes(one, staged.input(), 1u, rec, lanes);
            cell = one.get(0);
        }
        fold(lanes, tally);
        merge(tally);
    }
    std::sort(crushCells.begin(), crushCells.end());
    crushCells.erase(std::unique(crushCells.begin(), crushCells.end()), crushCells.end());
    // The crushed people's cells are entries of the field: on tiles made above, or in the map.
    for (const auto& [y, x] : crushCells) {
        if (sparse_) {
            sparseCells_[{y, x}].seconds[Crush] += dt;
        } else {
            const int c = inTile(x, y);
            store_[tileSlot(x, y)].blocks[c >> kBlockBits].seconds[Crush][c & (kBlockCells - 1)] += dt;
        }
    }
    for (int c = 0; c < kConditions; ++c) {
        if (!held[c]) continue;
        Timeline& tl = timeline_[c];
        if (!(tl.firstTime == tl.firstTime)) tl.firstTime = t;
        tl.seconds += dt;
        tl.maxPeople = std::max(tl.maxPeople, people[c]);
    }
}

std::string SafetyRecorder::heatmapCsv() const {
    std::string out =
        "x,y,max_density,max_contact_accel,seconds_above_density_threshold,seconds_above_crush_threshold,worst_los\n";
    int ix0 = bx0_, ix1 = bx1_, iy0 = by0_, iy1 = by1_;
    if (sparse_) {
        if (sparseCells_.empty()) return out;
        ix0 = ix1 = sparseCells_.begin()->first.second;
        iy0 = sparseCells_.begin()->first.first, iy1 = sparseCells_.rbegin()->first.first;
        for (const auto& [key, cell] : sparseCells_) {
            ix0 = std::min(ix0, key.second);
            ix1 = std::max(ix1, key.second);
        }
    } else if (ix1 < ix0) {
        return out;
    }
    const Cell empty;
    // The full rectangle while it is at most 4M cells (a plotting program wants a regular grid);
    // for a crowd scattered far apart, only the cells that were evaluated, in the same order.
    const bool full = (static_cast<double>(ix1) - ix0 + 1) * (static_cast<double>(iy1) - iy0 + 1) <= (1 << 22);
    auto row = [&](int ix, int iy, const Cell& c) {
        appendNumber(out, (ix + 0.5) * t_.cellSize);
        out += ',';
        appendNumber(out, (iy + 0.5) * t_.cellSize);
        for (const double v : {c.maxDensity, c.maxContact, c.seconds[DensityDangerous], c.seconds[Crush]}) {
            out += ',';
            appendNumber(out, v);
        }
        out += ',';
        out += c.worstLos;
        out += '\n';
    };
    if (!full) {
        forEachCell(row);
        return out;
    }
    for (int iy = iy0; iy <= iy1; ++iy)
        for (int ix = ix0; ix <= ix1; ++ix) {
            if (!sparse_) {  // the index covers the rectangle; cells never evaluated are default
                const Tile* tile = tileOf(ix, iy);
                row(ix, iy, tile != nullptr ? tile->get(inTile(ix, iy)) : empty);
                continue;
            }
            const auto it = sparseCells_.find({iy, ix});
            row(ix, iy, it == sparseCells_.end() ? empty : it->second);
        }
    return out;
}

VerdictReason SafetyRecorder::cellReason(Condition c, const std::string& level, const std::string& measure,
                                         double threshold, const std::string& unit, const std::string& what) const {
    VerdictReason r;
    r.level = level;
    r.measure = measure;
    r.threshold = threshold;
    r.unit = unit;
    r.firstTime = timeline_[c].firstTime;
    r.duration = timeline_[c].seconds;
    r.people = timeline_[c].maxPeople;
    double sw = 0, sx = 0, sy = 0;
    forEachCell([&](int ix, int iy, const Cell& cell) {
        const double s = cell.seconds[c];
        if (!(s > 0)) return;
        const double x = (ix + 0.5) * t_.cellSize, y = (iy + 0.5) * t_.cellSize;
        const double hx = 0.5 * t_.cellSize;
        if (!r.hasWhere) {
            r.xmin = x - hx; r.xmax = x + hx; r.ymin = y - hx; r.ymax = y + hx;
            r.hasWhere = true;
        }
        r.xmin = std::min(r.xmin, x - hx); r.xmax = std::max(r.xmax, x + hx);
        r.ymin = std::min(r.ymin, y - hx); r.ymax = std::max(r.ymax, y + hx);
        sw += s; sx += s * x; sy += s * y;
    });
    if (sw > 0) { r.x = sx / sw; r.y = sy / sw; }
    r.text = what + " above " + fmt(threshold) + " " + unit + " for " + fmt(r.duration) + " s from t = " +
             fmt(r.firstTime) + " s, up to " + std::to_string(r.people) + " people at once, around (" + fmt(r.x) +
             ", " + fmt(r.y) + ") m";
    return r;
}

Verdict SafetyRecorder::verdict(const Simulation& sim) const {
    Verdict v;
    // A threshold keeps its source in the text only while it is the default; one set in <Safety>
    // is the user's.
    const SafetyThresholds defaults;
    auto what = [](const std::string& measure, double value, double def, const std::string& source) {
        return measure + (value == def ? " (" + source + ")" : " (threshold set in <Safety>)");
    };
    // Density: the highest level that held at least minDuration.
    const struct { Condition c; const char* level; double threshold, def; const char* source; } density[] = {
        {DensityCritical, "critical", t_.densityCritical, defaults.densityCritical, "Still: crowd collapse"},
        {DensityDangerous, "dangerous", t_.densityDangerous, defaults.densityDangerous, "Still: moving crowd at risk"},
        {DensityCaution, "caution", t_.densityCaution, defaults.densityCaution, "Fruin: level of service F"},
    };
    for (const auto& d : density)
        if (timeline_[d.c].seconds >= t_.minDuration) {
            v.reasons.push_back(cellReason(d.c, d.level, "density", d.threshold, "persons/m2",
                                           what("local density", d.threshold, d.def, d.source)));
            break;
        }
    if (timeline_[Pressure].seconds >= t_.minDuration)
        v.reasons.push_back(cellReason(Pressure, "dangerous", "crowd_pressure", t_.crowdPressureCritical, "1/s2",
                                       what("crowd pressure", t_.crowdPressureCritical, defaults.crowdPressureCritical,
                                            "Helbing et al. 2007: crowd turbulence")));

    // Crush, from the per-agent records.
    const HealthLayer& h = sim.health();
    const CrushSummary& cs = h.crush();
    std::size_t above = 0, halfway = 0, injured = 0;
    double firstInjury = std::numeric_limits<double>::quiet_NaN(), longestInjured = 0, longestHalf = 0;
    double threshold = 0, dose = 0;
    for (const HealthRecord& r : h.records()) {
        if (!r.seen) continue;
        const HealthParams& p = h.params(r.policy);
        threshold = std::max(threshold, p.crushThreshold);
        dose = std::max(dose, p.injuryDose);
        if (r.timeAboveThreshold > 0) ++above;
        if (r.dose >= t_.doseDangerousFraction * p.injuryDose) {
            ++halfway;
            longestHalf = std::max(longestHalf, r.timeAboveThreshold);
        }
        if (r.injured()) {
            ++injured;
            longestInjured = std::max(longestInjured, r.timeAboveThreshold);
            if (!(firstInjury <= r.injuredAt)) firstInjury = r.injuredAt;
        }
    }
    auto crushWhere = [&](VerdictReason& r) {
        if (cs.samples == 0) return;
        r.hasWhere = true;
        r.x = cs.positionSum.x() / static_cast<double>(cs.samples);
        r.y = cs.positionSum.y() / static_cast<double>(cs.samples);
        r.xmin = cs.xmin; r.xmax = cs.xmax; r.ymin = cs.ymin; r.ymax = cs.ymax;
    };
    auto where = [](const VerdictReason& r) {
        return r.hasWhere ? ", around (" + fmt(r.x) + ", " + fmt(r.y) + ") m" : std::string();
    };
    if (injured > 0) {
        VerdictReason r;
        r.level = "critical";
        r.measure = "injured";
        r.threshold = dose;
        r.unit = "N s";
        r.firstTime = firstInjury;
        r.duration = longestInjured;
        r.people = injured;
        crushWhere(r);
        r.text = std::to_string(injured) + " injured (crush dose above " + fmt(dose) + " N s) from t = " +
                 fmt(firstInjury) + " s" + where(r);
        v.reasons.push_back(r);
    } else if (halfway > 0) {
        VerdictReason r;
        r.level = "dangerous";
        r.measure = "crush_dose";
        r.threshold = t_.doseDangerousFraction * dose;
        r.unit = "N s";
        r.firstTime = cs.firstTime;
        r.duration = longestHalf;
        r.people = halfway;
        crushWhere(r);
        r.text = std::to_string(halfway) + " people received a crush dose above " + fmt(r.threshold) +
                 " N s (half the injury dose)" + where(r);
        v.reasons.push_back(r);
    } else if (above > 0) {
        VerdictReason r;
        r.level = "caution";
        r.measure = "crush_force";
        r.threshold = threshold;
        r.unit = "N";
        r.firstTime = cs.firstTime;
        r.duration = cs.seconds;
        r.people = above;
        crushWhere(r);
        r.text = "contact force above " + fmt(threshold) + " N for " + fmt(cs.seconds) + " s from t = " +
                 fmt(cs.firstTime) + " s, " + std::to_string(above) + " people" + where(r);
        v.reasons.push_back(r);
    }

    // Falls (CrowdHealth falls): every fall is critical; where the first was, and where they all were.
    const std::vector<FallEvent>& falls = h.fallEvents();
    if (!falls.empty()) {
        VerdictReason r;
        r.level = "critical";
        r.measure = "fallen";
        double fallDose = 0;
        for (const HealthRecord& rec : h.records())
            if (rec.everFell()) fallDose = std::max(fallDose, h.params(rec.policy).fallDose);
        r.threshold = fallDose;
        r.unit = "N s";
        r.firstTime = falls.front().time;
        r.people = h.fallenCount();
        r.hasWhere = true;
        Vec2 sum(0, 0);
        r.xmin = r.xmax = falls.front().position.x();
        r.ymin = r.ymax = falls.front().position.y();
        double down = 0;  // the longest time anyone lay on the floor (until the end if still down)
        for (const FallEvent& f : falls) {
            sum += f.position;
            r.xmin = std::min(r.xmin, f.position.x());
            r.xmax = std::max(r.xmax, f.position.x());
            r.ymin = std::min(r.ymin, f.position.y());
            r.ymax = std::max(r.ymax, f.position.y());
        }
        for (const HealthRecord& rec : h.records())
            if (rec.everFell()) {
                const CareRecord& c = h.careOf(rec);
                const double until = rec.fallen ? sim.time() : c.gotUpAt;
                if (until == until) down = std::max(down, until - c.lastFellAt);
            }
        r.duration = down;
        r.x = sum.x() / static_cast<double>(falls.size());
        r.y = sum.y() / static_cast<double>(falls.size());
        const FallEvent& first = falls.front();
        r.text = std::to_string(r.people) + " fell (crush dose above " + fmt(fallDose) + " N s), " +
                 std::to_string(falls.size()) + (falls.size() == 1 ? " fall" : " falls") + "; the first at t = " +
                 fmt(first.time) + " s at (" + fmt(first.position.x()) + ", " + fmt(first.position.y()) +
                 ") m (agent " + std::to_string(first.id) + "); longest on the floor " + fmt(down) + " s";
        v.reasons.push_back(r);
    }
    // Helping: people who stopped or slowed down for an injured or fallen person are delayed where
    // the crowd is dangerous, and receive a dose of their own.
    if (const std::size_t helpers = h.helperCount(); helpers > 0) {
        VerdictReason r;
        r.level = "caution";
        r.measure = "helping";
        r.unit = "s";
        r.people = helpers;
        double total = 0, longest = 0, dose = 0, first = std::numeric_limits<double>::quiet_NaN();
        for (const HealthRecord& rec : h.records())
            if (const CareRecord& c = h.careOf(rec); c.isHelper()) {
                total += c.helpTime;
                longest = std::max(longest, c.helpTime);
                dose = std::max(dose, c.helpDose);
            }
        for (const HealthRecord& rec : h.records())
            if (h.careOf(rec).helpers > 0) {
                const double t = rec.injuredAt;
                if (t == t && !(first <= t)) first = t;
            }
        r.firstTime = first;
        r.duration = longest;
        r.text = std::to_string(helpers) + " people helped " + std::to_string(h.helpedCount()) +
                 " injured or fallen, delayed " + fmt(total) + " s in all (the longest " + fmt(longest) +
                 " s); the largest crush dose received while helping " + fmt(dose) + " N s";
        v.reasons.push_back(r);
    }
    std::stable_sort(v.reasons.begin(), v.reasons.end(), [](const VerdictReason& a, const VerdictReason& b) {
        return verdictRank(a.level) > verdictRank(b.level);
    });
    if (!v.reasons.empty()) v.level = v.reasons.front().level;
    return v;
}

void addReasons(Verdict& v, std::vector<VerdictReason> more) {
    for (VerdictReason& r : more) v.reasons.push_back(std::move(r));
    std::stable_sort(v.reasons.begin(), v.reasons.end(), [](const VerdictReason& a, const VerdictReason& b) {
        return verdictRank(a.level) > verdictRank(b.level);
    });
    if (!v.reasons.empty() && verdictRank(v.reasons.front().level) > verdictRank(v.level)) v.level = v.reasons.front().level;
}

Json verdictJsonValue(const Verdict& v) {
    Json reasons = Json::array();
    for (const VerdictReason& r : v.reasons) {
        Json where = nullptr;
        if (r.hasWhere)
            where = Json{{"x", jsonNumber(r.x, 6)},       {"y", jsonNumber(r.y, 6)},
                         {"xmin", jsonNumber(r.xmin, 6)}, {"xmax", jsonNumber(r.xmax, 6)},
                         {"ymin", jsonNumber(r.ymin, 6)}, {"ymax", jsonNumber(r.ymax, 6)}};
        reasons.push_back(Json{{"level", r.level},
                               {"measure", r.measure},
                               {"threshold", jsonNumber(r.threshold)},
                               {"unit", r.unit},
                               {"first_time", jsonNumber(r.firstTime)},
                               {"duration", jsonNumber(r.duration)},
                               {"people", r.people},
                               {"where", where},
                               {"place", r.place.empty() ? Json(nullptr) : Json(r.place)},
                               {"text", r.text}});
    }
    return Json{{"level", v.level}, {"reasons", reasons}};
}

std::string verdictJson(const Verdict& v) { return verdictJsonValue(v).dump(); }

std::string verdictText(const Verdict& v) {
    std::string upper = v.level;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    std::string out = "safety verdict: " + upper + "\n";
    if (v.reasons.empty()) out += "  no threshold was reached\n";
    for (const VerdictReason& r : v.reasons) out += "  [" + r.level + "] " + r.text + "\n";
    return out;
}

}  // namespace ch
