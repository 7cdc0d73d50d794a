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

void NeighbourLists::build(const std::vector<Vec2>& positions, const PointGrid& stepGrid, const World& world,
                           const std::vector<int>& group, const std::vector<double>& rangeOfGroup) {
    const std::size_t n = positions.size();
    // Long ranges (social forces: 5 m) search a finer grid of their own. With cells as wide as
    // the range, the query disc's bounding box covers 3 × 3 cells, (2r + c)² = 9r² of area for a
    // disc of πr²: 2.9 candidates per neighbour, each written to the list (branch-free append).
    // With cells of r/4 it covers (2.25r)², 1.6 candidates per neighbour, for one more counting
    // sort of the positions per step. Lists then follow that grid's visit order: the same
    // neighbours, summed in another order (docs/performance.md, issue 20). Short ranges (SPH,
    // contact: ~1 m) keep the step's grid and its order; so do periodic worlds.
    double reach = 0;
    for (double r : rangeOfGroup) reach = std::max(reach, r);
    const PointGrid* gridUsed = &stepGrid;
    if (!world.periodic() && reach >= kFineGridFrom && n > 0) {
        fine_.build(positions, reach / kFineGridCells);
        gridUsed = &fine_;
    }
    const PointGrid& grid = *gridUsed;
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
