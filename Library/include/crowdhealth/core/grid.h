// CrowdHealth — uniform-grid neighbour search (square cells, std::floor
// indexing, rebuilt each step with a counting sort), for agents and for static wall segments.
#pragma once

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/types.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

namespace ch {

/// Points (agent positions) bucketed in square cells. Supports a toric (periodic) domain.
class PointGrid {
public:
    /// Rebuilds the grid over `points` with cells of `cellSize` > 0 (m). Queries of any radius
    /// work; they scan the cells the query disc's bounding box touches, so cells smaller than the
    /// radius mean fewer candidates (Simulation::stepGridCell uses half the radius).
    /// If `periodic`, the domain is [-width/2, width/2) × [-height/2, height/2) and queries wrap.
    void build(const std::vector<Vec2>& points, double cellSize, bool periodic = false, double width = 0,
               double height = 0);

    /// Calls f(j, offset, distSq) for every point j with |offset| <= radius, where offset is
    /// (points[j] - p), the shortest such vector on a torus. The query point's own index is not
    /// skipped: callers that need "others only" compare j themselves. Visit order is deterministic.
    template <class F>
    void forEachWithin(const Vec2& p, double radius, F&& f) const;

    /// Calls f(j, offset, distSq) for every point forEachWithin(p, radius, ·) examines — the
    /// points of the cells the query disc touches, in the same order — whether or not it lies
    /// within `radius` (candidateCount(p, radius) calls). For callers that test the distance
    /// without a branch (a list append that always writes and advances by the test's outcome):
    /// in a crowd whose listing order within cells is irregular, the branch of forEachWithin is
    /// mispredicted often enough to cost a third of the neighbour search (docs/performance.md).
    template <class F>
    void forEachCandidate(const Vec2& p, double radius, F&& f) const;

    /// How many points forEachWithin(p, radius, f) examines: an upper bound of how many it reports.
    std::size_t candidateCount(const Vec2& p, double radius) const;

    /// Collects the indices within radius (for tests and simple callers).
    std::vector<int> within(const Vec2& p, double radius) const;

    /// The point indices grouped by cell, cells row by row (y outer), ascending within a cell.
    const std::vector<int>& order() const { return sorted_; }

    /// Cell width (x) actually used (≥ the requested size; larger for far-flung points).
    double cellSize() const { return cw_; }
    /// The corner of cell (0, 0): on a plane, the points' lower bounds; on a torus, the domain's.
    Vec2 origin() const { return origin_; }
    /// The cells in x and in y.
    int cellsX() const { return nx_; }
    int cellsY() const { return ny_; }
    bool periodic() const { return periodic_; }

    /// Whether the next build() keeps a copy of the points' coordinates in cell order (sortedX(),
    /// sortedY(): 16 bytes per point, true by default), which queries read contiguously. Without
    /// it they read the points through order(): the same calls in the same order, for half the
    /// grid's memory (a one-off grid over a large crowd, as ch::measureDensity builds).
    void keepPositions(bool keep) { keepPositions_ = keep; }

    /// x and y of the points in order() (structure of arrays, for vectorised queries); empty when
    /// the grid was built without keepPositions.
    const std::vector<double>& sortedX() const { return sortedX_; }
    const std::vector<double>& sortedY() const { return sortedY_; }

    /// A run of order(): positions [begin, end).
    struct Run {
        int begin, end;
    };
    /// Plane only: the runs of order() forEachCandidate(p, radius, ·) scans — one per row of cells
    /// the query disc's bounding box touches, in row order, empty ones left out — into
    /// runs[0, count); returns false (and nothing else) if there are more than maxRuns rows.
    /// `total` is their summed length, candidateCount(p, radius).
    bool rowRuns(const Vec2& p, double radius, Run* runs, int maxRuns, int& count, std::size_t& total) const {
        count = 0;
        total = 0;
        const CellBox b = boxAround(p, radius);
        if (b.x0 > b.x1) return true;
        if (b.y1 - b.y0 + 1 > maxRuns) return false;
        for (int y = b.y0; y <= b.y1; ++y) {
            const int k0 = cellStart_[y * nx_ + b.x0], k1 = cellStart_[y * nx_ + b.x1 + 1];
            runs[count] = Run{k0, k1};
            count += k1 > k0 ? 1 : 0;
            total += static_cast<std::size_t>(k1 - k0);
        }
        return true;
    }

    /// to − from, the shortest such vector on a torus (the domain of the last build()).
    Vec2 offset(const Vec2& from, const Vec2& to) const {
        Vec2 d = to - from;
        if (periodic_) {
            if (width_ > 0) d.x() -= width_ * std::round(d.x() / width_);
            if (height_ > 0) d.y() -= height_ * std::round(d.y() / height_);
        }
        return d;
    }

private:
    const std::vector<Vec2>* points_ = nullptr;
    double cw_ = 1, ch_ = 1;  ///< cell width and height (m); equal except on a torus
    bool periodic_ = false;
    double width_ = 0, height_ = 0;
    Vec2 origin_{0, 0};
    int nx_ = 1, ny_ = 1;
    std::vector<int> cellStart_;  ///< size nx*ny+1, counting-sort offsets
    std::vector<int> sorted_;     ///< point indices, grouped by cell (row-major cells)
    std::vector<double> sortedX_, sortedY_;  ///< points[sorted_[k]]: queries read positions contiguously
    std::vector<int> cellOf_, fill_;  ///< build scratch, kept to avoid allocating every step
    std::vector<Box> bounds_;         ///< build scratch: each thread's bounds of its points
    bool keepPositions_ = true;

    /// forEachCandidate, reading the positions from sortedX_/sortedY_ (kCopies) or via sorted_.
    template <bool kCopies, class F>
    void scanCandidates(const Vec2& p, double radius, F&& f) const;
    template <bool kCopies>
    Vec2 sortedPosition(int k) const {
        if constexpr (kCopies)
            return Vec2(sortedX_[static_cast<std::size_t>(k)], sortedY_[static_cast<std::size_t>(k)]);
        else
            return (*points_)[static_cast<std::size_t>(sorted_[static_cast<std::size_t>(k)])];
    }

    int cellX(double x) const { return floorToInt((x - origin_.x()) / cw_); }
    /// floor(v) for a cell coordinate, limited to [-1, n] (NaN gives -1) without calling floor.
    static int floorClamped(double v, int n) {
        if (!(v >= 0)) return -1;
        return v >= n ? n : static_cast<int>(v);
    }
    int cellY(double y) const { return floorToInt((y - origin_.y()) / ch_); }

    /// Cells touched by the query disc's bounding box (plane only), padded by 1 µm so that
    /// rounding never drops a point at exactly `radius`; x0 > x1 when it misses the grid.
    struct CellBox {
        int x0, x1, y0, y1;
    };
    CellBox boxAround(const Vec2& p, double radius) const {
        const double reach = radius + 1e-6;
        const double ix = 1.0 / cw_, iy = 1.0 / ch_;
        return CellBox{std::max(0, floorClamped((p.x() - reach - origin_.x()) * ix, nx_)),
                       std::min(nx_ - 1, floorClamped((p.x() + reach - origin_.x()) * ix, nx_)),
                       std::max(0, floorClamped((p.y() - reach - origin_.y()) * iy, ny_)),
                       std::min(ny_ - 1, floorClamped((p.y() + reach - origin_.y()) * iy, ny_))};
    }
    /// Periodic queries: the first cell and the number of cells visited along x and y.
    void periodicSpan(const Vec2& p, double radius, int& cx, int& cy, int& sx, int& sy) const {
        const int rx = static_cast<int>(std::ceil(radius / cw_));
        const int ry = static_cast<int>(std::ceil(radius / ch_));
        cx = cellX(p.x()) - rx;
        cy = cellY(p.y()) - ry;
        sx = std::min(2 * rx + 1, nx_);
        sy = std::min(2 * ry + 1, ny_);
    }
};

/// Static shapes' bounding boxes bucketed in square cells (built once): each box is listed in
/// every cell it touches, so the boxes listed in a point's cell include every box holding the
/// point. World uses it to find the obstacle polygon a point lies in without testing them all,
/// SegmentGrid to find the segments near a point.
class BoxIndex {
public:
    /// Lists box k (k ascending) in every cell it touches. Cells of `cellSize` (m), doubled while
    /// the boxes' bounds would need more than 2^22 cells or the lists more than 2^22 entries plus
    /// one per box (a few huge shapes over a large venue). Empty boxes and boxes with a coordinate
    /// that is not finite are not listed.
    void build(const std::vector<Box>& boxes, double cellSize);
    /// The cells [x0, x1] × [y0, y1] that `box` touches, clamped to the grid (x0 > x1 or y0 > y1:
    /// none). `box` must have finite bounds, or be empty.
    struct Cells {
        int x0, x1, y0, y1;
    };
    Cells cells(const Box& box) const;
    /// The boxes listed in cell (x, y), ascending.
    std::span<const int> at(int x, int y) const {
        const std::size_t c = static_cast<std::size_t>(y) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(x);
        return {items_.data() + cellStart_[c], static_cast<std::size_t>(cellStart_[c + 1] - cellStart_[c])};
    }
    /// The boxes listed in p's cell, ascending (none when p is off the grid or not finite).
    /// Inline: the walls' lists of every agent at every step start here (issue 20).
    std::span<const int> at(const Vec2& p) const {
        const int x = coordinate(p.x(), origin_.x(), nx_), y = coordinate(p.y(), origin_.y(), ny_);
        if (x < 0 || x >= nx_ || y < 0 || y >= ny_) return {};
        return at(x, y);
    }
    /// The cells box k is listed in (none for a box left out).
    const Cells& cellsOf(int k) const { return boxCells_[static_cast<std::size_t>(k)]; }
    /// True when a scan of the cells `scan` (row by row, y outer) meets box k first at (x, y):
    /// a scan that counts each box there only sees it once.
    bool firstAt(int k, const Cells& scan, int x, int y) const {
        const Cells& c = cellsOf(k);
        return x == std::max(c.x0, scan.x0) && y == std::max(c.y0, scan.y0);
    }
    double cellSize() const { return cell_; }
    /// The value rewrite() drops.
    static constexpr int kDrop = std::numeric_limits<int>::min();
    /// Rewrites every cell's list in place, in its order: entry k becomes f(k, cell) (cell: the
    /// cell's area, a point p of which has at(p) give this list, up to rounding), or leaves the
    /// list when f gives kDrop. cellsOf and firstAt still describe the lists as built.
    template <class F>
    void rewrite(F&& f) {
        std::size_t n = 0, from = 0;
        for (int y = 0; y < ny_; ++y)
            for (int x = 0; x < nx_; ++x) {
                const std::size_t c = static_cast<std::size_t>(y) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(x);
                const Box area(origin_ + cell_ * Vec2(x, y), origin_ + cell_ * Vec2(x + 1, y + 1));
                const std::size_t to = static_cast<std::size_t>(cellStart_[c + 1]);
                cellStart_[c] = static_cast<int>(n);
                for (; from < to; ++from)
                    if (const int v = f(items_[from], area); v != kDrop) items_[n++] = v;
            }
        if (!cellStart_.empty()) cellStart_.back() = static_cast<int>(n);
        items_.resize(n);
    }

private:
    /// The cell column (row) of coordinate v, limited to [-1, n] (NaN gives -1) before the cast,
    /// so far-flung coordinates are safe. The same expression for every coordinate (a box's
    /// corners and a point alike): it is monotone, so a point of a box falls in one of the box's
    /// cells.
    int coordinate(double v, double o, int n) const {
        const double c = (v - o) * inverse_;
        return !(c >= 0) ? -1 : (c >= n ? n : static_cast<int>(c));
    }
    double cell_ = 1;
    double inverse_ = 1;  ///< 1 / cell_
    Vec2 origin_{0, 0};
    int nx_ = 0, ny_ = 0;
    std::vector<Cells> boxCells_;
    std::vector<int> cellStart_;  ///< size nx*ny+1: the boxes of cell c are items_[start[c], start[c+1])
    std::vector<int> items_;
};

/// Static wall segments bucketed in square cells (built once).
class SegmentGrid {
public:
    void build(const std::vector<Segment>& segments, double cellSize);
    /// Indices of the segments that come within `radius` of p (each once, ascending).
    void near(const Vec2& p, double radius, std::vector<int>& out) const;
    /// Readies near() for queries of about `range` (a policy's neighbourhood, asked for every
    /// agent at every step): a second index lists in each cell, ascending, the segments whose
    /// bounds widened by `range` touch it, and a query of a radius in [¾ range, range] tests
    /// only p's cell's list: no scan of the cells round p, no sort. The same answers.
    void prepare(double range);
    bool empty() const { return segments_ == nullptr || segments_->empty(); }
    /// A lower bound (m) of p's distance to every segment: 0 where nothing is known (outside the
    /// clearance raster, NaN p), at most kClearanceReach. near() with a smaller radius finds nothing.
    double clearance(const Vec2& p) const {
        const double fx = (p.x() - clearOrigin_.x()) * clearInv_, fy = (p.y() - clearOrigin_.y()) * clearInv_;
        if (!(fx >= 0 && fy >= 0 && fx < clearNx_ && fy < clearNy_)) return 0;
        return clear_[static_cast<std::size_t>(fy) * static_cast<std::size_t>(clearNx_) + static_cast<std::size_t>(fx)];
    }
    /// How far the clearance raster looks for segments (m): queries of a larger radius always scan.
    static constexpr double kClearanceReach = 6.0;

private:
    /// The clearance raster: square cells of side 1 / clearInv_ (0.5 m, doubled to stay within
    /// 2^20 cells) over the segments' bounds widened by kClearanceReach, each holding
    /// min(distance from its centre to the nearest segment, kClearanceReach) less half its
    /// diagonal and a margin for rounding, as a float rounded down, and never below 0.
    void buildClearance(const Vec2& lo, const Vec2& hi);

    const std::vector<Segment>* segments_ = nullptr;
    BoxIndex cells_;  ///< each segment's bounding box
    struct Ranged {
        double range;
        /// Each segment whose bounding box widened by `range` (and a rounding margin) touches the
        /// cell, less those beyond range of every point of the cell; those within range of every
        /// point of it are listed as ~k (negative).
        BoxIndex index;
    };
    std::vector<Ranged> ranged_;
    Vec2 clearOrigin_{0, 0};
    double clearInv_ = 0;
    int clearNx_ = 0, clearNy_ = 0;
    std::vector<float> clear_;
};

// ---- template implementation -------------------------------------------------------------

template <class F>
void PointGrid::forEachCandidate(const Vec2& query, double radius, F&& f) const {
    if (points_ == nullptr || sorted_.empty()) return;
    const Vec2 p = query;  // a local copy: f may store to memory the query point could alias
    if (keepPositions_)
        scanCandidates<true>(p, radius, f);
    else
        scanCandidates<false>(p, radius, f);
}

template <bool kCopies, class F>
void PointGrid::scanCandidates(const Vec2& p, double radius, F&& f) const {
    if (!periodic_) {
        // Only the cells touched by the query disc's bounding box (boxAround). Cells of one row
        // are contiguous in sorted_, so each row is one run over sortedX_/sortedY_. The visit
        // order (rows, then cells, then ascending index) is the same as scanning whole cells, so
        // sums over neighbours do not change.
        // (Multiplying by the inverse cell size may round differently from the division used to
        // bin the points, by far less than the pad.)
        // (Trimming each row to the disc's chord, issue 20, skipped the corner cells but cost
        // more per row than it saved: docs/performance.md.)
        const CellBox b = boxAround(p, radius);
        if (b.x0 > b.x1) return;
        for (int y = b.y0; y <= b.y1; ++y) {
            const int row = y * nx_;
            const int end = cellStart_[row + b.x1 + 1];
            for (int k = cellStart_[row + b.x0]; k < end; ++k) {
                const Vec2 d = sortedPosition<kCopies>(k) - p;
                f(sorted_[k], d, d.squaredNorm());
            }
        }
        return;
    }
    // Periodic: visit each distinct wrapped cell once, then use the minimum-image offset.
    // (With radius > half a period only the nearest image of each point is reported.)
    int cx, cy, sx, sy;
    periodicSpan(p, radius, cx, cy, sx, sy);
    for (int oy = 0; oy < sy; ++oy)
        for (int ox = 0; ox < sx; ++ox) {
            const int x = ((cx + ox) % nx_ + nx_) % nx_;
            const int y = ((cy + oy) % ny_ + ny_) % ny_;
            const int c = y * nx_ + x;
            for (int k = cellStart_[c]; k < cellStart_[c + 1]; ++k) {
                Vec2 d = sortedPosition<kCopies>(k) - p;
                d.x() -= width_ * std::round(d.x() / width_);
                d.y() -= height_ * std::round(d.y() / height_);
                f(sorted_[k], d, d.squaredNorm());
            }
        }
}

template <class F>
void PointGrid::forEachWithin(const Vec2& query, double radius, F&& f) const {
    const double r2 = radius * radius;
    forEachCandidate(query, radius, [&](int j, const Vec2& d, double d2) {
        if (d2 <= r2) f(j, d, d2);
    });
}

}  // namespace ch
