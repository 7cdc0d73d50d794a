// The neighbour grids return exactly the brute-force neighbour sets; the cell lookups' floor and
// the bounding boxes (core/geometry.h's Box) the grids and venues test before exact shapes.
#define BOOST_TEST_MODULE core_grid
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/rng.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <vector>

using namespace ch;

namespace {
std::vector<Vec2> randomPoints(int n, double lo, double hi, std::uint64_t seed) {
    Rng rng(seed);
    std::vector<Vec2> pts;
    for (int i = 0; i < n; ++i) pts.emplace_back(rng.uniform(lo, hi), rng.uniform(lo, hi));
    return pts;
}

Vec2 minimumImage(Vec2 d, double w, double h) {
    d.x() -= w * std::round(d.x() / w);
    d.y() -= h * std::round(d.y() / h);
    return d;
}
}  // namespace

BOOST_AUTO_TEST_CASE(planar_grid_matches_brute_force) {
    const auto pts = randomPoints(2000, -30, 30, 7);
    PointGrid grid;
    for (double cell : {0.7, 1.0, 5.0}) {
        grid.build(pts, cell);
        for (double radius : {0.5, 1.0, 2.5, 5.0}) {
            for (int q = 0; q < 200; q += 7) {
                std::vector<int> expected;
                for (int j = 0; j < static_cast<int>(pts.size()); ++j)
                    if ((pts[j] - pts[q]).squaredNorm() <= radius * radius) expected.push_back(j);
                BOOST_TEST(grid.within(pts[q], radius) == expected, "cell " << cell << " radius " << radius);
            }
        }
    }
}

BOOST_AUTO_TEST_CASE(negative_coordinates_use_floor_not_truncation) {
    // Points straddling zero: truncation would merge cells -1 and 0 and still find them, so
    // check the offsets and that a far point is not reported.
    std::vector<Vec2> pts = {{-0.1, -0.1}, {0.1, 0.1}, {-1.9, 0.0}, {3.0, 3.0}};
    PointGrid grid;
    grid.build(pts, 1.0);
    BOOST_TEST((grid.within({0, 0}, 0.5) == std::vector<int>{0, 1}));
    BOOST_TEST((grid.within({-1.0, 0.0}, 1.0) == std::vector<int>{0, 2}));
}

// The grids' cell lookups (and the navigation grid's probes) use floorToInt instead of
// std::floor: the same cell for every coordinate, the awkward ones included.
BOOST_AUTO_TEST_CASE(floor_to_int_is_floor_for_every_coordinate) {
    const double awkward[] = {0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 0.999999999999, -0.999999999999, 1e-300, -1e-300,
                              std::nextafter(1.0, 0.0), std::nextafter(-1.0, 0.0), std::nextafter(-1.0, -2.0),
                              4503599627370495.5 / 4503599627370496.0 * 1e6, -2147483647.5, -2147483648.0,
                              2147483647.0, 2147483647.75, 123456.0, -123456.0, -123456.000001};
    for (double x : awkward) BOOST_TEST(floorToInt(x) == static_cast<int>(std::floor(x)), "x = " << x);
    Rng rng(7);
    for (int k = 0; k < 100000; ++k) {
        const double x = rng.uniform(-3000.0, 3000.0) * (k % 2 ? 1.0 : 1e-3);
        BOOST_TEST_REQUIRE(floorToInt(x) == static_cast<int>(std::floor(x)), "x = " << x);
        const double whole = std::round(x);  // exact integers and their neighbours in both directions
        BOOST_TEST_REQUIRE(floorToInt(whole) == static_cast<int>(whole));
        BOOST_TEST_REQUIRE(floorToInt(std::nextafter(whole, -kInf)) == static_cast<int>(whole) - 1);
        BOOST_TEST_REQUIRE(floorToInt(std::nextafter(whole, kInf)) == static_cast<int>(whole));
    }
}

// Box: the quick test in front of a polygon's (venue exits, measurement areas, source areas) and
// of a line crossing (measurement lines). Closed on every side, and a point outside a polygon's
// box is outside the polygon.
BOOST_AUTO_TEST_CASE(boxes_hold_their_points_and_reject_the_rest) {
    const std::vector<Vec2> l = {{0, 0}, {4, 0}, {4, 1}, {1, 1}, {1, 3}, {0, 3}};  // an L
    const Box b = Box::around(l);
    BOOST_TEST((b.lo == Vec2(0, 0)));
    BOOST_TEST((b.hi == Vec2(4, 3)));
    BOOST_TEST(Box().empty());
    BOOST_TEST(!Box().contains(Vec2(0, 0)));
    BOOST_TEST(!b.empty());
    for (const Vec2& corner : {Vec2(0, 0), Vec2(4, 0), Vec2(4, 3), Vec2(0, 3)}) BOOST_TEST(b.contains(corner));
    for (const Vec2& out : {Vec2(-1e-12, 1), Vec2(4 + 1e-12, 1), Vec2(2, -1e-12), Vec2(2, 3 + 1e-12)})
        BOOST_TEST(!b.contains(out));
    BOOST_TEST(!b.contains(Vec2(std::nan(""), 1)));
    // Corners given in any order span the same box; grown widens every side.
    const Box s(Vec2(3, -1), Vec2(-2, 5));
    BOOST_TEST((s.lo == Vec2(-2, -1)));
    BOOST_TEST((s.hi == Vec2(3, 5)));
    const Box g = b.grown(0.5);
    BOOST_TEST((g.lo == Vec2(-0.5, -0.5)));
    BOOST_TEST((g.hi == Vec2(4.5, 3.5)));
    // Overlap: sharing an edge counts, a gap on either axis does not, and it is symmetric.
    const Box right(Vec2(4, 2), Vec2(6, 5)), apartX(Vec2(4.001, 0), Vec2(6, 1)), apartY(Vec2(1, 3.001), Vec2(2, 4));
    const Box inside(Vec2(1, 1), Vec2(2, 2)), across(Vec2(-1, 1), Vec2(5, 2));
    for (const auto& [o, meet] : {std::pair{right, true}, {apartX, false}, {apartY, false}, {inside, true}, {across, true}}) {
        BOOST_TEST(b.overlaps(o) == meet);
        BOOST_TEST(o.overlaps(b) == meet);
    }
    // The box never rejects a point of its polygon.
    Rng rng(11);
    for (int k = 0; k < 20000; ++k) {
        const Vec2 p(rng.uniform(-1.0, 5.0), rng.uniform(-1.0, 4.0));
        if (pointInPolygon(p, l)) BOOST_TEST_REQUIRE(b.contains(p));
    }
}

BOOST_AUTO_TEST_CASE(toric_grid_finds_neighbours_across_the_border) {
    const double w = 20, h = 12;
    auto pts = randomPoints(800, -0.5, 0.5, 11);
    for (Vec2& p : pts) p = Vec2(p.x() * w, p.y() * h);  // spread over [-w/2, w/2) × [-h/2, h/2)
    PointGrid grid;
    grid.build(pts, 2.0, true, w, h);
    int acrossBorder = 0;
    for (int q = 0; q < static_cast<int>(pts.size()); q += 3) {
        const double radius = 2.0;
        std::vector<int> expected;
        for (int j = 0; j < static_cast<int>(pts.size()); ++j) {
            const Vec2 d = minimumImage(pts[j] - pts[q], w, h);
            if (d.squaredNorm() <= radius * radius) {
                expected.push_back(j);
                if ((pts[j] - pts[q]).norm() > radius) ++acrossBorder;
            }
        }
        BOOST_TEST(grid.within(pts[q], radius) == expected);
        // The reported offsets are the minimum-image vectors.
        grid.forEachWithin(pts[q], radius, [&](int j, const Vec2& d, double) {
            BOOST_TEST((d - minimumImage(pts[j] - pts[q], w, h)).norm() < 1e-12);
        });
    }
    BOOST_TEST(acrossBorder > 0, "the random set must contain pairs that are neighbours only across the border");
}

BOOST_AUTO_TEST_CASE(toric_grid_with_cells_smaller_than_the_radius) {
    // The simulation's grid has cells half the neighbourhood radius for short ranges
    // (Simulation::stepGridCell), so a query spans several cells each way, also across the border.
    for (const auto& [w, h] : {std::pair{20.0, 12.0}, std::pair{4.0, 3.0}}) {
        auto pts = randomPoints(600, -0.5, 0.5, 13);
        for (Vec2& p : pts) p = Vec2(p.x() * w, p.y() * h);
        PointGrid grid;
        for (double cell : {0.5, 0.7}) {
            grid.build(pts, cell, true, w, h);
            for (double radius : {1.0, 1.3}) {
                for (int q = 0; q < static_cast<int>(pts.size()); q += 5) {
                    std::vector<int> expected;
                    for (int j = 0; j < static_cast<int>(pts.size()); ++j)
                        if (minimumImage(pts[j] - pts[q], w, h).squaredNorm() <= radius * radius) expected.push_back(j);
                    BOOST_TEST(grid.within(pts[q], radius) == expected,
                               "torus " << w << " x " << h << " cell " << cell << " radius " << radius);
                    BOOST_TEST(grid.candidateCount(pts[q], radius) >= expected.size());
                }
            }
        }
    }
}

BOOST_AUTO_TEST_CASE(far_flung_points_do_not_explode_memory) {
    // UMANS examples put goals 50 km away; agents walking there spread the bounding box.
    std::vector<Vec2> pts = {{0, 0}, {0.5, 0}, {50000, 3}, {50000.4, 3}};
    PointGrid grid;
    grid.build(pts, 0.1);
    BOOST_TEST((grid.within({0, 0}, 1.0) == std::vector<int>{0, 1}));
    BOOST_TEST((grid.within({50000, 3}, 1.0) == std::vector<int>{2, 3}));
}

namespace {
/// `count` segments starting uniformly in [−extent, extent]², each end within `span` of its start.
std::vector<Segment> randomSegments(Rng& rng, int count, double extent, double span) {
    std::vector<Segment> segs;
    for (int k = 0; k < count; ++k) {
        Vec2 a(rng.uniform(-extent, extent), rng.uniform(-extent, extent));
        Vec2 b = a + Vec2(rng.uniform(-span, span), rng.uniform(-span, span));
        segs.push_back(Segment{a, b, k});
    }
    return segs;
}
/// The segments within r of p by brute force, ascending: what SegmentGrid::near must give.
std::vector<int> segmentsWithin(const std::vector<Segment>& segs, const Vec2& p, double r) {
    std::vector<int> out;
    for (int k = 0; k < static_cast<int>(segs.size()); ++k)
        if (distanceToSegmentSquared(p, segs[k].a, segs[k].b) <= r * r) out.push_back(k);
    return out;
}
}  // namespace

BOOST_AUTO_TEST_CASE(segment_grid_matches_brute_force) {
    Rng rng(3);
    const std::vector<Segment> segs = randomSegments(rng, 300, 20, 6);
    SegmentGrid grid;
    grid.build(segs, 2.0);
    std::vector<int> got;
    for (int q = 0; q < 200; ++q) {
        const Vec2 p(rng.uniform(-25, 25), rng.uniform(-25, 25));
        const double r = rng.uniform(0.1, 4.0);
        grid.near(p, r, got);
        BOOST_TEST(got == segmentsWithin(segs, p, r));
    }
}

BOOST_AUTO_TEST_CASE(box_index_lists_every_box_holding_a_point) {
    // BoxIndex::at(p) must list (ascending, each once) every box holding p, wherever p is in its
    // cell: boxes of all sizes, one far larger than the cells (the index then coarsens its cells),
    // boxes that touch at an edge, a degenerate box (a point) and boxes it must leave out.
    Rng rng(11);
    std::vector<Box> boxes;
    for (int k = 0; k < 400; ++k) {
        const Vec2 a(rng.uniform(-40, 40), rng.uniform(-40, 40));
        boxes.emplace_back(a, a + Vec2(rng.uniform(0, 3), rng.uniform(0, 3)));
    }
    boxes.emplace_back(Vec2(-39, -38), Vec2(39, 41));   // most of the scene
    boxes.emplace_back(Vec2(2, 2), Vec2(4, 2.5));        // touching the next one at x = 4
    boxes.emplace_back(Vec2(4, 2), Vec2(6, 2.5));
    boxes.emplace_back(Vec2(1.5, -7.25), Vec2(1.5, -7.25));  // a point
    boxes.emplace_back();                                     // empty: left out
    boxes.emplace_back(Vec2(0, 0), Vec2(std::numeric_limits<double>::infinity(), 1));  // not finite: left out
    for (const double cell : {0.5, 2.0, 7.0}) {
        BoxIndex index;
        index.build(boxes, cell);
        std::vector<Vec2> points;
        for (int q = 0; q < 20000; ++q) points.emplace_back(rng.uniform(-45, 45), rng.uniform(-45, 45));
        // Corners and edges, where a cell boundary may fall.
        for (const Box& b : boxes)
            if (!b.empty() && b.hi.allFinite())
                for (const Vec2& c : {b.lo, b.hi, Vec2(b.lo.x(), b.hi.y()), Vec2(b.hi.x(), b.lo.y())}) points.push_back(c);
        for (const Vec2& p : points) {
            const std::span<const int> listed = index.at(p);
            BOOST_TEST(std::is_sorted(listed.begin(), listed.end()));
            BOOST_TEST((std::adjacent_find(listed.begin(), listed.end()) == listed.end()));
            for (std::size_t k = 0; k < boxes.size(); ++k) {
                if (!boxes[k].contains(p)) continue;
                const bool in = std::find(listed.begin(), listed.end(), static_cast<int>(k)) != listed.end();
                BOOST_TEST((in || !boxes[k].hi.allFinite()), "box " << k << " missed at (" << p.x() << ", " << p.y() << ")");
            }
            for (const int k : listed) BOOST_TEST(boxes[static_cast<std::size_t>(k)].hi.allFinite());
        }
        // Far and not-finite points: nothing, no crash.
        BOOST_TEST(index.at(Vec2(1e300, 0)).empty());
        BOOST_TEST(index.at(Vec2(std::nan(""), 0)).empty());
        BOOST_TEST(index.at(Vec2(-1e300, -1e300)).empty());
    }
    BoxIndex none;
    none.build({}, 2.0);
    BOOST_TEST(none.at(Vec2(0, 0)).empty());
    // Twenty boxes of 1 km²: in 0.5 m cells that is 80 million entries. The index coarsens its
    // cells until there are at most 2^22 (plus one per box): 4 m cells, 1.25 million entries.
    std::vector<Box> huge(20, Box(Vec2(0, 0), Vec2(1000, 1000)));
    BoxIndex coarse;
    coarse.build(huge, 0.5);
    BOOST_TEST(coarse.cellSize() == 4.0);
    BOOST_TEST(coarse.at(Vec2(999.9, 0.1)).size() == 20u);
}

BOOST_AUTO_TEST_CASE(segment_grid_readied_for_a_range_matches_brute_force) {
    // After prepare(range), queries of a radius in [¾ range, range] read one list per point;
    // every radius must still find exactly the segments within it, ascending: at random points,
    // next to the segments' ends (where the widened bounds end) and far away.
    Rng rng(4);
    std::vector<Segment> segs = randomSegments(rng, 300, 20, 6);
    segs.push_back(Segment{Vec2(-30, -22), Vec2(30, -22), 300});  // a long wall
    SegmentGrid grid;
    grid.build(segs, 2.0);
    grid.prepare(5.0);
    grid.prepare(1.0);
    grid.prepare(5.0);  // again: nothing more
    std::vector<Vec2> points;
    for (int q = 0; q < 3000; ++q) points.emplace_back(rng.uniform(-40, 40), rng.uniform(-40, 40));
    for (const Segment& s : segs)
        for (const Vec2& end : {s.a, s.b})
            for (const double r : {1.0, 5.0})
                for (const Vec2& d : {Vec2(r, 0), Vec2(-r, 0), Vec2(0, r), Vec2(0, -r), Vec2(0.7 * r, 0.7 * r)})
                    points.push_back(end + d);
    points.emplace_back(1e6, 0);
    points.emplace_back(std::nan(""), 0);
    std::vector<int> got;
    for (const Vec2& p : points)
        for (const double r : {5.0, 4.9999999, 3.75, 3.7, 1.0, 0.8, 0.5, 2.0, 5.3, 6.0}) {
            grid.near(p, r, got);
            BOOST_TEST(got == segmentsWithin(segs, p, r), "r " << r << " at (" << p.x() << ", " << p.y() << ")");
        }
}

BOOST_AUTO_TEST_CASE(clamp_unit_is_std_clamp_bit_for_bit_and_nearest_points_are_exact) {
    // clampUnit replaces std::clamp(v, 0, 1) in every wall distance without a branch: it must give
    // the same bits, signed zeros, infinities, NaN and the neighbours of 0 and 1 included.
    const double inf = std::numeric_limits<double>::infinity(), tiny = std::numeric_limits<double>::denorm_min();
    for (const double v : {-2.0, -1e-300, -tiny, -0.0, 0.0, tiny, 1e-300, 0.25, std::nextafter(1.0, 0.0), 1.0,
                           std::nextafter(1.0, 2.0), 3.0, inf, -inf, std::nan("")}) {
        const double got = clampUnit(v), want = std::clamp(v, 0.0, 1.0);
        std::uint64_t a = 0, b = 0;
        std::memcpy(&a, &got, sizeof a);
        std::memcpy(&b, &want, sizeof b);
        BOOST_TEST(a == b, "v = " << v << ": " << got << " against " << want);
    }
    // The nearest point: before the start, past the end, in between, and on a degenerate segment.
    const Vec2 a(1, 1), b(5, 1);
    BOOST_TEST((closestPointOnSegment(Vec2(-2, 3), a, b) - a).norm() == 0.0);
    BOOST_TEST((closestPointOnSegment(Vec2(9, -4), a, b) - b).norm() == 0.0);
    BOOST_TEST((closestPointOnSegment(Vec2(2, 7), a, b) - Vec2(2, 1)).norm() == 0.0);
    BOOST_TEST(distanceToSegmentSquared(Vec2(2, 7), a, b) == 36.0);
    BOOST_TEST(distanceToSegmentSquared(Vec2(4, 5), a, a) == 25.0);
}

BOOST_AUTO_TEST_CASE(segment_grid_readied_lists_drop_and_keep_whole_cells_exactly) {
    // prepare(range) drops from a cell's list the segments beyond range of the whole cell and
    // marks those within range of all of it, which a query of radius = range then takes without
    // a test. Every point of a fine lattice (ten per cell side at 5 m, so both sides of each
    // cell's limits) must still get exactly the segments within the radius, here and far from
    // the origin, where the rounding margins are larger. (One check per scene: some 400,000
    // queries, which Boost.Test's checks one by one would slow tenfold under the sanitizers.)
    for (const Vec2& shift : {Vec2(0, 0), Vec2(1e5, -3e5)}) {
        Rng rng(11);
        std::vector<Segment> segs = randomSegments(rng, 60, 10, 4);
        segs.push_back(Segment{Vec2(-12, 9), Vec2(12, 9.5), 60});  // a long wall
        for (Segment& s : segs) s.a += shift, s.b += shift;
        SegmentGrid grid;
        grid.build(segs, 2.0);
        grid.prepare(5.0);
        grid.prepare(2.0);
        std::vector<int> got;
        int wrong = 0;
        std::string first;
        for (double y = -16; y <= 16; y += 0.125)
            for (double x = -16; x <= 16; x += 0.125) {
                const Vec2 p = shift + Vec2(x, y);
                for (const double r : {5.0, 4.5, 2.0}) {
                    grid.near(p, r, got);
                    if (got == segmentsWithin(segs, p, r)) continue;
                    if (wrong++ == 0)
                        first = "r " + std::to_string(r) + " at (" + std::to_string(x) + ", " + std::to_string(y) + ")";
                }
            }
        BOOST_TEST(wrong == 0, "shift " << shift.x() << ": first wrong answer " << first);
    }
}

BOOST_AUTO_TEST_CASE(segment_clearance_is_a_close_lower_bound) {
    // SegmentGrid::near answers "nothing within radius" from a raster of lower bounds of the
    // distance to the walls without scanning: the bound must never exceed the true distance (or
    // near() would miss a wall), and it must be close to it (or it saves nothing): within one
    // raster cell's diagonal (0.5 m cells here: the bound is the distance from the centre of the
    // point's cell less half a diagonal) away from the walls, 0 beyond the raster.
    Rng rng(5);
    std::vector<Segment> segs = randomSegments(rng, 40, 15, 4);
    segs.push_back(Segment{Vec2(-15, -16), Vec2(15, -16), 40});  // a long wall
    SegmentGrid grid;
    grid.build(segs, 2.0);
    const auto trueDistance = [&](const Vec2& p) {
        double d2 = std::numeric_limits<double>::infinity();
        for (const Segment& s : segs) d2 = std::min(d2, distanceToSegmentSquared(p, s.a, s.b));
        return std::sqrt(d2);
    };
    std::vector<int> got;
    int farEnough = 0;
    for (int q = 0; q < 20000; ++q) {
        const Vec2 p(rng.uniform(-24, 24), rng.uniform(-26, 24));
        const double d = trueDistance(p), c = grid.clearance(p);
        BOOST_TEST(c <= d, "p = (" << p.x() << ", " << p.y() << ")");
        BOOST_TEST(c >= 0);
        if (d < SegmentGrid::kClearanceReach - 0.5) {
            BOOST_TEST(c >= d - std::sqrt(2.0) * 0.5 - 1e-5, "c " << c << " d " << d << " p = (" << p.x() << ", " << p.y() << ")");
            ++farEnough;
        }
        // Radii on both sides of the true distance: near() keeps exactly the walls within reach.
        for (const double r : {d - 1e-9, d, d + 1e-9, 0.5 * d, c, c + 0.01}) {
            if (!(r >= 0)) continue;
            grid.near(p, r, got);
            BOOST_TEST(got == segmentsWithin(segs, p, r));
        }
    }
    BOOST_TEST(farEnough > 10000);
    // Beyond the raster (the walls' bounds and its reach) nothing is known.
    BOOST_TEST(grid.clearance(Vec2(200, 0)) == 0.0);
    BOOST_TEST(grid.clearance(Vec2(std::nan(""), 0)) == 0.0);
    // A single far wall: a point 3 m from it has a bound between 3 − 0.71 and 3.
    SegmentGrid one;
    const std::vector<Segment> wall = {Segment{Vec2(0, 0), Vec2(10, 0), 0}};
    one.build(wall, 2.0);
    for (double x = 0.05; x < 10; x += 0.37) {
        const double c = one.clearance(Vec2(x, 3.0));
        BOOST_TEST(c <= 3.0);
        BOOST_TEST(c > 3.0 - 0.71);
        one.near(Vec2(x, 3.0), 2.9, got);
        BOOST_TEST(got.empty());
        one.near(Vec2(x, 3.0), 3.0, got);
        BOOST_TEST(got == std::vector<int>{0});
    }
}

BOOST_AUTO_TEST_CASE(grid_built_on_two_threads_is_the_serial_one) {
    // The counting sort runs on the team for crowds (parallelCheapLoop; ctest sets
    // CROWDHEALTH_PARALLEL_MIN_AGENTS=1 so these small sets take that path): the points' order,
    // hence every query's visit order, must be the serial sort's (stable: ascending within a cell).
    const auto pts = randomPoints(3000, -20, 20, 11);
    for (const bool periodic : {false, true}) {
        for (const double cell : {0.5, 1.3}) {
            std::vector<std::vector<int>> order(2), visits(2);
            for (int threads = 1; threads <= 2; ++threads) {
                omp_set_num_threads(threads);
                PointGrid grid;
                grid.build(pts, cell, periodic, 40.0, 40.0);
                order[threads - 1] = grid.order();
                for (int q = 0; q < 3000; q += 37)
                    grid.forEachWithin(pts[q], 1.7, [&](int j, const Vec2&, double) { visits[threads - 1].push_back(j); });
            }
            omp_set_num_threads(2);
            BOOST_TEST(order[0] == order[1], "periodic " << periodic << " cell " << cell);
            BOOST_TEST(visits[0] == visits[1], "periodic " << periodic << " cell " << cell);
            BOOST_TEST(visits[0].size() > 1000u);
            // And the order is a permutation of the points (each listed once).
            std::vector<int> sorted = order[0];
            std::sort(sorted.begin(), sorted.end());
            for (int i = 0; i < 3000; ++i) BOOST_TEST_REQUIRE(sorted[static_cast<std::size_t>(i)] == i);
        }
    }
}

BOOST_AUTO_TEST_CASE(grid_bounds_found_on_two_threads_are_the_serial_ones) {
    // A plane grid's cells start at the points' lower bounds, which a crowd's build finds on the
    // team, each thread over its chunk (issue 20). The serial rule, NaN included: bounds start at
    // points[0] and a NaN coordinate is passed over, unless points[0] has it (then the grid is one
    // cell). Every case below must give the serial grid: the same order and the same candidates,
    // so the same cells.
    const double nan = std::nan("");
    std::vector<std::pair<const char*, std::vector<Vec2>>> cases;
    const auto base = randomPoints(3000, -20, 20, 31);
    cases.emplace_back("random", base);
    auto lowLast = base;  // the lowest point in the last thread's chunk, after a NaN opening it
    lowLast[1500] = Vec2(nan, nan);
    lowLast[2999] = Vec2(-25.3, -24.1);
    cases.emplace_back("lowest last, NaN first of the second chunk", lowLast);
    auto highLast = base;
    highLast[2999] = Vec2(26.7, 23.9);
    highLast[1700] = Vec2(nan, 3.0);
    cases.emplace_back("highest last, NaN x in the second chunk", highLast);
    auto nanFirst = base;
    nanFirst[0] = Vec2(nan, 0.3);
    cases.emplace_back("NaN x at points[0]", nanFirst);
    std::vector<std::vector<std::size_t>> serialCandidates;
    for (const auto& [name, pts] : cases) {
        // The bounds by the rule, worked out here one point after the other.
        Vec2 lo = pts[0], hi = pts[0];
        for (const Vec2& p : pts) {
            if (p.x() < lo.x()) lo.x() = p.x();
            if (p.y() < lo.y()) lo.y() = p.y();
            if (p.x() > hi.x()) hi.x() = p.x();
            if (p.y() > hi.y()) hi.y() = p.y();
        }
        const bool finite = std::isfinite(lo.x()) && std::isfinite(lo.y());
        std::vector<int> order[2];
        std::vector<std::size_t> candidates[2];
        for (int threads = 1; threads <= 2; ++threads) {
            omp_set_num_threads(threads);
            PointGrid grid;
            grid.build(pts, 0.7);
            order[threads - 1] = grid.order();
            for (double x = -26; x <= 27; x += 1.3)
                for (double y = -25; y <= 25; y += 2.9) candidates[threads - 1].push_back(grid.candidateCount(Vec2(x, y), 0.9));
            BOOST_TEST((finite ? grid.origin() == lo : std::isnan(grid.origin().x())), name << ", " << threads << " threads");
            if (finite) {
                BOOST_TEST(grid.cellsX() == static_cast<int>(std::floor((hi.x() - lo.x()) / 0.7)) + 1, name);
                BOOST_TEST(grid.cellsY() == static_cast<int>(std::floor((hi.y() - lo.y()) / 0.7)) + 1, name);
            } else {
                BOOST_TEST(grid.cellsX() * grid.cellsY() == 1, name);  // a NaN extent: one cell
            }
        }
        omp_set_num_threads(2);
        BOOST_TEST(order[0] == order[1], name);
        BOOST_TEST(candidates[0] == candidates[1], name);
        serialCandidates.push_back(candidates[0]);
    }
    // The cases are four grids: each extreme point (or the NaN at points[0]) moved the cells.
    for (std::size_t k = 1; k < serialCandidates.size(); ++k) BOOST_TEST((serialCandidates[k] != serialCandidates[0]), cases[k].first);
}

BOOST_AUTO_TEST_CASE(grid_without_its_copy_of_the_positions_makes_the_same_calls) {
    // keepPositions(false): queries read the points through order() instead of the grid's copy,
    // with the same calls (index, offset, squared distance, to the bit) in the same order, on a
    // plane and on a torus, on one thread and two; and a grid built again with the copy has it.
    const auto pts = randomPoints(3000, -20, 20, 23);
    struct Call {
        int j;
        double dx, dy, d2;
        bool operator==(const Call& o) const { return j == o.j && dx == o.dx && dy == o.dy && d2 == o.d2; }
    };
    for (const bool periodic : {false, true})
        for (int threads = 1; threads <= 2; ++threads) {
            omp_set_num_threads(threads);
            std::vector<Call> calls[2];
            PointGrid grid;
            for (const bool keep : {true, false}) {
                grid.keepPositions(keep);
                grid.build(pts, 1.0, periodic, 40.0, 40.0);
                BOOST_TEST(grid.sortedX().size() == (keep ? pts.size() : 0u));
                for (int q = 0; q < 3000; q += 29)
                    grid.forEachCandidate(pts[q] + Vec2(0.01, -0.02), 1.4, [&](int j, const Vec2& d, double d2) {
                        calls[keep ? 0 : 1].push_back(Call{j, d.x(), d.y(), d2});
                    });
            }
            BOOST_TEST(calls[0].size() > 2000u);
            BOOST_TEST((calls[0] == calls[1]), "periodic " << periodic << ", " << threads << " threads");
            grid.keepPositions(true);
            grid.build(pts, 1.0, periodic, 40.0, 40.0);
            BOOST_TEST(grid.sortedX().size() == pts.size());
        }
    omp_set_num_threads(2);
}
