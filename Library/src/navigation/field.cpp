// CrowdHealth — the walkable grid and geodesic distance fields (fast marching). See
// crowdhealth/navigation/field.h for the model.
//
// Measured accuracy (clearance 0; Tests/navigation_field_test.cpp prints these with
// --log_level=message). Largest |T − exact shortest path length| over the checked points, at cell
// size h = 0.1 / 0.2 / 0.4 m:
//   free space, point source, 10–50 m in 9 directions:  0.025 / 0.065 / 0.16 m (0.25–0.4 cell)
//   round a 4 m square pillar (paths touching corners):   0.26  / 0.54  / 1.06 m (2.6–2.7 cells)
//   L corridor 4 m wide, round the inner corner:          0.22  / 0.45  / 0.89 m (2.2 cells)
//   U-turn round the end of a thin wall (turn 147°):      0.35  / 0.70  / 1.35 m (3.4–3.5 cells)
// The free-space error comes from the first cells round the source and does not grow with the
// distance (first order alone: 0.19 / 0.34 / 0.59 m, growing with it). Round walls the error is
// about 1.3 cells per radian the path turns, at every cell size: it is geometric — at clearance 0
// the walkable cell centres nearest a wall lie 0.7–1.5 cells from it (blocked: within half a cell
// diagonal), so paths go round obstacles inflated by about a cell. Relative error ≤ 1 % + 4 cells
// in every case checked; T is never below the exact length by more than the free-space error.
//
// Cost (crowdhealth-bench --only navigation; 200 m × 200 m venue, ~100 wall segments, h = 0.2 m,
// 1M cells, one thread, this machine): grid 21 ms, 10 fields 1.93 s (0.19 s each, ~190 ns per
// cell), direction() + distance() ~0.57 µs per query. Memory: 9 bytes per cell for the grid,
// 4 per cell per field (+ 1 per cell and the heap while marching).
#include "crowdhealth/navigation/field.h"

#include "crowdhealth/core/cpu_features.h"
#include "crowdhealth/core/world.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <queue>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#endif

namespace ch {

namespace {

constexpr float kFInf = std::numeric_limits<float>::infinity();
/// A cell whose centre lies farther than this many cells from every wall has a 4 × 4 block of
/// walkable cells round any point in it (every cell of the block is within 2√2 cells of the
/// centre, so more than 3.6 − 2.83 > √2/2 cells from any wall, and a wall would have to be crossed
/// to reach an obstacle's inside): DistanceField::sample takes its short way there.
constexpr double kOpenFloorCells = 3.6;

}  // namespace

// ---------------------------------------------------------------------------------------------
// TargetShape

bool TargetShape::contains(const Vec2& p) const {
    if (kind == Kind::Point) return (p - point).norm() <= radius;
    return polygon.size() >= 3 && pointInPolygon(p, polygon);
}

double TargetShape::distance(const Vec2& p) const {
    if (kind == Kind::Point) return std::max(0.0, (p - point).norm() - radius);
    if (polygon.empty()) return kInf;
    if (polygon.size() == 1) return (p - polygon[0]).norm();
    if (contains(p)) return 0.0;
    double best = kInf;
    const std::size_t n = polygon.size();
    for (std::size_t k = 0; k < n; ++k)
        best = std::min(best, distanceToSegmentSquared(p, polygon[k], polygon[(k + 1) % n]));
    return std::sqrt(best);
}

Vec2 TargetShape::closest(const Vec2& p) const {
    if (kind == Kind::Point) return point;
    if (polygon.empty()) return p;
    if (polygon.size() == 1) return polygon[0];
    if (contains(p)) return p;
    double best = kInf;
    Vec2 q = polygon[0];
    const std::size_t n = polygon.size();
    for (std::size_t k = 0; k < n; ++k) {
        const Vec2 c = closestPointOnSegment(p, polygon[k], polygon[(k + 1) % n]);
        const double d = (c - p).squaredNorm();
        if (d < best) {
            best = d;
            q = c;
        }
    }
    return q;
}

Vec2 TargetShape::centre() const {
    if (kind == Kind::Point || polygon.empty()) return point;
    Vec2 c(0, 0);
    for (const Vec2& v : polygon) c += v;
    return c / static_cast<double>(polygon.size());
}

Box TargetShape::bounds() const {
    if (kind == Kind::Point || polygon.empty()) return Box(point - Vec2(radius, radius), point + Vec2(radius, radius));
    return Box::around(polygon);
}

// ---------------------------------------------------------------------------------------------
// WalkableGrid

WalkableGrid::WalkableGrid(const World& world, const WalkableGridSettings& settings, const Vec2& lo,
                           const Vec2& hi)
    : settings_(settings), origin_(lo), h_(settings.cellSize) {
    if (!(h_ > 0)) h_ = 0.2;
    nx_ = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / h_ - 1e-9)));
    ny_ = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / h_ - 1e-9)));
    const std::size_t n = cellCount();
    const double clearance = std::max(0.0, settings_.clearance);
    const double fmin = std::clamp(settings_.minSpeed, 1e-3, 1.0);
    const double blockRadius = h_ * std::sqrt(0.5);  // half a cell diagonal
    // Wall distances are only needed up to the clearance (for f) and the blocking radius: capped.
    // At least kOpenFloorCells + 1 cells: DistanceField::sample's open-floor test reads it.
    const double cap = std::max(2.0 * clearance + 2.0 * h_, (kOpenFloorCells + 1.0) * h_);
    wallDistance_.assign(n, static_cast<float>(cap));

    // Each segment visits only the cells within `cap` of it: per row of cells, the x-range of the
    // part of the segment within `cap` in y, widened by `cap`.
    for (const Segment& s : world.segments()) {
        const Vec2 a = s.a, b = s.b;
        const double y0 = std::min(a.y(), b.y()) - cap, y1 = std::max(a.y(), b.y()) + cap;
        const int jy0 = std::max(0, static_cast<int>(std::floor((y0 - origin_.y()) / h_ - 0.5)));
        const int jy1 = std::min(ny_ - 1, static_cast<int>(std::ceil((y1 - origin_.y()) / h_ - 0.5)));
        const double dy = b.y() - a.y();
        for (int iy = jy0; iy <= jy1; ++iy) {
            const double yc = origin_.y() + (iy + 0.5) * h_;
            double t0 = 0, t1 = 1;
            if (std::abs(dy) > 1e-12) {
                double ta = (yc - cap - a.y()) / dy, tb = (yc + cap - a.y()) / dy;
                if (ta > tb) std::swap(ta, tb);
                t0 = std::max(t0, ta);
                t1 = std::min(t1, tb);
                if (t0 > t1) continue;
            } else if (std::abs(yc - a.y()) > cap) {
                continue;
            }
            const double xa = a.x() + t0 * (b.x() - a.x()), xb = a.x() + t1 * (b.x() - a.x());
            const double xlo = std::min(xa, xb) - cap, xhi = std::max(xa, xb) + cap;
            const int ix0 = std::max(0, static_cast<int>(std::floor((xlo - origin_.x()) / h_ - 0.5)));
            const int ix1 = std::min(nx_ - 1, static_cast<int>(std::ceil((xhi - origin_.x()) / h_ - 0.5)));
            for (int ix = ix0; ix <= ix1; ++ix) {
                const double d = std::sqrt(distanceToSegmentSquared(centre(ix, iy), a, b));
                float& w = wallDistance_[static_cast<std::size_t>(index(ix, iy))];
                if (d < w) w = static_cast<float>(d);
            }
        }
    }

    // Inside obstacle polygons: a scanline per row (even-odd crossings, as pointInPolygon).
    std::vector<unsigned char> inside(n, 0);
    std::vector<double> xs;
    for (const ObstacleSpec& o : world.obstacles()) {
        const auto& pts = o.points;
        if (pts.size() < 3) continue;
        double ylo = pts[0].y(), yhi = pts[0].y();
        for (const Vec2& v : pts) {
            ylo = std::min(ylo, v.y());
            yhi = std::max(yhi, v.y());
        }
        const int jy0 = std::max(0, static_cast<int>(std::floor((ylo - origin_.y()) / h_ - 0.5)));
        const int jy1 = std::min(ny_ - 1, static_cast<int>(std::ceil((yhi - origin_.y()) / h_ - 0.5)));
        for (int iy = jy0; iy <= jy1; ++iy) {
            const double yc = origin_.y() + (iy + 0.5) * h_;
            xs.clear();
            for (std::size_t k = 0, m = pts.size(); k < m; ++k) {
                const Vec2& p = pts[k];
                const Vec2& q = pts[(k + 1) % m];
                if ((p.y() > yc) != (q.y() > yc)) xs.push_back(p.x() + (yc - p.y()) * (q.x() - p.x()) / (q.y() - p.y()));
            }
            std::sort(xs.begin(), xs.end());
            for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
                // Cells whose centre x lies in (xs[k], xs[k+1]).
                const int ix0 = std::max(0, static_cast<int>(std::floor((xs[k] - origin_.x()) / h_ - 0.5)) + 1);
                const int ix1 = std::min(nx_ - 1, static_cast<int>(std::ceil((xs[k + 1] - origin_.x()) / h_ - 0.5)) - 1);
                for (int ix = ix0; ix <= ix1; ++ix) inside[static_cast<std::size_t>(index(ix, iy))] = 1;
            }
        }
    }

    const bool planar = world.type() == WorldType::Planar;
    const WorldSpec& ws = world.spec();
    speed_.assign(n, 0.0f);
    for (int iy = 0; iy < ny_; ++iy)
        for (int ix = 0; ix < nx_; ++ix) {
            const std::size_t k = static_cast<std::size_t>(index(ix, iy));
            const double d = wallDistance_[k];
            if (inside[k] || d < blockRadius) continue;
            if (planar) {
                const Vec2 c = centre(ix, iy);
                if (c.x() < ws.xmin || c.x() > ws.xmax || c.y() < ws.ymin || c.y() > ws.ymax) continue;
            }
            const double f = clearance > 0 ? fmin + (1.0 - fmin) * std::min(1.0, d / clearance) : 1.0;
            speed_[k] = static_cast<float>(f);
        }

    // Connected components (4-neighbours) by flood fill, labelled in cell order.
    label_.assign(n, -1);
    std::vector<int> stack;
    int next = 0;
    for (std::size_t k0 = 0; k0 < n; ++k0) {
        if (speed_[k0] <= 0 || label_[k0] >= 0) continue;
        label_[k0] = next;
        stack.push_back(static_cast<int>(k0));
        while (!stack.empty()) {
            const int k = stack.back();
            stack.pop_back();
            const int ix = k % nx_, iy = k / nx_;
            const int nb[4][2] = {{ix - 1, iy}, {ix + 1, iy}, {ix, iy - 1}, {ix, iy + 1}};
            for (const auto& c : nb) {
                if (!walkable(c[0], c[1])) continue;
                int& l = label_[static_cast<std::size_t>(index(c[0], c[1]))];
                if (l >= 0) continue;
                l = next;
                stack.push_back(index(c[0], c[1]));
            }
        }
        ++next;
    }

    // Open floor (DistanceField::sample's short way), the same test it made on speed and wall distance.
    openBits_.assign((n + 63) / 64, 0);
    for (std::size_t k = 0; k < n; ++k)
        if (speed_[k] > 0 && wallDistance_[k] > kOpenFloorCells * h_) openBits_[k >> 6] |= std::uint64_t{1} << (k & 63);
}

void WalkableGrid::cellOf(const Vec2& p, int& ix, int& iy) const {
    ix = floorToInt((p.x() - origin_.x()) / h_);
    iy = floorToInt((p.y() - origin_.y()) / h_);
}

bool WalkableGrid::walkable(const Vec2& p) const {
    int ix, iy;
    cellOf(p, ix, iy);
    return walkable(ix, iy);
}

int WalkableGrid::componentNear(const Vec2& p, double search) const {
    int cx, cy;
    cellOf(p, cx, cy);
    if (walkable(cx, cy)) return component(cx, cy);
    const int r = static_cast<int>(std::ceil(search / h_)) + 1;
    double best = search * search;
    int label = -1;
    for (int iy = cy - r; iy <= cy + r; ++iy)
        for (int ix = cx - r; ix <= cx + r; ++ix) {
            if (!walkable(ix, iy)) continue;
            const double d = (centre(ix, iy) - p).squaredNorm();
            if (d <= best && (label < 0 || d < best)) {
                best = d;
                label = component(ix, iy);
            }
        }
    return label;
}

// ---------------------------------------------------------------------------------------------
// DistanceField: fast marching

namespace {

struct HeapEntry {
    float t;
    int cell;
};
// std::priority_queue keeps the largest on top: "larger" = later (greater T, then greater index),
// so the smallest T, ties by the smallest cell index, comes out first.
struct Later {
    bool operator()(const HeapEntry& a, const HeapEntry& b) const {
        return a.t > b.t || (a.t == b.t && a.cell > b.cell);
    }
};

}  // namespace

DistanceField::DistanceField(const WalkableGrid& grid, const TargetShape& target) : grid_(&grid), target_(target) {
    const int nx = grid.nx(), ny = grid.ny();
    const double h = grid.cellSize();
    value_.assign(grid.cellCount(), kFInf);
    // Seeds keep their exact value (the march never lowers them) but are accepted in order of T.
    enum : unsigned char { Far = 0, Trial = 1, Known = 2, Seed = 3 };
    std::vector<unsigned char> state(grid.cellCount(), Far);
    std::priority_queue<HeapEntry, std::vector<HeapEntry>, Later> heap;

    // Seeds: walkable cells whose centre is inside the target or within 1.5 cells of it.
    const double seedRadius = 1.5 * h;
    const auto [blo, bhi] = target.bounds();
    int ix0, iy0, ix1, iy1;
    grid.cellOf(blo - Vec2(seedRadius, seedRadius), ix0, iy0);
    grid.cellOf(bhi + Vec2(seedRadius, seedRadius), ix1, iy1);
    ix0 = std::max(ix0, 0);
    iy0 = std::max(iy0, 0);
    ix1 = std::min(ix1, nx - 1);
    iy1 = std::min(iy1, ny - 1);
    // With a clearance, where a body fits matters: cells closer than kBodyRoom to a wall (a target
    // drawn over the wall beside a door) are left out while others remain, and when the target
    // itself holds roomy cells only those are seeds (no halo round it). Otherwise the field leads
    // people to the part of the target over the wall, where the wall holds them off it for good.
    constexpr double kBodyRoom = 0.3;  // m, a body radius and a margin
    std::vector<int> candidates;
    bool roomy = false, roomyInside = false;
    for (int iy = iy0; iy <= iy1; ++iy)
        for (int ix = ix0; ix <= ix1; ++ix) {
            if (!grid.walkable(ix, iy)) continue;
            const double d = target.distance(grid.centre(ix, iy));
            if (!(d <= seedRadius)) continue;
            candidates.push_back(grid.index(ix, iy));
            const bool room = grid.wallDistance(ix, iy) >= kBodyRoom;
            roomy = roomy || room;
            roomyInside = roomyInside || (room && d == 0);
        }
    const bool clear = grid.settings().clearance > 0;
    const bool onlyRoomy = clear && roomy, onlyInside = clear && roomyInside;
    for (const int k : candidates) {
        const int ix = k % nx, iy = k / nx;
        if (onlyRoomy && grid.wallDistance(ix, iy) < kBodyRoom) continue;
        const double d = target.distance(grid.centre(ix, iy));
        if (onlyInside && d > 0) continue;
        // d/f, plus clearance·(1/f − 1): reaching the target close to a wall costs what keeping
        // clear of it would (0 where f = 1), so a target drawn across a door funnels people to
        // the door's middle instead of its posts.
        const double f = grid.speed(ix, iy);
        value_[static_cast<std::size_t>(k)] = static_cast<float>(d / f + grid.settings().clearance * (1.0 / f - 1.0));
        state[static_cast<std::size_t>(k)] = Seed;
        heap.push({value_[static_cast<std::size_t>(k)], k});
        seeded_ = true;
    }

    auto known = [&](int ix, int iy) {
        return ix >= 0 && iy >= 0 && ix < nx && iy < ny && state[static_cast<std::size_t>(grid.index(ix, iy))] == Known;
    };
    auto val = [&](int ix, int iy) { return static_cast<double>(value_[static_cast<std::size_t>(grid.index(ix, iy))]); };

    // One axis of the upwind stencil at (ix, iy): c·(T − v)² with c = 1 (first order) or 9/4 with
    // v = (4·T1 − T2)/3 (second order, when the next cell beyond the known neighbour is known and
    // smaller: T2 = T1 happens across a source or a ridge, where the one-sided stencil is wrong).
    // Returns false when no neighbour along the axis is known.
    auto axisTerm = [&](int ix, int iy, int dx, int dy, double& c, double& v) {
        double t1 = kInf;
        int side = 0;
        if (known(ix - dx, iy - dy)) {
            t1 = val(ix - dx, iy - dy);
            side = -1;
        }
        if (known(ix + dx, iy + dy) && val(ix + dx, iy + dy) < t1) {
            t1 = val(ix + dx, iy + dy);
            side = 1;
        }
        if (side == 0) return false;
        const int jx = ix + 2 * side * dx, jy = iy + 2 * side * dy;
        if (known(jx, jy) && val(jx, jy) < t1) {
            c = 2.25;
            v = (4.0 * t1 - val(jx, jy)) / 3.0;
        } else {
            c = 1.0;
            v = t1;
        }
        return true;
    };

    auto update = [&](int ix, int iy) {
        const double rhs = h / grid.speed(ix, iy);  // h / f
        double cx = 0, vx = 0, cy = 0, vy = 0;
        const bool hx = axisTerm(ix, iy, 1, 0, cx, vx);
        const bool hy = axisTerm(ix, iy, 0, 1, cy, vy);
        double t = kInf;
        if (hx) t = std::min(t, vx + rhs / std::sqrt(cx));
        if (hy) t = std::min(t, vy + rhs / std::sqrt(cy));
        if (hx && hy) {
            // cx (t − vx)² + cy (t − vy)² = rhs²; valid when the root is ≥ both upwind values.
            const double A = cx + cy;
            const double B = -2.0 * (cx * vx + cy * vy);
            const double C = cx * vx * vx + cy * vy * vy - rhs * rhs;
            const double disc = B * B - 4.0 * A * C;
            if (disc >= 0) {
                const double r = (-B + std::sqrt(disc)) / (2.0 * A);
                if (r >= vx && r >= vy) t = std::min(t, r);
            }
        }
        return t;
    };

    while (!heap.empty()) {
        const HeapEntry e = heap.top();
        heap.pop();
        const std::size_t k = static_cast<std::size_t>(e.cell);
        if (state[k] == Known || e.t != value_[k]) continue;  // stale entry
        state[k] = Known;
        const int ix = e.cell % nx, iy = e.cell / nx;
        const int nb[4][2] = {{ix - 1, iy}, {ix + 1, iy}, {ix, iy - 1}, {ix, iy + 1}};
        for (const auto& c : nb) {
            if (!grid.walkable(c[0], c[1])) continue;
            const std::size_t m = static_cast<std::size_t>(grid.index(c[0], c[1]));
            if (state[m] == Known || state[m] == Seed) continue;
            const float t = static_cast<float>(update(c[0], c[1]));
            if (t < value_[m]) {
                value_[m] = t;
                state[m] = Trial;
                heap.push({t, static_cast<int>(m)});
            }
        }
    }
}

double DistanceField::distance(const Vec2& p) const {
    if (grid_ == nullptr) return kInf;
    const WalkableGrid& g = *grid_;
    int cx, cy;
    g.cellOf(p, cx, cy);
    if (!g.inGrid(cx, cy)) return kInf;
    const bool own = g.walkable(cx, cy);
    if (own && !std::isfinite(value(cx, cy))) return kInf;  // p's own floor cannot reach the target
    const int label = own ? g.component(cx, cy) : -1;
    const double h = g.cellSize();
    const double fx = (p.x() - g.origin().x()) / h - 0.5, fy = (p.y() - g.origin().y()) / h - 0.5;
    const int i0 = static_cast<int>(std::floor(fx)), j0 = static_cast<int>(std::floor(fy));
    const double tx = fx - i0, ty = fy - j0;
    double sum = 0, wsum = 0, nearest = kInf, nearestD = kInf;
    for (int dj = 0; dj <= 1; ++dj)
        for (int di = 0; di <= 1; ++di) {
            const int ix = i0 + di, iy = j0 + dj;
            if (!g.walkable(ix, iy) || !std::isfinite(value(ix, iy))) continue;
            if (own && g.component(ix, iy) != label) continue;
            const double w = (di ? tx : 1 - tx) * (dj ? ty : 1 - ty);
            sum += w * value(ix, iy);
            wsum += w;
            const double d = (g.centre(ix, iy) - p).squaredNorm();
            if (d < nearestD) {
                nearestD = d;
                nearest = value(ix, iy);
            }
        }
    if (wsum > 1e-9) return sum / wsum;
    if (std::isfinite(nearest) || own) return nearest;
    // p in a blocked cell with no usable corner (pressed into a wall): the nearest reached cell
    // within 4 cells plus the straight way to it.
    int bx, by;
    if (!nearestReached(p, 4, bx, by)) return kInf;
    return value(bx, by) + (g.centre(bx, by) - p).norm();
}

bool DistanceField::nearestReached(const Vec2& p, int rings, int& bx, int& by) const {
    const WalkableGrid& g = *grid_;
    int cx, cy;
    g.cellOf(p, cx, cy);
    double best = kInf;
    bx = by = -1;
    for (int r = 1; r <= rings && bx < 0; ++r)
        for (int iy = cy - r; iy <= cy + r; ++iy)
            for (int ix = cx - r; ix <= cx + r; ++ix) {
                if (std::max(std::abs(ix - cx), std::abs(iy - cy)) != r) continue;  // ring r only
                if (!g.walkable(ix, iy) || !std::isfinite(value(ix, iy))) continue;
                const double d = (g.centre(ix, iy) - p).squaredNorm();
                if (d < best) {
                    best = d;
                    bx = ix;
                    by = iy;
                }
            }
    return bx >= 0;
}

bool DistanceField::cellGradient(int ix, int iy, Vec2& g) const {
    const WalkableGrid& grid = *grid_;
    const double h = grid.cellSize();
    const double t = value(ix, iy);
    auto usable = [&](int jx, int jy) { return grid.walkable(jx, jy) && std::isfinite(value(jx, jy)); };
    bool any = false;
    double comp[2] = {0, 0};
    for (int axis = 0; axis < 2; ++axis) {
        const int dx = axis == 0 ? 1 : 0, dy = 1 - dx;
        const bool lo = usable(ix - dx, iy - dy), hi = usable(ix + dx, iy + dy);
        if (lo && hi) comp[axis] = (value(ix + dx, iy + dy) - value(ix - dx, iy - dy)) / (2 * h);
        else if (hi) comp[axis] = (value(ix + dx, iy + dy) - t) / h;
        else if (lo) comp[axis] = (t - value(ix - dx, iy - dy)) / h;
        any = any || lo || hi;
    }
    g = Vec2(comp[0], comp[1]);
    return any;
}

Vec2 DistanceField::steepestNeighbour(const Vec2& p, int ix, int iy) const {
    const WalkableGrid& grid = *grid_;
    const double t0 = value(ix, iy);
    double best = 0;
    Vec2 dir(0, 0);
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0) continue;
            const int jx = ix + dx, jy = iy + dy;
            if (!grid.walkable(jx, jy) || !std::isfinite(value(jx, jy))) continue;
            // No corner cutting: a diagonal move needs both cells beside it walkable.
            if (dx != 0 && dy != 0 && (!grid.walkable(ix + dx, iy) || !grid.walkable(ix, iy + dy))) continue;
            const double slope = (value(jx, jy) - t0) / std::sqrt(static_cast<double>(dx * dx + dy * dy));
            if (slope < best) {
                best = slope;
                // Towards the neighbour's centre (which also pulls p back to the middle of its cell);
                // the plain offset when p already sits at that centre.
                const Vec2 to = grid.centre(jx, jy) - p;
                dir = to.norm() > 1e-9 ? Vec2(to.normalized()) : Vec2(Vec2(dx, dy).normalized());
            }
        }
    return dir;
}

Vec2 DistanceField::keepOffWalls(const Vec2& p, int ix, int iy, const Vec2& dir) const {
    const WalkableGrid& grid = *grid_;
    const double h = grid.cellSize();
    auto enters = [&](const Vec2& d, int& bx, int& by) {
        // The cells a half-cell step along d passes into: the cell of the end point and, when it is
        // diagonal to (ix, iy), the two cells beside the corner.
        int qx, qy;
        grid.cellOf(p + 0.5 * h * d, qx, qy);
        bx = qx - ix;
        by = qy - iy;
        if (!grid.walkable(qx, qy)) return true;
        if (bx != 0 && by != 0 && (!grid.walkable(qx, iy) || !grid.walkable(ix, qy))) return true;
        return false;
    };
    int bx = 0, by = 0;
    if (!enters(dir, bx, by)) return dir;
    // Project onto the walkable side: drop the component that steps into the blocked neighbour.
    Vec2 d = dir;
    if (bx != 0 && !grid.walkable(ix + bx, iy)) d.x() = 0;
    if (by != 0 && !grid.walkable(ix, iy + by)) d.y() = 0;
    if (d == dir && bx != 0 && by != 0) {
        // Only the diagonal cell is blocked: keep the larger component.
        if (std::abs(d.x()) >= std::abs(d.y())) d.y() = 0;
        else d.x() = 0;
    }
    const double n = d.norm();
    if (n > 0.2) {  // the projection keeps a real part of the descent
        d /= n;
        int cx, cy;
        if (!enters(d, cx, cy)) return d;
    }
    return steepestNeighbour(p, ix, iy);
}

WalkableGrid::Probe WalkableGrid::probe(const Vec2& p) const {
    Probe q;
    // The same divisions serve cellOf's floor (p's own cell) and the interpolation, half a cell lower.
    q.qx = (p.x() - origin_.x()) / h_;
    q.qy = (p.y() - origin_.y()) / h_;
    q.cx = floorToInt(q.qx);
    q.cy = floorToInt(q.qy);
    q.i0 = floorToInt(q.qx - 0.5);
    q.j0 = floorToInt(q.qy - 0.5);
    q.inGrid = q.i0 >= 1 && q.j0 >= 1 && q.i0 + 2 < nx_ && q.j0 + 2 < ny_;
    if (q.inGrid) {
        q.first = static_cast<std::size_t>(index(q.i0 - 1, q.j0 - 1));
        q.open = openFloor(q.cx, q.cy);
    }
    return q;
}

Vec2 DistanceField::sample(const Vec2& p, double& dist) const {
    if (grid_ != nullptr && seeded_) return sample(grid_->probe(p), p, dist);
    dist = distance(p);
    return direction(p);
}

bool DistanceField::shortWay(const float* block, std::size_t nx, double h, double qx, double qy, int cx, int cy,
                             int i0, int j0, Vec2& dir, double& dist) {
    // Open floor: the 4 × 4 block round p is walkable and in p's region (so reached when p's cell
    // is), and the general rules reduce to bilinear T and bilinearly blended central differences.
    double t[4][4];  // t[row][column] for cells (i0 − 1 … i0 + 2, j0 − 1 … j0 + 2)
    const float* row = block;
    for (int r = 0; r < 4; ++r, row += nx)
        for (int c = 0; c < 4; ++c) t[r][c] = row[c];
    // p's own cell is (i0 or i0 + 1, j0 or j0 + 1): unreached means no path from here.
    if (!std::isfinite(t[cy - j0 + 1][cx - i0 + 1])) return false;
    const double tx = (qx - 0.5) - i0, ty = (qy - 0.5) - j0;
    const double w00 = (1 - tx) * (1 - ty), w10 = tx * (1 - ty), w01 = (1 - tx) * ty, w11 = tx * ty;
    dist = w00 * t[1][1] + w10 * t[1][2] + w01 * t[2][1] + w11 * t[2][2];
    if (!(dist >= 2.0 * h)) return false;
    auto gx = [&](int r, int c) { return t[r][c + 1] - t[r][c - 1]; };
    auto gy = [&](int r, int c) { return t[r + 1][c] - t[r - 1][c]; };
    const Vec2 grad(w00 * gx(1, 1) + w10 * gx(1, 2) + w01 * gx(2, 1) + w11 * gx(2, 2),
                    w00 * gy(1, 1) + w10 * gy(1, 2) + w01 * gy(2, 1) + w11 * gy(2, 2));
    dir = normalisedOrZero(-grad);
    return !dir.isZero();
}

Vec2 DistanceField::sample(const WalkableGrid::Probe& q, const Vec2& p, double& dist) const {
    // A block leaving the grid, or near a wall, takes the general way.
    if (grid_ != nullptr && seeded_ && q.open) {
        Vec2 dir;
        if (shortWay(&value_[q.first], static_cast<std::size_t>(grid_->nx()), grid_->cellSize(), q.qx, q.qy, q.cx, q.cy,
                     q.i0, q.j0, dir, dist))
            return dir;
    }
    dist = distance(p);
    return direction(p);
}

void DistanceField::prefetch(const WalkableGrid::Probe& q) const {
    if (q.inGrid) prefetch(q.first);
}

void DistanceField::prefetch(std::size_t first) const {
    if (grid_ == nullptr || !seeded_) return;
    const std::size_t nx = static_cast<std::size_t>(grid_->nx());
    const float* row = &value_[first];
    for (int r = 0; r < 4; ++r, row += nx) {
        __builtin_prefetch(row);
        __builtin_prefetch(row + 3);  // the row's last cell, when the four straddle two cache lines
    }
}

Vec2 DistanceField::direction(const Vec2& p) const {
    if (grid_ == nullptr || !seeded_) return Vec2(0, 0);
    const WalkableGrid& g = *grid_;
    if (target_.contains(p)) return Vec2(0, 0);
    int cx, cy;
    g.cellOf(p, cx, cy);
    if (!g.inGrid(cx, cy)) return Vec2(0, 0);
    const double h = g.cellSize();
    if (!g.walkable(cx, cy)) {
        // Pressed into a wall: the direction of the nearest reached walkable cell (within 4 cells).
        int bx, by;
        if (!nearestReached(p, 4, bx, by)) return Vec2(0, 0);
        return direction(g.centre(bx, by));
    }
    if (!std::isfinite(value(cx, cy))) return Vec2(0, 0);
    const int label = g.component(cx, cy);

    Vec2 dir(0, 0);
    if (distance(p) < 2.0 * h) {
        dir = normalisedOrZero(target_.closest(p) - p);
    } else {
        // −∇T blended bilinearly from the gradients at the four surrounding cell centres.
        const double fx = (p.x() - g.origin().x()) / h - 0.5, fy = (p.y() - g.origin().y()) / h - 0.5;
        const int i0 = static_cast<int>(std::floor(fx)), j0 = static_cast<int>(std::floor(fy));
        const double tx = fx - i0, ty = fy - j0;
        Vec2 grad(0, 0);
        double wsum = 0;
        for (int dj = 0; dj <= 1; ++dj)
            for (int di = 0; di <= 1; ++di) {
                const int ix = i0 + di, iy = j0 + dj;
                if (!g.walkable(ix, iy) || !std::isfinite(value(ix, iy)) || g.component(ix, iy) != label) continue;
                Vec2 gc;
                if (!cellGradient(ix, iy, gc)) continue;
                const double w = (di ? tx : 1 - tx) * (dj ? ty : 1 - ty) + 1e-9;
                grad += w * gc;
                wsum += w;
            }
        dir = wsum > 0 ? normalisedOrZero(-grad) : Vec2(0, 0);
    }
    if (dir.isZero()) return steepestNeighbour(p, cx, cy);
    return keepOffWalls(p, cx, cy, dir);
}

// ---- Eight agents at once (issue 20) ----------------------------------------------------------
//
// WalkableGrid::probe8 and DistanceField::sample8: probe() and sample()'s short way for eight
// positions in the lanes of AVX-512 registers, with the scalar code's operations one by one in
// the same order and no fused multiply-add (fp-contract=off), so every lane has the scalar code's
// bits (Tests/navigation_field_test.cpp compares them everywhere on grids with walls, targets and
// edges). The lanes whose short way does not apply are left to sample(): near walls, targets and
// the grid's edges, a few per cent of a crowd on open floor.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_NAV_X86 1
#define CH_NAV_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl"), optimize("fp-contract=off")))
#endif

namespace {

std::atomic<int> gSamplePath{cpu::hasAvx512() ? 1 : 0};

#ifdef CH_NAV_X86
// GCC 12's <avx512fintrin.h> starts many intrinsics from _mm512_undefined_*(), a variable
// initialised with itself, which its -Wuninitialized then reports as used uninitialised once the
// intrinsic is inlined here (a false positive: the lanes are all written). Silenced for these two
// functions only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
/// probe() in eight lanes (lanes ≥ count left out). Positions whose cell numbers would not fit an
/// int (|q| ≥ 2^30 cells) lie far off any grid: left out of inGrid, as probe() leaves them.
CH_NAV_AVX512 void probe8Avx512(const Vec2* pos, int count, const Vec2& origin, double h, int nx, int ny,
                                const std::uint64_t* openBits, WalkableGrid::Probe8& q) {
    const __mmask8 live = static_cast<__mmask8>((1u << count) - 1u);
    // The positions' words: x of lane l is word 2l of the column, y word 2l + 1.
    const double* w = pos[0].data();
    const int lowWords = std::min(count, 4) * 2, highWords = std::max(count - 4, 0) * 2;
    const __m512d a = _mm512_maskz_loadu_pd(static_cast<__mmask8>((1u << lowWords) - 1u), w);
    const __m512d b = highWords > 0 ? _mm512_maskz_loadu_pd(static_cast<__mmask8>((1u << highWords) - 1u), w + 8)
                                    : _mm512_setzero_pd();
    const __m512d x = _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), b);
    const __m512d y = _mm512_permutex2var_pd(a, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), b);
    const __m512d hv = _mm512_set1_pd(h);
    const __m512d qx = _mm512_div_pd(_mm512_sub_pd(x, _mm512_set1_pd(origin.x())), hv);
    const __m512d qy = _mm512_div_pd(_mm512_sub_pd(y, _mm512_set1_pd(origin.y())), hv);
    const __m512d limit = _mm512_set1_pd(1073741824.0), half = _mm512_set1_pd(0.5);
    const __mmask8 fits = _mm512_mask_cmp_pd_mask(live, _mm512_abs_pd(qx), limit, _CMP_LT_OQ) &
                          _mm512_cmp_pd_mask(_mm512_abs_pd(qy), limit, _CMP_LT_OQ);
    // ⌊v⌋ as an int (floorToInt), for the lanes that fit; 0 in the others.
    auto floorInt = [&](__m512d v) {
        return _mm512_maskz_cvttpd_epi32(fits, _mm512_roundscale_pd(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
    };
    const __m256i cx = floorInt(qx), cy = floorInt(qy);
    const __m256i i0 = floorInt(_mm512_sub_pd(qx, half)), j0 = floorInt(_mm512_sub_pd(qy, half));
    const __m256i one = _mm256_set1_epi32(1), two = _mm256_set1_epi32(2);
    const __mmask8 inGrid = fits & _mm256_cmp_epi32_mask(i0, one, _MM_CMPINT_NLT) &
                            _mm256_cmp_epi32_mask(j0, one, _MM_CMPINT_NLT) &
                            _mm256_cmp_epi32_mask(_mm256_add_epi32(i0, two), _mm256_set1_epi32(nx), _MM_CMPINT_LT) &
                            _mm256_cmp_epi32_mask(_mm256_add_epi32(j0, two), _mm256_set1_epi32(ny), _MM_CMPINT_LT);
    const __m256i nxv = _mm256_set1_epi32(nx);
    const __m256i first = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(j0, one), nxv), _mm256_sub_epi32(i0, one));
    // openFloor(cx, cy): bit k % 64 of word k / 64, k = cy·nx + cx (in the grid where inGrid).
    const __m256i k = _mm256_add_epi32(_mm256_mullo_epi32(cy, nxv), cx);
    const __m512i words =
        _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), inGrid, _mm256_srli_epi32(k, 6), openBits, 8);
    const __m512i bits = _mm512_srlv_epi64(words, _mm512_cvtepi32_epi64(_mm256_and_si256(k, _mm256_set1_epi32(63))));
    const __mmask8 open = _mm512_mask_test_epi64_mask(inGrid, bits, _mm512_set1_epi64(1));
    _mm512_store_pd(q.qx, qx);
    _mm512_store_pd(q.qy, qy);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(q.cx), cx);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(q.cy), cy);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(q.i0), i0);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(q.j0), j0);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(q.first), first);
    q.inGrid = inGrid;
    q.open = open;
}

/// shortWay() in eight lanes: block[l] is the address of lane l's block's first cell (null in
/// the lanes not in `lanes`), `nx` the grid's row length.
CH_NAV_AVX512 unsigned shortWay8(const float* const* blocks, unsigned lanesIn, std::size_t nx, double h,
                                 const WalkableGrid::Probe8& q, Vec2* dir, double* dist) {
    static_assert(sizeof(const float*) == sizeof(long long));
    const __mmask8 lanes = static_cast<__mmask8>(lanesIn);
    const __m512i block = _mm512_loadu_si512(blocks);
    // T at (row r, column c) of the blocks, as doubles (0 in the lanes not sampled).
    auto t = [&](int r, int c) {
        const __m512i at = _mm512_add_epi64(block, _mm512_set1_epi64(static_cast<long long>((r * nx + c) * sizeof(float))));
        return _mm512_cvtps_pd(_mm512_mask_i64gather_ps(_mm256_setzero_ps(), lanes, at, nullptr, 1));
    };
    const __m512d t01 = t(0, 1), t02 = t(0, 2);
    const __m512d t10 = t(1, 0), t11 = t(1, 1), t12 = t(1, 2), t13 = t(1, 3);
    const __m512d t20 = t(2, 0), t21 = t(2, 1), t22 = t(2, 2), t23 = t(2, 3);
    const __m512d t31 = t(3, 1), t32 = t(3, 2);
    const __m256i i0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q.i0));
    const __m256i j0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q.j0));
    const __m256i cx = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q.cx));
    const __m256i cy = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q.cy));
    // p's own cell: (i0 or i0 + 1, j0 or j0 + 1), that is t11, t12, t21 or t22.
    const __mmask8 right = _mm256_cmp_epi32_mask(cx, i0, _MM_CMPINT_NE);
    const __mmask8 up = _mm256_cmp_epi32_mask(cy, j0, _MM_CMPINT_NE);
    const __m512d own = _mm512_mask_blend_pd(up, _mm512_mask_blend_pd(right, t11, t12), _mm512_mask_blend_pd(right, t21, t22));
    const __m512d inf = _mm512_set1_pd(std::numeric_limits<double>::infinity());
    __mmask8 ok = _mm512_mask_cmp_pd_mask(lanes, _mm512_abs_pd(own), inf, _CMP_LT_OQ);
    const __m512d one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5);
    const __m512d tx = _mm512_sub_pd(_mm512_sub_pd(_mm512_load_pd(q.qx), half), _mm512_cvtepi32_pd(i0));
    const __m512d ty = _mm512_sub_pd(_mm512_sub_pd(_mm512_load_pd(q.qy), half), _mm512_cvtepi32_pd(j0));
    const __m512d ux = _mm512_sub_pd(one, tx), uy = _mm512_sub_pd(one, ty);
    const __m512d w00 = _mm512_mul_pd(ux, uy), w10 = _mm512_mul_pd(tx, uy), w01 = _mm512_mul_pd(ux, ty),
                  w11 = _mm512_mul_pd(tx, ty);
    // w00·a + w10·b + w01·c + w11·d, added left to right as the scalar expression is.
    auto blend = [&](__m512d a, __m512d b, __m512d c, __m512d d) {
        __m512d s = _mm512_add_pd(_mm512_mul_pd(w00, a), _mm512_mul_pd(w10, b));
        s = _mm512_add_pd(s, _mm512_mul_pd(w01, c));
        return _mm512_add_pd(s, _mm512_mul_pd(w11, d));
    };
    const __m512d d = blend(t11, t12, t21, t22);
    ok = _mm512_mask_cmp_pd_mask(ok, d, _mm512_set1_pd(2.0 * h), _CMP_GE_OQ);
    ok = _mm512_mask_cmp_pd_mask(ok, _mm512_abs_pd(d), inf, _CMP_LT_OQ);
    if (ok == 0) return 0;
    const __m512d sign = _mm512_set1_pd(-0.0);
    const __m512d gx = _mm512_xor_pd(blend(_mm512_sub_pd(t12, t10), _mm512_sub_pd(t13, t11), _mm512_sub_pd(t22, t20),
                                           _mm512_sub_pd(t23, t21)), sign);
    const __m512d gy = _mm512_xor_pd(blend(_mm512_sub_pd(t21, t01), _mm512_sub_pd(t22, t02), _mm512_sub_pd(t31, t11),
                                           _mm512_sub_pd(t32, t12)), sign);
    // normalisedOrZero(−∇T): n = √(x² + y²), zero (the general way) where n ≤ 1e-12.
    const __m512d n = _mm512_sqrt_pd(_mm512_add_pd(_mm512_mul_pd(gx, gx), _mm512_mul_pd(gy, gy)));
    ok = _mm512_mask_cmp_pd_mask(ok, n, _mm512_set1_pd(1e-12), _CMP_GT_OQ);
    const __m512d dx = _mm512_div_pd(gx, n), dy = _mm512_div_pd(gy, n);
    double* out = dir[0].data();
    _mm512_storeu_pd(out, _mm512_permutex2var_pd(dx, _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11), dy));
    _mm512_storeu_pd(out + 8, _mm512_permutex2var_pd(dx, _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15), dy));
    _mm512_storeu_pd(dist, d);
    return ok;
}
#pragma GCC diagnostic pop
#endif

}  // namespace

int navigationSamplePath() { return gSamplePath.load(); }

bool setNavigationSamplePath(int path) {
    if (path != 0 && !(path == 1 && cpu::hasAvx512())) return false;
    gSamplePath.store(path);
    return true;
}

void WalkableGrid::probe8(const Vec2* pos, int count, Probe8& q) const {
#ifdef CH_NAV_X86
    if (gSamplePath.load(std::memory_order_relaxed) == 1) {
        probe8Avx512(pos, count, origin_, h_, nx_, ny_, openBits_.data(), q);
        return;
    }
#endif
    q.inGrid = q.open = 0;
    for (int l = 0; l < count; ++l) {
        const Probe p = probe(pos[l]);
        q.qx[l] = p.qx, q.qy[l] = p.qy;
        q.cx[l] = p.cx, q.cy[l] = p.cy, q.i0[l] = p.i0, q.j0[l] = p.j0;
        q.first[l] = static_cast<std::int32_t>(p.first);
        q.inGrid |= static_cast<unsigned>(p.inGrid) << l;
        q.open |= static_cast<unsigned>(p.open) << l;
    }
}

unsigned DistanceField::sample8(const DistanceField* const* fields, const WalkableGrid::Probe8& q, unsigned lanes,
                                Vec2* dir, double* dist) {
    lanes &= q.open;
    // The lanes whose field can take the short way, and their blocks' first cells.
    const float* block[8] = {};
    const WalkableGrid* grid = nullptr;
    for (unsigned m = lanes; m != 0; m &= m - 1) {
        const int l = __builtin_ctz(m);
        const DistanceField& f = *fields[l];
        if (f.grid_ == nullptr || !f.seeded_) {
            lanes &= ~(1u << l);
            continue;
        }
        grid = f.grid_;
        block[l] = &f.value_[static_cast<std::size_t>(q.first[l])];
    }
    if (lanes == 0) return 0;
    const std::size_t nx = static_cast<std::size_t>(grid->nx());
    const double h = grid->cellSize();
#ifdef CH_NAV_X86
    if (gSamplePath.load(std::memory_order_relaxed) == 1) {
        return shortWay8(block, lanes, nx, h, q, dir, dist);
    }
#endif
    unsigned done = 0;
    for (unsigned m = lanes; m != 0; m &= m - 1) {
        const int l = __builtin_ctz(m);
        if (shortWay(block[l], nx, h, q.qx[l], q.qy[l], q.cx[l], q.cy[l], q.i0[l], q.j0[l], dir[l], dist[l]))
            done |= 1u << l;
    }
    return done;
}

}  // namespace ch
