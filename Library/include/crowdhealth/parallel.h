// CrowdHealth — when loops run on the OpenMP team.
#pragma once

#include <cstddef>

namespace ch {

/// Per-agent loops over neighbours (neighbour lists, SPH density, contact, the policy evaluation)
/// run on the OpenMP team only from this many agents: below it, waking the team costs more than
/// the loop, and on a busy machine a partner thread that spins while waiting for a descheduled one
/// can cost far more (the 400-agent doorway ran 20x slower on 2 threads beside another job).
/// Results never depend on it: every loop writes only its own agent's slot.
inline constexpr std::ptrdiff_t kParallelMinAgents = 1000;

}  // namespace ch
