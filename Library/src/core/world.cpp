// CrowdHealth — the static world.
#include "crowdhealth/core/world.h"

#include <algorithm>
#include <cmath>

namespace ch {

World::World(const WorldSpec& spec, const std::vector<ObstacleSpec>& obstacles)
    : spec_(spec), obstacles_(obstacles) {
    firstSegment_.assign(1, 0);
    polygonBounds_.assign(obstacles_.size(), Box());
    for (std::size_t o = 0; o < obstacles_.size(); ++o) {
        const auto& pts = obstacles_[o].points;
        const std::size_t n = pts.size();
        // A two-point obstacle is a single wall; a polygon is closed implicitly.
        const std::size_t edges = n == 2 ? 1 : n;
        for (std::size_t k = 0; k < edges; ++k)
            segments_.push_back(Segment{pts[k], pts[(k + 1) % n], static_cast<int>(o)});
        firstSegment_.push_back(segments_.size());
        particles_.insert(particles_.end(), obstacles_[o].particles.begin(), obstacles_[o].particles.end());
        // pointInPolygon interpolates its crossings, so a point it finds inside may lie a few
        // rounding errors to the right of the vertices' bounds: the margin keeps it in the box.
        if (n >= 3) polygonBounds_[o] = Box::around(pts).grownPastRounding(0.0);
    }
    // Walls are queried with radii of about an agent radius up to a few metres.
    segmentGrid_.build(segments_, 2.0);
    polygons_.build(polygonBounds_, 2.0);
    particleGrid_.build(particles_, 1.0);
}

Vec2 World::offset(const Vec2& from, const Vec2& to) const {
    Vec2 d = to - from;
    if (periodic()) {
        d.x() -= spec_.width * std::round(d.x() / spec_.width);
        d.y() -= spec_.height * std::round(d.y() / spec_.height);
    }
    return d;
}

Vec2 World::wrap(const Vec2& p) const {
    if (!periodic()) return p;
    Vec2 q = p;
    const double hw = 0.5 * spec_.width, hh = 0.5 * spec_.height;
    q.x() -= spec_.width * std::floor((q.x() + hw) / spec_.width);
    q.y() -= spec_.height * std::floor((q.y() + hh) / spec_.height);
    return q;
}

bool World::inside(const Vec2& p) const {
    if (spec_.type != WorldType::Planar) return true;
    return p.x() >= spec_.xmin && p.x() <= spec_.xmax && p.y() >= spec_.ymin && p.y() <= spec_.ymax;
}

int World::obstacleAt(const Vec2& p) const {
    for (const int o : polygons_.at(p)) {
        const std::size_t k = static_cast<std::size_t>(o);
        if (polygonBounds_[k].contains(p) && pointInPolygon(p, obstacles_[k].points)) return o;
    }
    return -1;
}

}  // namespace ch
