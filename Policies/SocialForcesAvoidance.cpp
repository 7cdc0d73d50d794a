// CrowdHealth — SocialForcesAvoidance (Helbing & Molnár 1995).
#include "SocialForcesAvoidance.h"

#include "SocialForcesSimd.h"
#include "crowdhealth/core/cpu_features.h"
#include "crowdhealth/core/parallel.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <span>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#endif

namespace ch {

namespace {

/// What the pair loop needs besides the neighbour list (one agent's call).
struct PairLoop {
    const SocialForcesAvoidance::Other* other;  ///< per agent: its step, |step|², radius
    Vec2 ownStep;            ///< with relative velocities: the agent's own v Δt (subtracted)
    bool relative, cutoff, headingZero;
    double ownRadius, range, cosFov, behind, V0, sigma;
    Vec2 heading;
};

/// Two doubles, what one 16-byte load gives.
using D2 = simd::DV2;

[[gnu::always_inline]] inline D2 load2(const void* p) {
    D2 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

/// Lanes l of a vector of N doubles from N two-double halves h[l] = {x_l, y_l}, as two vectors
/// {x_0, y_0, x_2, y_2, …} and {x_1, y_1, x_3, y_3, …}; one unpack of those then gives
/// {x_0, x_1, …} and {y_0, y_1, …} (in-lane unpacks in AVX2 and AVX-512, where the 128-bit inserts
/// take their halves straight from memory).
template <class V>
[[gnu::always_inline]] inline void transpose(const D2* h, V& x, V& y) {
    V even, odd;
    if constexpr (sizeof(V) == 16) {
        x = __builtin_shufflevector(h[0], h[1], 0, 2);
        y = __builtin_shufflevector(h[0], h[1], 1, 3);
        return;
    } else if constexpr (sizeof(V) == 32) {
        even = __builtin_shufflevector(h[0], h[2], 0, 1, 2, 3);
        odd = __builtin_shufflevector(h[1], h[3], 0, 1, 2, 3);
        x = __builtin_shufflevector(even, odd, 0, 4, 2, 6);
        y = __builtin_shufflevector(even, odd, 1, 5, 3, 7);
    } else {
        typedef double D4 __attribute__((vector_size(32)));
        const D4 e0 = __builtin_shufflevector(h[0], h[2], 0, 1, 2, 3), e1 = __builtin_shufflevector(h[4], h[6], 0, 1, 2, 3);
        const D4 o0 = __builtin_shufflevector(h[1], h[3], 0, 1, 2, 3), o1 = __builtin_shufflevector(h[5], h[7], 0, 1, 2, 3);
        even = __builtin_shufflevector(e0, e1, 0, 1, 2, 3, 4, 5, 6, 7);
        odd = __builtin_shufflevector(o0, o1, 0, 1, 2, 3, 4, 5, 6, 7);
        x = __builtin_shufflevector(even, odd, 0, 8, 2, 10, 4, 12, 6, 14);
        y = __builtin_shufflevector(even, odd, 1, 9, 3, 11, 5, 13, 7, 15);
    }
}

/// What the pair loop reads of N neighbours (V: N doubles), lane l from list entry e[l].
template <class V>
struct Lanes {
    V ox, oy, sx, sy, ssq, rj;
};

/// Gathers N neighbours with 16-byte loads and shuffles: each entry's offset (16 of its 24 bytes)
/// and each neighbour's 32-byte Other record as two 16-byte halves, {sx, sy} and {stepSq, radius}.
/// (Building the lanes one element at a time took a load and an insert per element: 24 of each
/// per four pairs.)
template <class V>
[[gnu::always_inline]] inline Lanes<V> gather(const NeighbourAgent* const* e, const SocialForcesAvoidance::Other* other) {
    using Other = SocialForcesAvoidance::Other;
    static_assert(sizeof(Other) == 32 && offsetof(Other, sx) == 0 && offsetof(Other, sy) == 8 &&
                  offsetof(Other, stepSq) == 16 && offsetof(Other, radius) == 24);
    constexpr int n = sizeof(V) / sizeof(double);
    D2 off[n], step[n], rest[n];
    for (int l = 0; l < n; ++l) {
        const Other* o = other + e[l]->index;
        off[l] = load2(&e[l]->offset);  // offset.x(), offset.y(): the entry's first 16 bytes
        step[l] = load2(&o->sx);
        rest[l] = load2(&o->stepSq);
    }
    Lanes<V> g;
    transpose(off, g.ox, g.oy);
    transpose(step, g.sx, g.sy);
    transpose(rest, g.ssq, g.rj);
    return g;
}

/// The loop-invariant values of one agent's call, in every lane of a V.
template <class V>
struct PairConstants {
    V range, ownRadius, behind, hx, hy, cosFov, ownSx, ownSy, vOverSigma, invS;
};

// Comparisons and selects by width (two lanes: the generic x86-64 build; four: AVX2; eight:
// AVX-512 mask registers), from crowdhealth/core/simd.h.
using simd::allLanes;
using simd::le;
using simd::lt;
using simd::sel;

#if defined(__GNUC__) && !defined(__clang__)
// No fused multiply-add contraction in the pair loop's builds (see pedestrianForcesGeneric).
#define CH_SF_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#else
#define CH_SF_NO_CONTRACT
#endif

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_SF_X86 1
#define CH_SF_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl")))
#endif

/// The force terms (tx, ty) of N pairs (the lanes of V), +0 in lanes where `live` is not set.
/// The model's switches without a branch: no contact cutoff is
/// ownRadius = −∞ (every distance > −∞ + r_j), a zero heading is behind = 1 (every weight 1, the
/// field of view's full weight); relative velocities are a template parameter.
template <bool Relative, class V, class M>
[[gnu::always_inline]] inline void pairTerms(const Lanes<V>& g, M live, const PairConstants<V>& p, V& tx, V& ty) {
    const auto c = [](double v) { return simd::splatAs<V>(v); };
    const V zero = c(0.0), one = c(1.0);
    const V ox = g.ox, oy = g.oy;
    const V distance = simd::sqrt(ox * ox + oy * oy);  // NeighbourAgent::distance()
    M use = live & le(distance, p.range) & lt(p.ownRadius + g.rj, distance);  // in contact: contact forces act
    V sx = g.sx, sy = g.sy, ssq = g.ssq;
    if constexpr (Relative) {
        sx = sx - p.ownSx;
        sy = sy - p.ownSy;
        ssq = sx * sx + sy * sy;
    }
    // pairForce(R = −offset, |R|, s, |s|²).
    const V Rx = -ox, Ry = -oy;
    const V R2x = Rx - sx, R2y = Ry - sy;
    const V magR2 = simd::sqrt(R2x * R2x + R2y * R2y);
    const V sum = distance + magR2;
    const V twoBSquared = sum * sum - ssq;
    use &= lt(zero, twoBSquared) & le(c(1e-9), distance) & le(c(1e-9), magR2);
    const V b = c(0.5) * simd::sqrt(sel(use, twoBSquared, one));
    use &= le(c(1e-3), b);
    // ∇b = (|R| + |R−s|)/(4b) · (R/|R| + (R−s)/|R−s|), over one common denominator.
    const V k = sum / (c(4.0) * b * distance * magR2);
    const V gx = k * (Rx * magR2 + R2x * distance), gy = k * (Ry * magR2 + R2y * distance);
    const V a = p.vOverSigma * simd::expNonPositive(-b * p.invS);
    // Eq. 8: full weight when the neighbour is within the field of view.
    const M inView = le(p.cosFov * distance, p.hx * ox + p.hy * oy);
    const V w = sel(inView, one, p.behind);
    tx = sel(use, w * (a * gx), zero);
    ty = sel(use, w * (a * gy), zero);
}

/// (fx, fy) += the lanes of (tx, ty), one after the other in lane order.
template <class V>
[[gnu::always_inline]] inline void addLanes(V tx, V ty, double& fx, double& fy) {
    for (int l = 0; l < static_cast<int>(sizeof(V) / sizeof(double)); ++l) {
        fx += tx[l];
        fy += ty[l];
    }
}

/// Blocks of lanes the pair loop computes before adding their terms (3: per pair 1.1-1.2x
/// faster than 1 in the AVX2 and AVX-512 builds on AMD Zen 5; 2 and 4 were between).
inline constexpr std::size_t kBlocks = 3;

/// The pair loop over a whole list, N = sizeof(V) / 8 pairs at a time.
template <bool Relative, class V>
[[gnu::always_inline]] inline Vec2 pairLoop(std::span<const NeighbourAgent> list, const PairLoop& in) {
    constexpr std::size_t n = sizeof(V) / sizeof(double);
    const auto c = [](double v) { return simd::splatAs<V>(v); };
    const std::size_t m = list.size();
    const double invSigma = 1.0 / in.sigma;
    PairConstants<V> p;
    p.range = c(in.range);
    p.ownRadius = c(in.cutoff ? in.ownRadius : -std::numeric_limits<double>::infinity());
    p.behind = c(in.headingZero ? 1.0 : in.behind);
    p.hx = c(in.heading.x());
    p.hy = c(in.heading.y());
    p.cosFov = c(in.cosFov);
    p.ownSx = c(in.ownStep.x());
    p.ownSy = c(in.ownStep.y());
    p.vOverSigma = c(in.V0 * invSigma);
    p.invS = c(invSigma);
    double fx = 0, fy = 0;
    const NeighbourAgent* e[n];
    const auto all = allLanes(V{});
    std::size_t k0 = 0;
    V tx[kBlocks], ty[kBlocks];
    // kBlocks blocks of n pairs at a time, their terms added after all are computed: independent
    // work for the out-of-order core while one block waits on its square roots and exponential
    // (the loop is latency-bound). The sum keeps the list's order.
    for (; k0 + kBlocks * n <= m; k0 += kBlocks * n) {
        for (std::size_t u = 0; u < kBlocks; ++u) {
            for (std::size_t l = 0; l < n; ++l) e[l] = &list[k0 + u * n + l];
            pairTerms<Relative>(gather<V>(e, in.other), all, p, tx[u], ty[u]);
        }
        for (std::size_t u = 0; u < kBlocks; ++u) addLanes(tx[u], ty[u], fx, fy);
    }
    for (; k0 + n <= m; k0 += n) {
        for (std::size_t l = 0; l < n; ++l) e[l] = &list[k0 + l];
        pairTerms<Relative>(gather<V>(e, in.other), all, p, tx[0], ty[0]);
        addLanes(tx[0], ty[0], fx, fy);
    }
    if (k0 < m) {
        // The last block repeats the list's last entry in the unused lanes, masked.
        for (std::size_t l = 0; l < n; ++l) e[l] = &list[std::min(k0 + l, m - 1)];
        // Lanes k0 + l < m: as many as the list has left, counted from the first.
        V minusLane;  // {0, −1, −2, …}: lane l is live where k0 − m < −l
        for (std::size_t l = 0; l < n; ++l) minusLane[l] = -static_cast<double>(l);
        const auto live = lt(simd::splatAs<V>(static_cast<double>(k0) - static_cast<double>(m)), minusLane);
        pairTerms<Relative>(gather<V>(e, in.other), live, p, tx[0], ty[0]);
        addLanes(tx[0], ty[0], fx, fy);
    }
    return Vec2(fx, fy);
}

/// Σ_j w_j f_j over the neighbour list: the elliptic pair force of pairForce() and the field-of-view
/// weight, several pairs at a time (issue 20). Pairs that exert no force (beyond range, in contact,
/// degenerate ellipse) are masked to +0. The sum runs over the list in order, one term after the
/// other, so it does not depend on how the lanes are grouped. The terms differ from pairForce()'s
/// in the last bits: the exponential is simd::expNonPositive (within 3e-16 of std::exp) and the
/// gradient takes one division instead of three (∇b = (|R| + |R−s|)/(4b|R||R−s|) ·
/// (R|R−s| + (R−s)|R|)). With std::exp and pairForce()'s three divisions this loop gave the bits
/// of the scalar loop it replaced, every state hash of crowdhealth-bench unchanged.
/// Three builds of it, chosen when the program starts (SocialForcesAvoidance::pairLoopPath): two
/// lanes for generic x86-64 and other CPUs (one SSE2 register per value on x86-64; four lanes in
/// two registers spilled to the stack and took 1.5x longer), four lanes in AVX2, eight lanes in
/// AVX-512. All do the same operations lane by lane without fused multiply-add (GCC would
/// contract a·b + c into one where the target has FMA, as AVX-512F does: fp-contract=off keeps
/// every product and sum rounded on its own), so all give the same bits
/// (Tests/policies_social_forces_simd_test.cpp compares them).
CH_SF_NO_CONTRACT
Vec2 pedestrianForcesGeneric(std::span<const NeighbourAgent> list, const PairLoop& in) {
    return in.relative ? pairLoop<true, D2>(list, in) : pairLoop<false, D2>(list, in);
}

#ifdef CH_SF_X86
__attribute__((target("avx2"))) CH_SF_NO_CONTRACT
Vec2 pedestrianForcesAvx2(std::span<const NeighbourAgent> list, const PairLoop& in) {
    return in.relative ? pairLoop<true, simd::DV>(list, in) : pairLoop<false, simd::DV>(list, in);
}

/// Eight pairs at a time in one AVX-512 register (issue 20: 1.5x faster per pair than AVX2 on AMD
/// Zen 5, where most AVX-512 instructions cost about what their AVX2 forms do).
CH_SF_AVX512 CH_SF_NO_CONTRACT
Vec2 pedestrianForcesWide(std::span<const NeighbourAgent> list, const PairLoop& in) {
    return in.relative ? pairLoop<true, simd::DV8>(list, in) : pairLoop<false, simd::DV8>(list, in);
}
#endif

/// The pair-loop path in use: the best this CPU runs, found once when the program starts.
std::atomic<int> gPairLoopPath{cpu::bestBuild()};

Vec2 pedestrianForces(std::span<const NeighbourAgent> list, const PairLoop& in) {
#ifdef CH_SF_X86
    switch (gPairLoopPath.load(std::memory_order_relaxed)) {
    case 2: return pedestrianForcesWide(list, in);
    case 1: return pedestrianForcesAvx2(list, in);
    default: break;
    }
#endif
    return pedestrianForcesGeneric(list, in);
}

}  // namespace

CH_REGISTER_COMPONENT(SocialForcesAvoidance);

ComponentInfo SocialForcesAvoidance::Info() {
    ComponentInfo info;
    info.name = "SocialForcesAvoidance";
    info.kind = ComponentKind::Force;
    info.summary = "repulsive social forces from pedestrians (elliptic potential) and walls";
    info.reference = "Helbing & Molnar 1995, Social force model for pedestrian dynamics, Phys. Rev. E 51(5):4282";
    info.params = {
        ParamSpec::real("dt", "s", 2.0, 0.0, 60.0, "time horizon of the other's step in the elliptic potential (eq. 4)"),
        ParamSpec::real("V0", "m2/s2", 2.1, 0.0, 1e4, "strength of the pedestrian repulsion potential (eq. 13)"),
        ParamSpec::real("sigma", "m", 0.3, 1e-6, 100.0, "decay length of the pedestrian potential (eq. 13)"),
        ParamSpec::real("U0", "m2/s2", 10.0, 0.0, 1e4, "strength of the wall repulsion potential (eq. 13)"),
        ParamSpec::real("R", "m", 0.2, 1e-6, 100.0, "decay length of the wall potential (eq. 13)"),
        ParamSpec::real("fov", "deg", 100.0, 0.0, 180.0, "half-angle of the field of view (eq. 8)"),
        ParamSpec::real("behind", "-", 0.5, 0.0, 1.0, "weight of interactions outside the field of view (eq. 8)"),
        ParamSpec::choice("otherVelocity", {"preferred", "relative"}, 0,
                          "the other's motion in b (eq. 4): preferred = its speed along its preferred direction, "
                          "v_b dt e_b (Helbing & Molnar 1995); relative = (v_b - v_a) dt (UMANS 1.x)"),
        ParamSpec::boolean("contactCutoff", true,
                           "pairs whose bodies overlap exert no social force (contact forces take over); false: "
                           "the force acts at every distance (UMANS 1.x)"),
        ParamSpec::choice("walls", {"nearest", "umans"}, 0,
                          "nearest = one force per obstacle from its nearest point, full weight; umans = one per "
                          "wall segment whose outer side faces the agent (polygons counter-clockwise, taken as "
                          "listed), a shared corner once, weighted by fov/behind (UMANS 1.x)"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<SocialForcesAvoidance>(p); };
    return info;
}

SocialForcesAvoidance::SocialForcesAvoidance(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "dt", dt_);
    bind(params, "V0", V0_);
    bind(params, "sigma", sigma_);
    bind(params, "U0", U0_);  // UMANS reads U0 into V0 by mistake; we keep them apart
    bind(params, "R", R_);
    bind(params, "fov", fovDeg_);
    bind(params, "behind", behind_);
    bind(params, "otherVelocity", otherVelocity_);
    bind(params, "contactCutoff", contactCutoff_);
    bind(params, "walls", walls_);
}

Vec2 SocialForcesAvoidance::pairForce(const Vec2& R, double vb, const Vec2& eb) const {
    const Vec2 step = vb * dt_ * eb;
    return pairForce(R, R.norm(), step, step.squaredNorm());
}

Vec2 SocialForcesAvoidance::pairForce(const Vec2& R, double magR, const Vec2& step, double stepSq) const {
    const Vec2 R2 = R - step;
    const double magR2 = R2.norm();
    const double sum = magR + magR2;
    const double twoBSquared = sum * sum - stepSq;  // (2b)²
    if (twoBSquared <= 0 || magR < 1e-9 || magR2 < 1e-9) return {0, 0};
    const double b = 0.5 * std::sqrt(twoBSquared);
    if (b < 1e-3) return {0, 0};
    // ∇_R b = (|R| + |R−s|)/(4b) · (R/|R| + (R−s)/|R−s|); f = −dV/db ∇b = V0/σ e^{−b/σ} ∇b.
    // (Three divisions per pair: this runs for every neighbour within 5 m.)
    const double inv1 = 1.0 / magR, inv2 = 1.0 / magR2, invSigma = 1.0 / sigma_;
    const Vec2 gradB = (sum / (4.0 * b)) * (R * inv1 + R2 * inv2);
    return V0_ * invSigma * std::exp(-b * invSigma) * gradB;
}

int SocialForcesAvoidance::pairLoopPath() { return gPairLoopPath.load(); }

bool SocialForcesAvoidance::setPairLoopPath(int path) {
    if (!cpu::runsBuild(path)) return false;
    gPairLoopPath.store(path);
    return true;
}

void SocialForcesAvoidance::prepare(const StepContext& ctx) {
    // The neighbour's step v_β Δt e_β depends on the neighbour only: computed once per agent here
    // instead of once per pair (a norm and a normalisation saved in the O(N·k) loop). With relative
    // velocities the pair's step (v_β − v_α)Δt is step_[j] − step_[i], step_ = v Δt.
    const AgentStore& A = ctx.agents;
    const std::size_t n = A.size();
    const bool relative = otherVelocity_ != 0;
    step_.resize(n);
    other_.resize(n);
    // The field of view's cosine, once per step rather than once per agent (a library cos per
    // agent was ~1 % of the UMANS 10k run; issue 20). fov may change between steps (schedules).
    cosFov_ = std::cos(fovDeg_ * kPi / 180.0);
    // On the team, in the static chunks of the step's other loops: one thread reading every
    // agent's velocity here made the other core's writes of its velocities in the integration take
    // each cache line back (issue 20).
#pragma omp parallel for schedule(static) if (parallelCheapLoop(n))
    for (std::ptrdiff_t jj = 0; jj < static_cast<std::ptrdiff_t>(n); ++jj) {
        const std::size_t j = static_cast<std::size_t>(jj);
        step_[j] = relative ? Vec2(dt_ * A.vel[j]) : Vec2(A.vel[j].norm() * dt_ * normalisedOrZero(A.prefVel[j]));
        // What the pair loop reads of a neighbour, in one 32-byte record (one cache line).
        other_[j] = Other{step_[j].x(), step_[j].y(), relative ? 0.0 : step_[j].squaredNorm(), A.radius[j]};
    }
}

Vec2 SocialForcesAvoidance::wallForce(const Vec2& diff) const {
    const double d = diff.norm();
    if (d < 1e-3) return {0, 0};
    return U0_ / R_ * std::exp(-d / R_) * (diff / d);
}

Vec2 SocialForcesAvoidance::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    // Walking direction for the field of view: the velocity, or the preferred one when at rest.
    Vec2 heading = normalisedOrZero(q.velocity);
    if (heading.squaredNorm() == 0) heading = normalisedOrZero(q.prefVelocity);
    const double cosFov = cosFov_;

    const bool relative = otherVelocity_ != 0;
    PairLoop in;
    in.other = other_.data();
    in.ownStep = relative ? Vec2(step_[static_cast<std::size_t>(q.i)]) : Vec2(0, 0);
    in.relative = relative;
    in.cutoff = contactCutoff_ != 0;
    in.headingZero = heading.squaredNorm() == 0;
    in.ownRadius = q.radius;
    in.range = range_;
    in.cosFov = cosFov;
    in.behind = behind_;
    in.V0 = V0_;
    in.sigma = sigma_;
    in.heading = heading;
    Vec2 f = q.agents.empty() ? Vec2(0, 0) : pedestrianForces(q.agents, in);
    if (walls_ != 0) return (f + wallsUmans(q, ctx, heading, cosFov)) / q.mass;
    // Walls: one force per obstacle, from its nearest point (Helbing & Molnár's "nearest point of
    // the border"). Summing over segments would count a convex corner twice — its two edges share
    // the nearest point — and push agents back from door jambs with double strength. The query's
    // segments are ascending by index and an obstacle's edges are consecutive.
    const auto& segments = ctx.world.segments();
    std::size_t k = 0;
    while (k < q.segments.size()) {
        const int obstacle = segments[q.segments[k]].obstacle;
        Vec2 nearest(0, 0);
        double best = kInf;
        for (; k < q.segments.size() && segments[q.segments[k]].obstacle == obstacle; ++k) {
            const Segment& seg = segments[q.segments[k]];
            const Vec2 diff = q.position - closestPointOnSegment(q.position, seg.a, seg.b);
            if (diff.squaredNorm() < best) {
                best = diff.squaredNorm();
                nearest = diff;
            }
        }
        if (std::sqrt(best) <= range_) f += wallForce(nearest);
    }
    return f / q.mass;
}

Vec2 SocialForcesAvoidance::wallsUmans(const AgentQuery& q, const StepContext& ctx, const Vec2& heading,
                                       double cosFov) const {
    // UMANS 1.x: every obstacle edge in range counts, except (1) an edge the agent lies behind
    // (inside the obstacle, or the far face of a thick wall) and (2) an edge whose nearest point is
    // its end corner: walking a polygon counter-clockwise, the next edge starts at that corner, so
    // a convex corner pushes once. Each force is weighted like a pedestrian at the nearest point
    // (full inside the field of view, `behind` outside). As in UMANS the edges are taken as listed
    // and "behind" means left of a→b, which is right for counter-clockwise polygons (UMANS'
    // convention, its example files, our <Box>); a clockwise polygon keeps its far faces instead.
    const auto& segments = ctx.world.segments();
    Vec2 f(0, 0);
    for (const int k : q.segments) {
        const Segment& seg = segments[static_cast<std::size_t>(k)];
        const Vec2& a = seg.a;
        const Vec2& b = seg.b;
        const Vec2 ab = b - a;
        const Vec2 ap = q.position - a;
        if (ab.x() * ap.y() - ab.y() * ap.x() > 0) continue;  // left of a→b: the inner side
        const double len2 = ab.squaredNorm();
        const double t = len2 > 0 ? ap.dot(ab) / len2 : 0.0;
        if (t >= 1.0) continue;  // nearest point is its end corner: the next edge takes it
        const Vec2 diff = t <= 0.0 ? ap : Vec2(ap - t * ab);
        if (diff.squaredNorm() > range_ * range_) continue;
        const double d = diff.norm();
        const bool inView = heading.squaredNorm() == 0 || d < 1e-9 || heading.dot(-diff / d) >= cosFov;
        f += (inView ? 1.0 : behind_) * wallForce(diff);
    }
    return f;
}

}  // namespace ch
