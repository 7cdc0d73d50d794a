// CrowdHealth — per-step neighbour lists.
#include "crowdhealth/core/neighbours.h"

#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/world.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

namespace ch {

NeighbourLists::Slice NeighbourLists::slice(int thread, const Place& at, std::size_t count) {
    return Slice{static_cast<std::uint32_t>(thread), static_cast<std::uint32_t>(at.block),
                 static_cast<std::uint32_t>(at.begin), static_cast<std::uint32_t>(count)};
}

void NeighbourLists::build(const std::vector<Vec2>& positions, const PointGrid& grid, const World& world,
                           const std::vector<int>& group, const std::vector<double>& rangeOfGroup) {
    const std::size_t n = positions.size();
    const int threads = std::max(1, omp_get_max_threads());
    if (agentBuffers_.size() < static_cast<std::size_t>(threads)) {
        agentBuffers_.resize(static_cast<std::size_t>(threads));
        segmentBuffers_.resize(static_cast<std::size_t>(threads));
        scratch_.resize(static_cast<std::size_t>(threads));
    }
    agentSlice_.resize(n);
    segmentSlice_.resize(n);
    group_ = &group;
    rangeOfGroup_ = rangeOfGroup;

#pragma omp parallel num_threads(threads) if (parallelNeighbourLoop(n))
    {
        const int t = omp_get_thread_num();
        BlockBuffer<NeighbourAgent>& out = agentBuffers_[static_cast<std::size_t>(t)];
        BlockBuffer<int>& segOut = segmentBuffers_[static_cast<std::size_t>(t)];
        std::vector<int>& near = scratch_[static_cast<std::size_t>(t)];
        out.clear();
        segOut.clear();
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const int self = static_cast<int>(i);
            const double r = rangeOfGroup[static_cast<std::size_t>(group[i])];
            Place at;
            NeighbourAgent* list = out.open(at, grid.candidateCount(positions[i], r));
            std::size_t count = 0;
            const double r2 = r * r;
            // Branch-free append: every candidate is written at `count`, which advances only for
            // the others within r (the buffer holds candidateCount entries, so this stays inside).
            grid.forEachCandidate(positions[i], r, [&](int j, const Vec2& d, double d2) {
                list[count] = NeighbourAgent{d, j};
                count += static_cast<std::size_t>((d2 <= r2) & (j != self));
            });
            out.close(at, count);
            agentSlice_[i] = slice(t, at, count);
            world.segmentsNear(positions[i], r, near);
            Place sat;
            std::copy(near.begin(), near.end(), segOut.open(sat, near.size()));
            segOut.close(sat, near.size());
            segmentSlice_[i] = slice(t, sat, near.size());
        }
    }
}

}  // namespace ch
