// CrowdHealth — small SIMD helpers (issue 20): four doubles per value with GCC/Clang vector
// extensions (two SSE2 registers in the generic x86-64 build, one AVX2 register where the caller is
// compiled for it), and an exponential for them (a 16-entry table and a degree-7 series). Used by
// SocialForcesAvoidance's pair loop (Policies/SocialForcesSimd.h), the crowd field's Gaussian
// weights (health/safety.cpp), and an atan2 for the health layer's turns (angleOf).
// The helpers are templates over the vector type too: the pair loop also runs two lanes (one SSE2
// register) and eight (one AVX-512 register). (Eight lanes in two AVX2 registers per value ran the
// pair loop 2x slower: the registers spill.)
#pragma once

#include <cstdint>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#define CH_SIMD_AVX512_MASKS 1
#endif

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"  // DV by value: every helper is inlined, no call crosses an ABI

namespace ch::simd {

/// Lanes per value.
inline constexpr int kLanes = 4;
/// kLanes doubles; arithmetic is element-wise IEEE (no fused multiply-add unless the compiler is
/// told it may contract, which the generic build does not), so each lane gives the bits of the
/// same scalar expression.
typedef double DV __attribute__((vector_size(8 * kLanes)));
/// kLanes 64-bit integers: masks from comparisons of DV (all ones = true) and exponent bits.
typedef std::int64_t IV __attribute__((vector_size(8 * kLanes)));

/// kWideLanes doubles (one AVX-512 register): SocialForcesAvoidance's pair loop where the CPU has
/// AVX-512 (issue 20). splatAs, asInt, asDouble, sqrt, select and expInRange take any width.
inline constexpr int kWideLanes = 8;
typedef double DV8 __attribute__((vector_size(8 * kWideLanes)));
typedef std::int64_t IV8 __attribute__((vector_size(8 * kWideLanes)));

/// Two doubles (one SSE2 register): the generic x86-64 build of the pair loop.
typedef double DV2 __attribute__((vector_size(16)));
typedef std::int64_t IV2 __attribute__((vector_size(16)));

/// The mask type of a double vector V (what its comparisons give).
template <class V>
using MaskOf = decltype(V{} < V{});

[[gnu::always_inline]] inline DV splat(double x) { return DV{} + x; }
/// x in every lane of a V.
template <class V>
[[gnu::always_inline]] inline V splatAs(double x) {
    return V{} + x;
}

template <class I>
[[gnu::always_inline]] inline auto asDouble(I v) {
    typedef double D __attribute__((vector_size(sizeof(I))));
    D d;
    std::memcpy(&d, &v, sizeof d);
    return d;
}
template <class V>
[[gnu::always_inline]] inline MaskOf<V> asInt(V v) {
    MaskOf<V> i;
    std::memcpy(&i, &v, sizeof i);
    return i;
}

/// Square root lane by lane: packed instructions where the including file is compiled with
/// -fno-math-errno (SocialForcesAvoidance.cpp is), else scalar ones.
template <class V>
[[gnu::always_inline]] inline V sqrt(V v) {
    V r;
    for (int l = 0; l < static_cast<int>(sizeof(V) / sizeof(double)); ++l) r[l] = __builtin_sqrt(v[l]);
    return r;
}

/// Lane-wise select: m ? a : b (m from a comparison).
template <class V>
[[gnu::always_inline]] inline V select(MaskOf<V> m, V a, V b) {
    return asDouble((m & asInt(a)) | (~m & asInt(b)));
}

/// 2^{j/16} for j = 0 … 15, each the double nearest to it: the table of expInRange.
alignas(64) inline constexpr double kExp2Sixteenths[16] = {
    1.0,
    1.044273782427413840321966,
    1.090507732665257659207011,
    1.138788634756691653703830,
    1.189207115002721066717500,
    1.241857812073484048593677,
    1.296839554651009665933754,
    1.354255546936892728298015,
    1.414213562373095048801689,
    1.476826145939499311386907,
    1.542210825407940823612292,
    1.610490331949254308179521,
    1.681792830507429086062251,
    1.756252160373299483112161,
    1.834008086409342463487083,
    1.915206561397147293872611,
};

/// kExp2Sixteenths[j[l]] in lane l (0 ≤ j[l] < 16). Eight lanes (an AVX-512 register where the
/// caller is compiled for it): one two-register permute (the table is two registers). Fewer
/// lanes: a load per lane. Either way the table's values themselves, so the same bits.
template <class V>
[[gnu::always_inline]] inline V exp2Sixteenths(MaskOf<V> j) {
#if defined(__GNUC__) && !defined(__clang__)
    if constexpr (sizeof(V) == 64) {
        V lo, hi;
        std::memcpy(&lo, kExp2Sixteenths, sizeof lo);
        std::memcpy(&hi, kExp2Sixteenths + 8, sizeof hi);
        return __builtin_shuffle(lo, hi, j);
    }
#endif
    V r;
    for (int l = 0; l < static_cast<int>(sizeof(V) / sizeof(double)); ++l) r[l] = kExp2Sixteenths[j[l]];
    return r;
}

/// Comparisons and selects by width, for code written once for every width (templates over V,
/// such as SocialForcesAvoidance's pair loop and expNonPositive):
/// le(a, b) = a ≤ b, lt(a, b) = a < b and eq(a, b) = a == b lane by lane (IEEE ordered: false with
/// NaN), sel(m, a, b)
/// = m ? a : b, allLanes(v) = every lane set.
/// Two and four lanes: GCC's vector comparisons (all-ones lanes). Eight lanes: AVX-512 mask
/// registers through GCC's builtins (GCC 12 expands a comparison of 512-bit vectors that gives a
/// vector lane by lane, with scalar compares; the <immintrin.h> functions carry the AVX-512 target
/// themselves and could not be inlined into these generic helpers), only in functions compiled
/// for AVX-512. Every width gives the same results lane by lane.
[[gnu::always_inline]] inline IV2 le(DV2 a, DV2 b) { return a <= b; }
[[gnu::always_inline]] inline IV2 lt(DV2 a, DV2 b) { return a < b; }
[[gnu::always_inline]] inline IV2 eq(DV2 a, DV2 b) { return a == b; }
[[gnu::always_inline]] inline IV2 allLanes(DV2) { return IV2{} - 1; }
[[gnu::always_inline]] inline DV2 sel(IV2 m, DV2 a, DV2 b) { return select(m, a, b); }
[[gnu::always_inline]] inline IV le(DV a, DV b) { return a <= b; }
[[gnu::always_inline]] inline IV lt(DV a, DV b) { return a < b; }
[[gnu::always_inline]] inline IV eq(DV a, DV b) { return a == b; }
[[gnu::always_inline]] inline IV allLanes(DV) { return IV{} - 1; }
[[gnu::always_inline]] inline DV sel(IV m, DV a, DV b) { return select(m, a, b); }
#ifdef CH_SIMD_AVX512_MASKS
[[gnu::always_inline]] inline __mmask8 le(DV8 a, DV8 b) {
    return __builtin_ia32_cmppd512_mask(a, b, _CMP_LE_OQ, 0xff, _MM_FROUND_CUR_DIRECTION);
}
[[gnu::always_inline]] inline __mmask8 lt(DV8 a, DV8 b) {
    return __builtin_ia32_cmppd512_mask(a, b, _CMP_LT_OQ, 0xff, _MM_FROUND_CUR_DIRECTION);
}
[[gnu::always_inline]] inline __mmask8 eq(DV8 a, DV8 b) {
    return __builtin_ia32_cmppd512_mask(a, b, _CMP_EQ_OQ, 0xff, _MM_FROUND_CUR_DIRECTION);
}
[[gnu::always_inline]] inline __mmask8 allLanes(DV8) { return 0xff; }
[[gnu::always_inline]] inline DV8 sel(__mmask8 m, DV8 a, DV8 b) { return __builtin_ia32_blendmpd_512_mask(b, a, m); }
#endif

/// e^x lane by lane for x in [−708, 0], no comparison: the core of expNonPositive (whose method
/// note applies). Lanes outside that interval give unspecified values.
template <class V>
[[gnu::always_inline]] inline V expInRange(V x) {
    using I = MaskOf<V>;
    // K = round(x·16/ln 2): adding 1.5·2^52 leaves K in the low bits of the mantissa (|K| < 2^15),
    // so the integer image of t is that of 1.5·2^52 (a multiple of 16) plus K.
    const V shifter = splatAs<V>(6755399441055744.0);
    const V t = x * splatAs<V>(23.083120654223414517758790) + shifter;
    const V k = t - shifter;
    // r = x − K·ln 2/16, |r| ≤ ln 2/32: ln 2/16 in two parts, the first with 32 significant bits
    // (K·it is exact), r exact to ~1e-20.
    const V r = (x - k * splatAs<V>(4.3321698773070238530e-02)) - k * splatAs<V>(1.1926343307941173125e-11);
    // e^r − 1 ≈ Σ_{n=1}^{7} rⁿ/n! (truncation below 2e-18 relative on that interval), by Estrin's
    // scheme: (r + r²(1/2 + r/6)) + r⁴((1/24 + r/120) + r²(1/720 + r/5040)).
    const V r2 = r * r, r4 = r2 * r2;
    const V a = splatAs<V>(1.0 / 2) + splatAs<V>(1.0 / 6) * r;
    const V b = splatAs<V>(1.0 / 24) + splatAs<V>(1.0 / 120) * r;
    const V c = splatAs<V>(1.0 / 720) + splatAs<V>(1.0 / 5040) * r;
    const V em1 = (r + a * r2) + (b + c * r2) * r4;
    // e^x = 2^m · 2^{j/16} · e^r with K = 16m + j (j = K mod 16, the low four bits of t's image;
    // m = ⌊K/16⌋): T + T·(e^r − 1) with T = 2^{j/16} from the table, then m added to the
    // exponent field (T·e^r ∈ [0.97, 1.96]; m = −1022 only for K ≥ −16343 with j ≥ 9, where
    // T·e^r > 1: the field stays ≥ 1, a normal number).
    const I bits = asInt(t);
    const V table = exp2Sixteenths<V>(bits & 15);
    const V p = table + table * em1;
    return asDouble(asInt(p) + ((bits >> 4) << 52));
}

/// e^x lane by lane, for x ≤ 0 (the social-force potential's e^{−b/σ}); relative error below
/// 3e-16 (about one ulp) against std::exp over [−708, 0] (Tests/policies_social_forces_simd_test.cpp), 0 below −708 (where
/// e^x is below 3e-308, a subnormal or zero). NaN lanes give unspecified values (callers mask them).
/// Any width (DV8 only in functions compiled for AVX-512: its comparison is a mask register).
///
/// Method: x = (16m + j)·ln 2/16 + r with 16m + j = round(16x / ln 2), 0 ≤ j < 16 and
/// |r| ≤ ln 2/32; e^x = 2^m · 2^{j/16} · e^r, with 2^{j/16} from a 16-entry table, e^r − 1 by its
/// Taylor series to r⁷, and 2^m put into the exponent bits. No branch, no library call: it
/// vectorises, which std::exp does not. (Until issue 20's fifth round: no table, |r| ≤ ln 2/2 and
/// the series to r¹², ~4 ulp: a quarter more operations; with the table the AVX-512 pair loop's
/// exponential takes 19 % less time, the SSE2 one 10 % less, the AVX2 one 3 % more, since AVX2
/// has no permute across four doubles from a register pair and loads the entries one by one.)
template <class V>
[[gnu::always_inline]] inline V expNonPositive(V x) {
    const V tooSmall = splatAs<V>(-708.0);
    const auto underflow = lt(x, tooSmall);
    return sel(underflow, V{}, expInRange(sel(underflow, tooSmall, x)));
}

/// atan(k/8) for k = 0 … 8, each the double nearest to it: the table of angleOf.
inline constexpr double kAtanEighths[9] = {
    0.0,
    0.1243549945467614350313548,
    0.2449786631268641541720825,
    0.3587706702705722203959201,
    0.4636476090008061162142562,
    0.5585993153435624359715082,
    0.6435011087932843868028092,
    0.7188299996216245054170142,
    0.7853981633974483096156608,
};

/// atan2(y, x) lane by lane for y ≥ 0: the angle in [0, π] of the vector (x, y) — and so, with
/// y = |sin θ|, x = cos θ, the size of a turn θ. Relative error below 5e-16 (about two ulp)
/// against std::atan2 (Tests/core_simd_angle_test.cpp). Lanes with x = y = 0 give 0 (std::atan2
/// gives π for x = −0); NaN lanes give unspecified values. For DV and narrower: its comparisons are
/// GCC's vector ones, which GCC 12 does lane by lane on DV8.
///
/// Method: u = min(y, |x|)/max(y, |x|) ∈ [0, 1]; with c = k/8 the nearest eighth,
/// atan u = atan c + atan v, v = (u − c)/(1 + uc), computed from y and |x| themselves as
/// (num − c·den)/(den + c·num), |v| ≤ 1/16; atan(c) from a 9-entry table, atan v by its series to
/// v¹³ (truncation below 3e-20 relative); then π/2 − · where |x| < y and π − · where x < 0 (π/2
/// and π in two parts). No branch, no library call.
template <class V>
[[gnu::always_inline]] inline V angleOf(V y, V x) {
    using I = MaskOf<V>;
    const V ax = asDouble(asInt(x) & static_cast<std::int64_t>(0x7fffffffffffffff));
    const I swap = y > ax;
    const V num = select(swap, ax, y);
    const I empty = select(swap, y, ax) == splatAs<V>(0.0);
    const V den = select(empty, splatAs<V>(1.0), select(swap, y, ax));
    // k = round(8u) ∈ {0, …, 8} (1.5·2^52 leaves it in the low bits), c = k/8.
    const V shifter = splatAs<V>(6755399441055744.0);
    const V t = (num / den) * splatAs<V>(8.0) + shifter;
    const V c = (t - shifter) * splatAs<V>(0.125);
    const V v = (num - c * den) / (den + c * num);
    const V w = v * v;
    V q = splatAs<V>(1.0 / 13);
    q = q * w - splatAs<V>(1.0 / 11);
    q = q * w + splatAs<V>(1.0 / 9);
    q = q * w - splatAs<V>(1.0 / 7);
    q = q * w + splatAs<V>(1.0 / 5);
    q = q * w - splatAs<V>(1.0 / 3);
    const I k = asInt(t) & 15;
    V table;
    for (int l = 0; l < static_cast<int>(sizeof(V) / sizeof(double)); ++l) table[l] = kAtanEighths[k[l]];
    const V a = table + (v + v * (w * q));
    const V b = select(swap, (splatAs<V>(1.5707963267948966) - a) + splatAs<V>(6.123233995736766e-17), a);
    const V angle = select(x < splatAs<V>(0.0), (splatAs<V>(3.141592653589793) - b) + splatAs<V>(1.2246467991473532e-16), b);
    return select(empty, splatAs<V>(0.0), angle);
}

}  // namespace ch::simd

#pragma GCC diagnostic pop
