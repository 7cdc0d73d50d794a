// CrowdHealth — an exact radix sort of doubles, for sorts repeated every step over many values.
#pragma once

#include <cstdint>
#include <vector>

namespace ch {

/// Sorts v ascending, as std::sort(v.begin(), v.end()) does: the same values in the same order
/// (equal values may differ only in the sign of a zero, which no comparison sees). v must hold no
/// NaN; ±∞ and negative values are fine. A least-significant-digit radix sort of order-keeping
/// 64-bit keys, one byte per pass, skipping the passes whose byte is the same in every key:
/// several times quicker than std::sort from a few thousand values on (the quickest exit rule sorts
/// everyone's remaining distance every step). Below 256 values it calls std::sort. `keys` and
/// `scratch`: working storage the caller keeps between calls (resized here, contents ignored).
void sortDoubles(std::vector<double>& v, std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch);

}  // namespace ch
