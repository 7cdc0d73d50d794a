// CrowdHealth — which vector instruction sets this CPU runs, for the hand-vectorised loops that
// pick a build when the program starts (the social-force pair loop, the neighbour-list gather,
// UMANS' contact filter, SPH's and ContactForces' pair sums; docs/performance.md, issue 20). Safe
// to call from static initialisers.
#pragma once

namespace ch::cpu {

/// AVX2.
inline bool hasAvx2() {
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();  // a static initialiser may run before libgcc's own
    return __builtin_cpu_supports("avx2");
#else
    return false;
#endif
}

/// AVX-512 F, DQ and VL (what the AVX-512 builds of those loops use).
inline bool hasAvx512() {
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl");
#else
    return false;
#endif
}

/// The builds of the loops hand-vectorised three ways (the social-force pair loop, the
/// neighbour-list gather, the crowd field's scatter), numbered alike: 0 generic, 1 AVX2,
/// 2 AVX-512. Those loops compile the AVX2 and AVX-512 builds with GCC on x86-64 only; elsewhere
/// build 0 alone runs.
inline bool runsBuild(int path) {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    if (path == 1) return hasAvx2();
    if (path == 2) return hasAvx512();
#endif
    return path == 0;
}

/// The best of those builds this CPU runs (what such a loop uses unless told otherwise).
inline int bestBuild() { return runsBuild(2) ? 2 : runsBuild(1) ? 1 : 0; }

}  // namespace ch::cpu
