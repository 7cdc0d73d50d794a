// CrowdHealth — the static world: its type (infinite, toric, planar), obstacles as wall
// segments with a segment grid, and static SPH boundary particles.
#pragma once

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/scenario.h"

#include <vector>

namespace ch {

class World {
public:
    World() = default;
    World(const WorldSpec& spec, const std::vector<ObstacleSpec>& obstacles);

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
    /// Static SPH boundary particles of every obstacle (m).
    const std::vector<Vec2>& boundaryParticles() const { return particles_; }
    const PointGrid& particleGrid() const { return particleGrid_; }
    /// True when p is inside any obstacle polygon.
    bool insideObstacle(const Vec2& p) const;

private:
    WorldSpec spec_;
    std::vector<ObstacleSpec> obstacles_;
    std::vector<Segment> segments_;
    SegmentGrid segmentGrid_;
    std::vector<Vec2> particles_;
    PointGrid particleGrid_;
};

}  // namespace ch
