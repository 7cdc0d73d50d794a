// CrowdHealth — when loops run on the OpenMP team.
#pragma once

#include <cstddef>

namespace ch {

/// The smallest crowd whose per-agent loops over neighbours (neighbour lists, SPH density,
/// contact, the policy evaluation) run on the OpenMP team. Below it, waking the team costs more
/// than the loop, and on a busy machine a partner thread that spins while waiting for a
/// descheduled one can cost far more (the 400-agent doorway ran 20x slower on 2 threads beside
/// another job). Default 1000, or the environment variable CROWDHEALTH_PARALLEL_MIN_AGENTS; the
/// test suite sets 1 so that small test crowds exercise the parallel code paths. Results never
/// depend on it: every loop writes only its own agent's slot.
std::size_t parallelMinAgents();
void setParallelMinAgents(std::size_t n);

/// Whether a loop over n agents with neighbour work runs on the team.
inline bool parallelNeighbourLoop(std::size_t n) { return n >= parallelMinAgents(); }
/// Whether a cheap O(n) loop (a few operations per agent: preferred velocities, integration, the
/// health layer's updates) runs on the team: from four times as many agents.
inline bool parallelCheapLoop(std::size_t n) { return n >= 4 * parallelMinAgents(); }

}  // namespace ch
