// CrowdHealth — geodesic distance fields on a grid (DESIGN §8, docs/navigation.md).
//
// The venue is rasterised once into a WalkableGrid of square cells: a cell is blocked when its
// centre lies inside an obstacle polygon or within half a cell diagonal of a wall segment (so every
// cell a wall crosses is blocked and a wall of any orientation is a 4-connected barrier), or
// outside a planar world. Every walkable cell carries a travel speed that keeps paths clear of
// walls:
//     f(d) = f_min + (1 − f_min)·min(1, d / clearance),   d = distance from the cell centre to the
//                                                          nearest wall (m),
// so f = 1 at least `clearance` from every wall and f_min at a wall (clearance 0: f = 1).
//
// A DistanceField is the solution T of the eikonal equation |∇T| = 1/f on the walkable cells with
// T = d/f + clearance·(1/f − 1), d the Euclidean distance to the target shape, on the cells next to
// or inside the target (centre within 1.5 cells of the shape; /f keeps these seeds consistent with
// the cost the march charges near a wall, the second term makes reaching the target close to a
// wall cost what keeping clear of it would — a target drawn across a door funnels people to its
// middle — and both reduce to the plain distance where f = 1), computed
// by fast marching (Sethian 1996; second-order upwind differences where both upwind neighbours
// are known, first order otherwise). With clearance 0, T is the geodesic (shortest walkable path)
// length in metres; with a clearance, T weighs the stretches closer than `clearance` to a wall by
// 1/f (a travel cost in metres of open floor).
//
// Determinism: fast marching visits cells in a fixed order (ties by cell index), so a field is a
// pure function of the grid and the target; fields may be built in parallel.
#pragma once

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/types.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace ch {

class World;

/// Settings of the grid (from <Navigation>, crowdhealth/navigation/venue.h).
struct WalkableGridSettings {
    double cellSize = 0.2;   ///< m, side of a grid cell
    double clearance = 0.5;  ///< m, distance from walls below which travel is slower
    double minSpeed = 0.2;   ///< f_min, relative travel speed at a wall (0, 1]
};

/// A shape agents walk to: a point (with an arrival radius), or a polygon (a rectangle is a polygon
/// of four vertices).
struct TargetShape {
    enum class Kind { Point, Polygon } kind = Kind::Point;
    Vec2 point{0, 0};            ///< Kind::Point
    double radius = 0;           ///< Kind::Point: reached within this distance (m)
    std::vector<Vec2> polygon;   ///< Kind::Polygon: vertices in order, closed implicitly

    /// True when p is inside the shape (a point: within `radius`; a polygon: inside, even-odd).
    bool contains(const Vec2& p) const;
    /// Euclidean distance from p to the shape (0 inside).
    double distance(const Vec2& p) const;
    /// The point of the shape nearest to p (p itself inside a polygon; the centre of a point shape).
    Vec2 closest(const Vec2& p) const;
    /// A representative point: the point, or the polygon's vertex mean.
    Vec2 centre() const;
    /// Axis-aligned bounds of the shape (a point: ± radius).
    Box bounds() const;
};

/// The venue rasterised: which cells are walkable and how fast travel is in each.
class WalkableGrid {
public:
    WalkableGrid() = default;
    /// Rasterises `world` (its wall segments, obstacle polygons and, when planar, its bounds) over
    /// the rectangle [lo, hi] (m), which the caller chooses to hold everything agents may reach
    /// (a planar world's bounds; for an infinite world the bounding box of obstacles, targets and
    /// agents with a margin). The grid covers the rectangle with whole cells starting at lo.
    WalkableGrid(const World& world, const WalkableGridSettings& settings, const Vec2& lo, const Vec2& hi);

    int nx() const { return nx_; }
    int ny() const { return ny_; }
    double cellSize() const { return h_; }
    const Vec2& origin() const { return origin_; }   ///< lower-left corner of cell (0, 0)
    const WalkableGridSettings& settings() const { return settings_; }
    std::size_t cellCount() const { return static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_); }
    int index(int ix, int iy) const { return iy * nx_ + ix; }
    Vec2 centre(int ix, int iy) const { return origin_ + Vec2((ix + 0.5) * h_, (iy + 0.5) * h_); }
    /// Cell holding p (may be outside [0, nx) × [0, ny)).
    void cellOf(const Vec2& p, int& ix, int& iy) const;
    bool inGrid(int ix, int iy) const { return ix >= 0 && iy >= 0 && ix < nx_ && iy < ny_; }
    bool walkable(int ix, int iy) const { return inGrid(ix, iy) && speed_[static_cast<std::size_t>(index(ix, iy))] > 0; }
    /// True when the cell holding p is walkable.
    bool walkable(const Vec2& p) const;
    /// Relative travel speed f of a cell (0 = blocked).
    float speed(int ix, int iy) const { return speed_[static_cast<std::size_t>(index(ix, iy))]; }
    /// Distance (m) from a cell's centre to the nearest wall segment (capped at a few clearances).
    float wallDistance(int ix, int iy) const { return wallDistance_[static_cast<std::size_t>(index(ix, iy))]; }
    /// Connected-component label of each walkable cell (4-neighbours), -1 when blocked. Two places
    /// are connected by a walkable path iff their cells carry the same label.
    int component(int ix, int iy) const { return inGrid(ix, iy) ? label_[static_cast<std::size_t>(index(ix, iy))] : -1; }
    /// Component of the walkable cell nearest to p within `search` m (-1 if none).
    int componentNear(const Vec2& p, double search) const;
    /// True when the cell is walkable and its centre lies farther than DistanceField::sample's
    /// open-floor distance from every wall: one bit per cell, so the test every agent makes every
    /// step reads a small table that stays in cache instead of speed and wall distance.
    bool openFloor(int ix, int iy) const {
        const std::size_t k = static_cast<std::size_t>(index(ix, iy));
        return inGrid(ix, iy) && ((openBits_[k >> 6] >> (k & 63)) & 1u) != 0;
    }

    /// Where DistanceField::sample reads round a point p, worked out once for every field on this
    /// grid (the fields of one venue share it): p in cell units, p's cell, and the 4 × 4 block of
    /// cell centres (i0 − 1 … i0 + 2, j0 − 1 … j0 + 2) whose inner four surround p.
    struct Probe {
        double qx = 0, qy = 0;  ///< p − origin, in cells
        int cx = 0, cy = 0;     ///< p's cell
        int i0 = 0, j0 = 0;     ///< the lower-left of the four centres round p
        bool inGrid = false;    ///< the whole block lies on the grid
        bool open = false;      ///< inGrid and p's cell is openFloor(): sample's short way applies
        std::size_t first = 0;  ///< index() of the block's first cell (i0 − 1, j0 − 1) when inGrid
    };
    Probe probe(const Vec2& p) const;

    /// Eight positions probed at once (probe8), for DistanceField::sample8: each lane's Probe
    /// numbers, one array per number, and the lanes' inGrid and open flags as bit masks (bit l:
    /// lane l). `first` and the open test hold for the lanes in inGrid only.
    struct Probe8 {
        alignas(64) double qx[8], qy[8];
        std::int32_t cx[8], cy[8], i0[8], j0[8];
        std::int32_t first[8];
        unsigned inGrid = 0, open = 0;
    };
    /// probe(pos[l]) for the lanes l < count (1 … 8) of a column of positions, the others left out
    /// of both masks: in AVX-512 where the CPU runs it (navigationSamplePath), with probe()'s
    /// operations (the same numbers, bit for bit), else lane by lane.
    void probe8(const Vec2* pos, int count, Probe8& q) const;

private:
    WalkableGridSettings settings_;
    Vec2 origin_{0, 0};
    double h_ = 0.2;
    int nx_ = 0, ny_ = 0;
    std::vector<float> speed_;         ///< per cell, row-major (y outer)
    std::vector<float> wallDistance_;  ///< per cell (m)
    std::vector<int> label_;           ///< per cell
    std::vector<std::uint64_t> openBits_;  ///< openFloor(), bit k % 64 of word k / 64 for cell k
};

/// The travel-cost field T towards one target (see the top of this file).
class DistanceField {
public:
    DistanceField() = default;
    /// Fast marching from the target over `grid`. The grid must outlive the field.
    DistanceField(const WalkableGrid& grid, const TargetShape& target);

    /// T at p (m), bilinear between cell centres (blocked or unreached corners are left out of the
    /// interpolation); +inf when p cannot reach the target or lies off the grid.
    double distance(const Vec2& p) const;
    /// Unit vector along −∇T at p: the direction of the shortest path (zero inside the target or
    /// where no direction is defined). Never points into a blocked cell from a walkable one.
    Vec2 direction(const Vec2& p) const;
    /// direction(p), with distance(p) in `dist`: what an agent needs every step, in one call. On
    /// open floor (no wall within a few cells) it reads the 4 × 4 cells round p once instead of
    /// applying the rules near walls (the same values up to rounding).
    Vec2 sample(const Vec2& p, double& dist) const;
    /// sample(p, dist) with q = grid().probe(p) already worked out: a loop over agents probes each
    /// position once for its prefetch and its sample, and an agent weighing several exits probes
    /// once for all their fields. The same results as sample(p, dist), bit for bit.
    Vec2 sample(const WalkableGrid::Probe& q, const Vec2& p, double& dist) const;
    /// Asks the processor to fetch the cells sample(p) reads on open floor (no effect on results):
    /// a loop over agents calls it a few agents ahead, with q = grid().probe(p).
    void prefetch(const WalkableGrid::Probe& q) const;
    /// The same for a block whose first cell is `first` (a lane of WalkableGrid::Probe8 in inGrid).
    void prefetch(std::size_t first) const;
    /// sample() for up to eight agents at once (Navigation's loop over agents, issue 20): lane l of
    /// q (grid().probe8 of the agents' positions) is sampled on *fields[l] for the lanes in `lanes`
    /// (fields on q's grid). The lanes on open floor whose sample takes the short way (p's own cell
    /// reached, at least two cells from the target, a gradient not zero) are worked out eight at a
    /// time, in AVX-512 where the CPU runs it, with sample()'s operations in the same order, so the
    /// same bits; their direction and distance go to dir[l] and dist[l]. Returns the mask of the
    /// lanes written; sample() gives the others (the rules near walls and targets).
    static unsigned sample8(const DistanceField* const* fields, const WalkableGrid::Probe8& q, unsigned lanes,
                            Vec2* dir, double* dist);
    /// T at a cell centre (+inf: blocked or unreachable).
    float value(int ix, int iy) const { return value_[static_cast<std::size_t>(grid_->index(ix, iy))]; }
    /// True when at least one cell was seeded (the target touches walkable floor).
    bool seeded() const { return seeded_; }
    const WalkableGrid& grid() const { return *grid_; }

private:
    /// sample()'s short way at a block on open floor (`block` its first cell; the other numbers
    /// those of p's WalkableGrid::Probe): false where it does not apply (p's cell unreached,
    /// within two cells of the target, no gradient).
    static bool shortWay(const float* block, std::size_t nx, double h, double qx, double qy, int cx, int cy, int i0,
                         int j0, Vec2& dir, double& dist);
    /// Gradient of T at a reached cell centre (central differences, one-sided next to blocked or
    /// unreached cells); false when no neighbour along either axis is usable.
    bool cellGradient(int ix, int iy, Vec2& g) const;
    /// Direction from p towards the walkable neighbour (of 8) of cell (ix, iy) with the steepest
    /// descent of T (no corner cutting); zero when none descends.
    Vec2 steepestNeighbour(const Vec2& p, int ix, int iy) const;
    /// Keeps a direction from the walkable cell (ix, iy) from stepping into a blocked cell within
    /// half a cell: the blocked axis component is dropped, else the steepest neighbour is used.
    Vec2 keepOffWalls(const Vec2& p, int ix, int iy, const Vec2& dir) const;
    /// The reached walkable cell nearest to p in the rings 1..`rings` of cells round p's cell
    /// (the first ring holding one); false when none.
    bool nearestReached(const Vec2& p, int rings, int& bx, int& by) const;

    const WalkableGrid* grid_ = nullptr;
    TargetShape target_;  ///< a copy: direction() aims straight at it within a couple of cells
    std::vector<float> value_;
    bool seeded_ = false;
};

/// The build of WalkableGrid::probe8 and DistanceField::sample8 in use: 0 lane by lane, 1 AVX-512
/// (the best this CPU runs unless set; the same bits). setNavigationSamplePath returns false, and
/// changes nothing, for a build this CPU does not run (tests and crowdhealth-bench --isa).
int navigationSamplePath();
bool setNavigationSamplePath(int path);

}  // namespace ch
