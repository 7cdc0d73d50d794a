// CrowdHealth — small SIMD helpers (issue 20): four doubles per value with GCC/Clang vector
// extensions (two SSE2 registers in the generic x86-64 build, one AVX2 register where the caller is
// compiled for it), and an exponential for them. Used by SocialForcesAvoidance's pair loop
// (Policies/SocialForcesSimd.h) and by the crowd field's Gaussian weights (health/safety.cpp).
// The helpers are templates over the vector type too: the pair loop also runs two lanes (one SSE2
// register) and eight (one AVX-512 register). (Eight lanes in two AVX2 registers per value ran the
// pair loop 2x slower: the registers spill.)
#pragma once

#include <cstdint>
#include <cstring>

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

/// e^x lane by lane for x in [−708, 0], no comparison: the core of expNonPositive (whose method
/// note applies). Lanes outside that interval give unspecified values.
template <class V>
[[gnu::always_inline]] inline V expInRange(V x) {
    using I = MaskOf<V>;
    // k = round(x·log2 e): adding 1.5·2^52 leaves k in the low bits of the mantissa (|k| < 2^31).
    const V shifter = splatAs<V>(6755399441055744.0);
    const V t = x * splatAs<V>(1.4426950408889634074) + shifter;
    const V k = t - shifter;
    const V r = (x - k * splatAs<V>(6.93147180369123816490e-01)) - k * splatAs<V>(1.90821492927058770002e-10);
    // e^r ≈ Σ_{n=0}^{12} rⁿ/n!, evaluated by Estrin's scheme (pairs, then powers r², r⁴, r⁸): a
    // dependency chain of 5 multiply-adds instead of Horner's 12, so the lanes of several pairs
    // overlap in the pipeline.
    const V r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
    const V q0 = splatAs<V>(1.0) + r, q2 = splatAs<V>(1.0 / 2) + splatAs<V>(1.0 / 6) * r;
    const V q4 = splatAs<V>(1.0 / 24) + splatAs<V>(1.0 / 120) * r, q6 = splatAs<V>(1.0 / 720) + splatAs<V>(1.0 / 5040) * r;
    const V q8 = splatAs<V>(1.0 / 40320) + splatAs<V>(1.0 / 362880) * r;
    const V q10 = splatAs<V>(1.0 / 3628800) + splatAs<V>(1.0 / 39916800) * r;
    const V s0 = q0 + q2 * r2, s4 = q4 + q6 * r2, s8 = q8 + q10 * r2;
    const V p = (s0 + s4 * r4) + (s8 + splatAs<V>(1.0 / 479001600) * r4) * r8;
    // 2^k: k sits in the low 32 bits of t's integer image (two's complement); shifted into the
    // exponent field it adds k to p's exponent (p ∈ [0.7, 1.5], k ≥ −1022: no overflow of the field).
    const I kbits = (asInt(t) << 52);
    return asDouble(asInt(p) + kbits);
}

/// e^x lane by lane, for x ≤ 0 (the social-force potential's e^{−b/σ}); relative error below
/// 1e-14 against std::exp over [−708, 0] (Tests/policies_social_forces_simd_test.cpp), 0 below −708 (where
/// e^x is below 3e-308, a subnormal or zero). NaN lanes give unspecified values (callers mask them).
/// (For DV; with DV8 GCC 12 would compare lane by lane in scalar code: the AVX-512 pair loop
/// clamps with a mask register and calls expInRange.)
///
/// Method: x = k·ln 2 + r with k = round(x / ln 2) and |r| ≤ ln 2 / 2 (ln 2 in two parts, so r is
/// exact to ~1e-19), e^r by its Taylor series to r¹² (truncation < 2e-16 relative on that
/// interval; Estrin's scheme), then 2^k put into the exponent bits. No table, no branch, no library call: it
/// vectorises, which std::exp does not.
[[gnu::always_inline]] inline DV expNonPositive(DV x) {
    const DV tooSmall = splat(-708.0);
    const IV underflow = x < tooSmall;
    return select(underflow, splat(0.0), expInRange(select(underflow, tooSmall, x)));
}

}  // namespace ch::simd

#pragma GCC diagnostic pop
