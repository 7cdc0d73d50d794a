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

}  // namespace ch::cpu
