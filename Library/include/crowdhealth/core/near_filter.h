// CrowdHealth — a quick first pass over a neighbour list: which entries lie within a distance
// (issue 20: UMANS' post-clamp contact scans the 5 m lists of SocialForces for the few neighbours
// in contact; this finds the candidates eight entries at a time where the CPU has AVX-512).
#pragma once

#include "crowdhealth/core/neighbours.h"

#include <cstddef>
#include <cstdint>

namespace ch {

/// Bit l set (l < count ≤ 64) when entry e[l]'s offset has x·x + y·y ≤ bound2 (computed without
/// fused multiply-add), and possibly for a few more: bound2 is widened by a relative 2^-40 so
/// that an entry an exact test `distanceSquared() < r²` with r² ≤ bound2 keeps is always set,
/// whatever the rounding. A conservative filter: callers test each set entry exactly. Bits at
/// and above `count` are 0.
std::uint64_t nearEntries(const NeighbourAgent* e, std::size_t count, double bound2);

/// The builds of nearEntries: 0 scalar (every CPU), 1 AVX-512 (eight entries per step). The
/// best this CPU runs is used; setNearEntriesPath returns false and changes nothing when this
/// CPU cannot run `path` (tests compare the builds).
int nearEntriesPath();
bool setNearEntriesPath(int path);

}  // namespace ch
