// CrowdHealth — the static world: its type (infinite, toric, planar), obstacles as wall
// segments with a segment grid, and static SPH boundary particles.
#pragma once

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/scenario.h"

#include <span>
#include <vector>

namespace ch {

class World {
public:
    World() = default;
    World(const WorldSpec& spec, const std::vector<ObstacleSpec>& obstacles);
    /// Not copied or moved: its wall and particle grids point into its own vectors, which a copy
    /// would leave pointing into the original (and a move, into the emptied one).
    World(const World&) = delete;
    World& operator=(const World&) = delete;

    WorldType type() const { return spec_.type; }
    const WorldSpec& spec() const { return spec_; }
    bool periodic() const { return spec_.type == WorldType::Toric; }

    /// Shortest vector from `from` to `to` (minimum image on a torus).
    Vec2 offset(const Vec2& from, const Vec2& to) const;
    /// Maps a position back into the torus [-w/2, w/2) × [-h/2, h/2) (identity otherwise).
    Vec2 wrap(const Vec2& p) const;
    /// Planar worlds: true when p is inside the bounds (always true for other types).
    bool inside(const Vec2& p) const;

    const std::vector<ObstacleSpec>& obstacles() const { return obstacles_; }
    /// Every obstacle edge, in obstacle order then vertex order.
    const std::vector<Segment>& segments() const { return segments_; }
    /// Indices of the segments within `radius` of p (ascending, each once).
    void segmentsNear(const Vec2& p, double radius, std::vector<int>& out) const { segmentGrid_.near(p, radius, out); }
    /// Readies segmentsNear() for queries of these radii (the policies' neighbourhoods): see
    /// SegmentGrid::prepare.
    void prepareWallQueries(const std::vector<double>& radii) {
        for (const double r : radii) segmentGrid_.prepare(r);
    }
    /// Static SPH boundary particles of every obstacle (m).
    const std::vector<Vec2>& boundaryParticles() const { return particles_; }
    const PointGrid& particleGrid() const { return particleGrid_; }
    /// True when p is inside any obstacle polygon.
    bool insideObstacle(const Vec2& p) const { return obstacleAt(p) >= 0; }
    /// The lowest index of the obstacle polygons (three points or more) p lies inside
    /// (pointInPolygon), or −1. Only the obstacles listed in p's cell of an index of their bounds
    /// are tested, so a venue of thousands of obstacles costs a few tests, not thousands.
    int obstacleAt(const Vec2& p) const;
    /// Obstacle o's edges: a contiguous run of segments().
    std::span<const Segment> segmentsOf(int o) const {
        const std::size_t k = static_cast<std::size_t>(o);
        return {segments_.data() + firstSegment_[k], firstSegment_[k + 1] - firstSegment_[k]};
    }

private:
    WorldSpec spec_;
    std::vector<ObstacleSpec> obstacles_;
    std::vector<Segment> segments_;
    std::vector<std::size_t> firstSegment_;  ///< obstacle o's edges: segments_[first[o], first[o + 1])
    SegmentGrid segmentGrid_;
    std::vector<Box> polygonBounds_;  ///< each obstacle polygon's bounds, widened a little (empty for a wall)
    BoxIndex polygons_;               ///< polygonBounds_ by cell
    std::vector<Vec2> particles_;
    PointGrid particleGrid_;
};

}  // namespace ch
