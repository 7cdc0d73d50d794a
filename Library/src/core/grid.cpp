// CrowdHealth — uniform-grid neighbour search.
#include "crowdhealth/core/grid.h"

#include "crowdhealth/core/parallel.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

namespace ch {

namespace {
// Cap on the number of cells: beyond it the cell size grows (sparse, far-flung agents such as
// UMANS' goals at x = 50 km would otherwise ask for millions of empty cells).
constexpr long long kMaxCells = 1 << 22;

/// The cells of side `cell` (doubled until there are at most kMaxCells) covering [lo, hi]. The
/// counts are computed in floating point first: over a huge extent (a point 1e15 m away) the
/// number of cells does not fit an int, and casting it would be undefined.
void cellsCovering(const Vec2& lo, const Vec2& hi, double& cell, int& nx, int& ny) {
    for (;;) {
        const double fx = std::floor((hi.x() - lo.x()) / cell) + 1;
        const double fy = std::floor((hi.y() - lo.y()) / cell) + 1;
        if (!(fx * fy < kInf) || !(cell < kInf)) {  // NaN or infinite extent: one cell
            nx = ny = 1;
            return;
        }
        if (fx * fy <= static_cast<double>(kMaxCells)) {
            nx = static_cast<int>(fx);
            ny = static_cast<int>(fy);
            return;
        }
        cell *= 2;
    }
}
/// The cells [x0, x1] × [y0, y1] of an nx × ny grid (corner `origin`, square cells of side
/// `cell`) that the box touches, clamped to the grid: empty (x0 > x1 or y0 > y1) when the box lies
/// outside it. Bounds of finite values only (the cell numbers must fit an int).
struct CellRange {
    int x0, x1, y0, y1;
};
CellRange cellRange(const Box& box, const Vec2& origin, double cell, int nx, int ny) {
    const auto at = [&](double v, double o) { return static_cast<int>(std::floor((v - o) / cell)); };
    return {std::max(0, at(box.lo.x(), origin.x())), std::min(nx - 1, at(box.hi.x(), origin.x())),
            std::max(0, at(box.lo.y(), origin.y())), std::min(ny - 1, at(box.hi.y(), origin.y()))};
}
/// The bounds of the points as one loop `lo = hi = points[0]`, then `lo = min(lo, p)` and
/// `hi = max(hi, p)` over them all gives them (Box::add: Eigen's cwiseMin/Max keep the left
/// operand unless the right one compares smaller/larger, so a NaN coordinate is passed over,
/// unless points[0] has it, and of equal values the first is kept). A large crowd's points are
/// scanned on the team, in the static chunks of the step's other loops, each thread's bounds
/// started from points[0] too and then taken in thread order: the same bits. (Scanned by the
/// main thread alone, every position was read by one core at each step, and the other core's
/// writes of its own agents' positions in the next integration then had to take each cache line
/// back: on two threads that half of the dense 10k crowd's integration took twice as long as the
/// other, issue 20.)
Box extent(const std::vector<Vec2>& points, std::vector<Box>& part) {
    const std::size_t n = points.size();
    if (n == 0) return Box(Vec2(0, 0), Vec2(0, 0));
    // A thread's bounds in a local Box, stored once: the threads' slots share a cache line.
    const auto scan = [&](std::size_t begin, std::size_t end) {
        Box b(points[0], points[0]);
        for (std::size_t i = begin; i < end; ++i) b.add(points[i]);
        return b;
    };
    const int threads = omp_get_max_threads();
    if (threads <= 1 || !parallelCheapLoop(n)) return scan(0, n);
    // A slot of a thread the team did not get keeps the box of points[0]: it changes nothing.
    part.assign(static_cast<std::size_t>(threads), Box(points[0], points[0]));
#pragma omp parallel num_threads(threads)
    {
        const std::size_t t = static_cast<std::size_t>(omp_get_thread_num());
        const std::size_t team = static_cast<std::size_t>(omp_get_num_threads());
        part[t] = scan(n * t / team, n * (t + 1) / team);
    }
    Box all = part[0];
    for (std::size_t t = 1; t < part.size(); ++t) {
        all.lo = all.lo.cwiseMin(part[t].lo);
        all.hi = all.hi.cwiseMax(part[t].hi);
    }
    return all;
}
}  // namespace

void PointGrid::build(const std::vector<Vec2>& points, double cellSize, bool periodic, double width,
                      double height) {
    points_ = &points;
    periodic_ = periodic;
    width_ = width;
    height_ = height;
    const double cell = cellSize > 0 ? cellSize : 1.0;
    if (periodic_) {
        // A whole number of cells per period, each at least `cell` wide and high.
        nx_ = std::max(1, static_cast<int>(std::floor(width_ / cell)));
        ny_ = std::max(1, static_cast<int>(std::floor(height_ / cell)));
        cw_ = width_ / nx_;
        ch_ = height_ / ny_;
        origin_ = Vec2(-0.5 * width_, -0.5 * height_);
    } else {
        const Box bounds = extent(points, bounds_);
        cw_ = cell;
        cellsCovering(bounds.lo, bounds.hi, cw_, nx_, ny_);
        ch_ = cw_;
        origin_ = bounds.lo;
    }
    const int ncells = nx_ * ny_;
    const std::size_t n = points.size();
    cellStart_.assign(ncells + 1, 0);
    cellOf_.resize(n);
    sorted_.resize(n);
    if (keepPositions_) {
        sortedX_.resize(n);
        sortedY_.resize(n);
    } else {
        std::vector<double>().swap(sortedX_);
        std::vector<double>().swap(sortedY_);
    }
    const auto cellIndex = [&](const Vec2& p) {
        int x = cellX(p.x()), y = cellY(p.y());
        if (periodic_) {
            x = ((x % nx_) + nx_) % nx_;
            y = ((y % ny_) + ny_) % ny_;
        } else {
            x = std::clamp(x, 0, nx_ - 1);
            y = std::clamp(y, 0, ny_ - 1);
        }
        return y * nx_ + x;
    };
    // A crowd large enough, on cells not much more numerous than its points: the counting sort on
    // the team (issue 20: on one thread it was ~4 % of a 100k dense step on two). Each thread
    // counts its own static chunk of the points; the offsets are then handed out cell by cell in
    // thread order, so each cell lists its points in ascending index, as the serial sort does:
    // the same grid, bit for bit. Sparse grids (far-flung goals) stay serial: one histogram of
    // the cells per thread would cost more than the points.
    const int threads = omp_get_max_threads();
    if (threads > 1 && parallelCheapLoop(n) && static_cast<std::size_t>(ncells) <= 4 * n) {
        const std::size_t cells = static_cast<std::size_t>(ncells);
        fill_.assign(static_cast<std::size_t>(threads) * cells, 0);
        int team = 1;
#pragma omp parallel num_threads(threads)
        {
            const int t = omp_get_thread_num();
#pragma omp single
            team = omp_get_num_threads();
            const std::size_t begin = n * static_cast<std::size_t>(t) / static_cast<std::size_t>(team);
            const std::size_t end = n * static_cast<std::size_t>(t + 1) / static_cast<std::size_t>(team);
            int* count = fill_.data() + static_cast<std::size_t>(t) * cells;
            for (std::size_t i = begin; i < end; ++i) {
                cellOf_[i] = cellIndex(points[i]);
                ++count[cellOf_[i]];
            }
#pragma omp barrier
#pragma omp single
            {
                // Each thread's first slot in each cell; cellStart_ as the serial prefix sum.
                int at = 0;
                for (std::size_t c = 0; c < cells; ++c) {
                    cellStart_[c] = at;
                    for (int u = 0; u < team; ++u) {
                        int& k = fill_[static_cast<std::size_t>(u) * cells + c];
                        const int many = k;
                        k = at;
                        at += many;
                    }
                }
                cellStart_[cells] = at;
            }
            for (std::size_t i = begin; i < end; ++i) {
                const int k = count[cellOf_[i]]++;
                sorted_[k] = static_cast<int>(i);
                if (keepPositions_) {
                    sortedX_[k] = points[i].x();
                    sortedY_[k] = points[i].y();
                }
            }
        }
        return;
    }
    for (std::size_t i = 0; i < n; ++i) {
        cellOf_[i] = cellIndex(points[i]);
        ++cellStart_[cellOf_[i] + 1];
    }
    for (int c = 0; c < ncells; ++c) cellStart_[c + 1] += cellStart_[c];
    fill_.assign(cellStart_.begin(), cellStart_.end() - 1);
    // Counting sort, stable: within a cell, indices stay ascending.
    for (std::size_t i = 0; i < n; ++i) {
        const int k = fill_[cellOf_[i]]++;
        sorted_[k] = static_cast<int>(i);
        if (keepPositions_) {
            sortedX_[k] = points[i].x();
            sortedY_[k] = points[i].y();
        }
    }
}

std::size_t PointGrid::candidateCount(const Vec2& p, double radius) const {
    if (points_ == nullptr || sorted_.empty()) return 0;
    std::size_t total = 0;
    if (!periodic_) {
        const CellBox b = boxAround(p, radius);
        if (b.x0 > b.x1) return 0;
        for (int y = b.y0; y <= b.y1; ++y)
            total += static_cast<std::size_t>(cellStart_[y * nx_ + b.x1 + 1] - cellStart_[y * nx_ + b.x0]);
        return total;
    }
    int cx, cy, sx, sy;
    periodicSpan(p, radius, cx, cy, sx, sy);
    for (int oy = 0; oy < sy; ++oy)
        for (int ox = 0; ox < sx; ++ox) {
            const int c = ((cy + oy) % ny_ + ny_) % ny_ * nx_ + ((cx + ox) % nx_ + nx_) % nx_;
            total += static_cast<std::size_t>(cellStart_[c + 1] - cellStart_[c]);
        }
    return total;
}

std::vector<int> PointGrid::within(const Vec2& p, double radius) const {
    std::vector<int> out;
    forEachWithin(p, radius, [&](int j, const Vec2&, double) { out.push_back(j); });
    std::sort(out.begin(), out.end());
    return out;
}

void BoxIndex::build(const std::vector<Box>& boxes, double cellSize) {
    cellStart_.clear();
    items_.clear();
    nx_ = ny_ = 0;
    boxCells_.clear();
    const auto listed = [](const Box& b) { return !b.empty() && b.lo.allFinite() && b.hi.allFinite(); };
    Box bounds;
    for (const Box& b : boxes)
        if (listed(b)) bounds.add(b.lo), bounds.add(b.hi);
    if (bounds.empty()) return;
    origin_ = bounds.lo;
    cell_ = cellSize > 0 ? cellSize : 1.0;
    inverse_ = 1.0 / cell_;
    // Few entries per box unless a box is far larger than the cells: then coarser cells.
    const long long maxItems = (1LL << 22) + static_cast<long long>(boxes.size());
    for (;;) {
        cellsCovering(bounds.lo, bounds.hi, cell_, nx_, ny_);
        long long items = 0;
        for (const Box& b : boxes) {
            if (!listed(b)) continue;
            const Cells r = cells(b);
            items += static_cast<long long>(r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1);
        }
        if (items <= maxItems || (nx_ == 1 && ny_ == 1)) break;
        cell_ *= 2;
        inverse_ = 1.0 / cell_;
    }
    // One array with per-cell offsets, in two passes (count, then fill in box order).
    boxCells_.assign(boxes.size(), Cells{0, -1, 0, -1});
    for (std::size_t k = 0; k < boxes.size(); ++k)
        if (listed(boxes[k])) boxCells_[k] = cells(boxes[k]);
    const std::size_t ncells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
    cellStart_.assign(ncells + 1, 0);
    const auto forCells = [&](std::size_t k, auto&& f) {
        const Cells& r = boxCells_[k];
        for (int y = r.y0; y <= r.y1; ++y)
            for (int x = r.x0; x <= r.x1; ++x) f(static_cast<std::size_t>(y) * static_cast<std::size_t>(nx_) + x);
    };
    for (std::size_t k = 0; k < boxes.size(); ++k) forCells(k, [&](std::size_t c) { ++cellStart_[c + 1]; });
    for (std::size_t c = 0; c < ncells; ++c) cellStart_[c + 1] += cellStart_[c];
    items_.resize(static_cast<std::size_t>(cellStart_[ncells]));
    std::vector<int> fill(cellStart_.begin(), cellStart_.end() - 1);
    for (std::size_t k = 0; k < boxes.size(); ++k)
        forCells(k, [&](std::size_t c) { items_[static_cast<std::size_t>(fill[c]++)] = static_cast<int>(k); });
}

BoxIndex::Cells BoxIndex::cells(const Box& box) const {
    if (nx_ <= 0 || ny_ <= 0 || box.empty()) return {0, -1, 0, -1};
    return {std::max(0, coordinate(box.lo.x(), origin_.x(), nx_)),
            std::min(nx_ - 1, coordinate(box.hi.x(), origin_.x(), nx_)),
            std::max(0, coordinate(box.lo.y(), origin_.y(), ny_)),
            std::min(ny_ - 1, coordinate(box.hi.y(), origin_.y(), ny_))};
}

void SegmentGrid::build(const std::vector<Segment>& segments, double cellSize) {
    segments_ = &segments;
    ranged_.clear();
    clear_.clear();
    clearNx_ = clearNy_ = 0;
    std::vector<Box> boxes;
    boxes.reserve(segments.size());
    Box bounds;
    for (const Segment& s : segments) {
        boxes.emplace_back(s.a, s.b);
        bounds.add(s.a), bounds.add(s.b);
    }
    cells_.build(boxes, cellSize);
    if (!segments.empty()) buildClearance(bounds.lo, bounds.hi);
}

void SegmentGrid::buildClearance(const Vec2& lo, const Vec2& hi) {
    // Most queries (an agent's neighbour list, its walls) come from far from any wall, where the
    // scan of the cells found nothing at the cost of a few hundred instructions (issue 20: 5 % of
    // the dense 10k step's). The raster answers those in a lookup.
    clear_.clear();
    clearNx_ = clearNy_ = 0;
    clearInv_ = 0;
    const double reach = kClearanceReach;
    const Vec2 from = lo - Vec2(reach, reach), to = hi + Vec2(reach, reach);
    double cell = 0.5;
    double fx = 0, fy = 0;
    for (;;) {
        fx = std::ceil((to.x() - from.x()) / cell);
        fy = std::ceil((to.y() - from.y()) / cell);
        if (!(fx * fy < kInf)) return;  // NaN or infinite bounds: no raster, every query scans
        if (fx * fy <= static_cast<double>(1 << 20)) break;
        cell *= 2;
    }
    clearNx_ = std::max(1, static_cast<int>(fx));
    clearNy_ = std::max(1, static_cast<int>(fy));
    clearOrigin_ = from;
    clearInv_ = 1.0 / cell;
    // A point of a cell is at most half a diagonal from its centre (plus what rounding in
    // clearance()'s cell lookup may add, far below the micrometre kept here).
    const double slack = 0.5 * std::sqrt(2.0) * cell + 1e-6;
    // The bound as a float rounded down (never above the double it stands for), kept at once:
    // no second raster of doubles (the 1M crowd's room has ~930,000 cells).
    const auto below = [](double bound) {
        if (!(bound > 0)) return 0.0f;  // NaN too: nothing known
        const float f = static_cast<float>(bound);
        return static_cast<double>(f) > bound ? std::nextafter(f, 0.0f) : f;
    };
    clear_.assign(static_cast<std::size_t>(clearNx_) * clearNy_, below(reach - slack));
    for (const Segment& s : *segments_) {
        if (!s.a.allFinite() || !s.b.allFinite()) {  // no cell range to bound: no raster, every query scans
            clear_.clear();
            clearNx_ = clearNy_ = 0;
            return;
        }
        const Box box(s.a, s.b);
        const CellRange r = cellRange(box.grown(reach), from, cell, clearNx_, clearNy_);
        for (int y = r.y0; y <= r.y1; ++y)
            for (int x = r.x0; x <= r.x1; ++x) {
                const Vec2 centre = from + Vec2((x + 0.5) * cell, (y + 0.5) * cell);
                float& m = clear_[static_cast<std::size_t>(y) * clearNx_ + x];
                // The segment is at least as far as its bounding box: where that is already
                // farther than m + slack (with room for rounding), the bound below could not be
                // less than m. Most cells near many walls pass here (issue 20: a forest of 2,500
                // pillars spent 9 % of a 10 s run on this raster).
                const double dx = std::max({box.lo.x() - centre.x(), 0.0, centre.x() - box.hi.x()});
                const double dy = std::max({box.lo.y() - centre.y(), 0.0, centre.y() - box.hi.y()});
                const double limit = static_cast<double>(m) + slack;
                if (dx * dx + dy * dy > limit * limit * (1 + 1e-9)) continue;
                const float bound = below(std::sqrt(distanceToSegmentSquared(centre, s.a, s.b)) - slack);
                if (bound < m) m = bound;
            }
    }
}

void SegmentGrid::prepare(double range) {
    if (empty() || !(range > 0) || !(range < kInf)) return;
    for (const Ranged& g : ranged_)
        if (g.range == range) return;
    // A point within `range` of a segment lies in its bounds widened by `range` (the distance is
    // at least each coordinate's), and the margin covers the rounding of the distance test.
    std::vector<Box> boxes;
    boxes.reserve(segments_->size());
    for (const Segment& s : *segments_) boxes.push_back(Box(s.a, s.b).grownPastRounding(range));
    // Cells of a quarter of the range: a list holds the segments within about 1.1 range of p,
    // where the cells round p would hold those within 1.4 range and more than one cell each.
    Ranged g{range, {}};
    g.index.build(boxes, std::max(0.5, 0.25 * range));
    // Each cell's list by distance from the cell's centre c (half-diagonal h): for p in the cell,
    // |d(p) − d(c)| ≤ h, so a segment with d(c) > range + h is beyond range of all of them and
    // leaves the list, and one with d(c) + h ≤ range is within range of all of them and needs no
    // test (issue 20: among many obstacles a third of a list goes, half of the rest is sure). The
    // margin covers the rounding of the distances here and in near(), and p's cell being found by
    // a rounded division.
    const std::vector<Segment>& segs = *segments_;
    g.index.rewrite([&](int k, const Box& cell) {
        const Vec2 c = 0.5 * (cell.lo + cell.hi);
        const double h = 0.5 * (cell.hi - cell.lo).norm();
        const Segment& s = segs[static_cast<std::size_t>(k)];
        const double scale = std::max({std::abs(c.x()), std::abs(c.y()), std::abs(s.a.x()), std::abs(s.a.y()),
                                       std::abs(s.b.x()), std::abs(s.b.y())});
        const double margin = Box::roundingMargin(scale + h + range);
        const double d = std::sqrt(distanceToSegmentSquared(c, s.a, s.b));
        if (d - h - margin > range) return BoxIndex::kDrop;
        return d + h + margin <= range ? ~k : k;
    });
    ranged_.push_back(std::move(g));
}

void SegmentGrid::near(const Vec2& p, double radius, std::vector<int>& out) const {
    out.clear();
    if (empty()) return;
    for (const Ranged& g : ranged_) {
        if (!(radius <= g.range && radius >= 0.75 * g.range)) continue;
        const double r2 = radius * radius;
        // A list entry ~k (negative) is within range of the whole cell: taken without a test
        // when the radius is the range. The others are written and the count advanced by the
        // test's result: which of them are within the radius follows no order a branch could
        // predict (issue 20).
        const bool whole = radius == g.range;
        const auto list = g.index.at(p);
        out.resize(list.size());
        const Segment* seg = segments_->data();
        std::size_t n = 0;
        for (const int e : list) {
            if (e < 0 && whole) {
                out[n++] = ~e;
                continue;
            }
            const int s = e < 0 ? ~e : e;
            const Segment& w = seg[static_cast<std::size_t>(s)];
            out[n] = s;
            n += distanceToSegmentSquared(p, w.a, w.b) <= r2;
        }
        out.resize(n);
        return;
    }
    if (radius < clearance(p)) return;  // every segment farther than radius
    // The cells of the query's bounding box, padded by 1 µm (a superset is harmless: every
    // candidate is tested by distance). A segment listed in several of them is tested in the
    // first only.
    const double reach = radius + 1e-6;
    const BoxIndex::Cells r = cells_.cells(Box(p - Vec2(reach, reach), p + Vec2(reach, reach)));
    const double r2 = radius * radius;
    for (int y = r.y0; y <= r.y1; ++y)
        for (int x = r.x0; x <= r.x1; ++x)
            for (const int s : cells_.at(x, y)) {
                if (!cells_.firstAt(s, r, x, y)) continue;
                const Segment& seg = (*segments_)[static_cast<std::size_t>(s)];
                if (distanceToSegmentSquared(p, seg.a, seg.b) <= r2) out.push_back(s);
            }
    if (out.size() > 1) std::sort(out.begin(), out.end());
}

}  // namespace ch
