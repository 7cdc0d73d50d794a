// The walkable grid and the fast-marching distance fields (crowdhealth/navigation/field.h):
// shortest path lengths on shapes with known answers, paths along −∇T with a clearance, walls
// never crossed, unreachable places, determinism.
#define BOOST_TEST_MODULE navigation_field
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/world.h"
#include "crowdhealth/navigation/field.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

using namespace ch;

namespace {

ObstacleSpec box(double x0, double y0, double x1, double y1) {
    ObstacleSpec o;
    o.points = {Vec2(x0, y0), Vec2(x1, y0), Vec2(x1, y1), Vec2(x0, y1)};
    return o;
}
ObstacleSpec wall(const Vec2& a, const Vec2& b) {
    ObstacleSpec o;
    o.points = {a, b};
    return o;
}
TargetShape pointTarget(const Vec2& p, double radius = 0) {
    TargetShape t;
    t.kind = TargetShape::Kind::Point;
    t.point = p;
    t.radius = radius;
    return t;
}
WalkableGridSettings settings(double cell, double clearance = 0, double minSpeed = 0.2) {
    WalkableGridSettings s;
    s.cellSize = cell;
    s.clearance = clearance;
    s.minSpeed = minSpeed;
    return s;
}

/// A scene with known shortest path lengths: T at each query must equal the exact length.
struct Known {
    const char* name;
    std::vector<ObstacleSpec> obstacles;
    Vec2 lo, hi;
    Vec2 target;
    std::vector<std::pair<Vec2, double>> queries;  // point, exact path length
};

double len(const Vec2& a, const Vec2& b) { return (a - b).norm(); }

std::vector<Known> knownScenes() {
    std::vector<Known> scenes;
    {
        // Free space: a point source, queries at 10–50 m in many directions (axis, diagonal, others).
        Known k{"free space", {}, Vec2(-52, -52), Vec2(52, 52), Vec2(0.03, -0.07), {}};
        for (double r : {10.0, 25.0, 50.0})
            for (double deg : {0.0, 22.5, 30.0, 45.0, 60.0, 90.0, 135.0, 200.0, 315.0}) {
                const Vec2 q = k.target + r * Vec2(std::cos(deg * kPi / 180), std::sin(deg * kPi / 180));
                k.queries.push_back({q, r});
            }
        scenes.push_back(k);
    }
    {
        // A square pillar [-2, 2]²: paths are straight segments touching its corners.
        Known k{"square pillar", {box(-2, -2, 2, 2)}, Vec2(-15, -12), Vec2(15, 12), Vec2(-10, 0), {}};
        const Vec2 a(2, 2), b(-2, 2), c(2, -2), d(-2, -2), t(-10, 0);
        k.queries.push_back({Vec2(10, 0), len(Vec2(10, 0), a) + 4 + len(b, t)});
        k.queries.push_back({Vec2(6, -1), len(Vec2(6, -1), c) + 4 + len(d, t)});
        k.queries.push_back({Vec2(3, 0.5), len(Vec2(3, 0.5), a) + 4 + len(b, t)});
        k.queries.push_back({Vec2(1, 2.3), len(Vec2(1, 2.3), b) + len(b, t)});
        k.queries.push_back({Vec2(10, 6), len(Vec2(10, 6), t)});  // in sight
        scenes.push_back(k);
    }
    {
        // An L corridor 4 m wide: the bottom strip y ∈ [0, 4] and the right strip x ∈ [16, 20];
        // paths bend round the inner corner (16, 4).
        Known k{"L corridor", {box(-1, 4, 16, 21)}, Vec2(0, 0), Vec2(20, 20), Vec2(2, 2), {}};
        const Vec2 c(16, 4), t(2, 2);
        for (const Vec2& q : {Vec2(18, 18), Vec2(18, 10), Vec2(17, 19), Vec2(19.5, 6)})
            k.queries.push_back({q, len(t, c) + len(c, q)});
        k.queries.push_back({Vec2(19, 1), len(t, Vec2(19, 1))});
        scenes.push_back(k);
    }
    {
        // A U-turn round the end (0, 10) of a thin wall reaching the bottom of the grid.
        Known k{"U-turn", {wall(Vec2(0, -30), Vec2(0, 10))}, Vec2(-10, -20), Vec2(10, 20), Vec2(-3, 0), {}};
        const Vec2 e(0, 10), t(-3, 0);
        for (const Vec2& q : {Vec2(3, 0), Vec2(1, -15), Vec2(6, 8), Vec2(0.5, 9.0)})
            k.queries.push_back({q, len(t, e) + len(e, q)});
        k.queries.push_back({Vec2(-5, 15), len(t, Vec2(-5, 15))});
        scenes.push_back(k);
    }
    return scenes;
}

/// Largest |T − exact|, largest relative error and most negative error over a scene at one cell size.
struct Error {
    double abs = 0, rel = 0, lowest = 0;  // lowest: the most negative T − exact (T below the true length)
};

Error measure(const Known& k, double cell, double relTol, double cellsTol, bool check) {
    const World world(WorldSpec{}, k.obstacles);
    const WalkableGrid grid(world, settings(cell), k.lo, k.hi);
    const DistanceField field(grid, pointTarget(k.target));
    BOOST_TEST_REQUIRE(field.seeded());
    Error e;
    for (const auto& [q, exact] : k.queries) {
        const double t = field.distance(q);
        const double err = t - exact;
        e.abs = std::max(e.abs, std::abs(err));
        e.rel = std::max(e.rel, std::abs(err) / exact);
        e.lowest = std::min(e.lowest, err);
        if (check)
            BOOST_TEST(std::abs(err) <= relTol * exact + cellsTol * cell,
                       k.name << " h " << cell << " at (" << q.x() << ", " << q.y() << "): T " << t << " exact "
                              << exact);
    }
    return e;
}

}  // namespace

// Tolerance: 1 % of the length + 4 cells. At clearance 0 the walls are inflated: a walkable cell
// centre is at least half a cell diagonal from a wall and in practice the nearest ones are 1–1.5
// cells away, so a path bending by θ rad round a corner is longer by about 1.3 cells per rad
// (measured: 3.2 cells for the U-turn, θ = 2.56, at every cell size 0.05–0.4). Measured errors
// (printed with --log_level=message) are listed at the top of Library/src/navigation/field.cpp.
BOOST_AUTO_TEST_CASE(path_lengths_match_known_shortest_paths) {
    for (const Known& k : knownScenes())
        for (double cell : {0.1, 0.2, 0.4}) {
            const Error e = measure(k, cell, 0.01, 4.0, cell <= 0.2);
            BOOST_TEST_MESSAGE(k.name << " h " << cell << ": max |err| " << e.abs << " m (" << e.abs / cell
                                      << " cells), max rel " << e.rel << ", most below " << e.lowest);
        }
}

// Free space is where the second-order stencil shows: within 0.4 cell of the exact distance at
// 10–50 m (measured 0.33 cell; the error comes from the first cells round the source and does not
// grow with the distance). First order alone is off by more on the diagonals.
// The source anywhere in its cell: off the lattice, on a cell corner (two equal cells either side,
// where a one-sided second-order stencil across the source would be wrong) and on a cell centre.
BOOST_AUTO_TEST_CASE(free_space_is_second_order_accurate) {
    for (const Vec2& source : {Vec2(0.03, -0.07), Vec2(0, 0), Vec2(0.1, 0.1)}) {
        Known k = knownScenes()[0];
        for (auto& [q, exact] : k.queries) q += source - k.target;
        k.target = source;
        const Error e = measure(k, 0.2, 0.0, 0.4, true);
        BOOST_TEST_MESSAGE("free space h 0.2, source (" << source.x() << ", " << source.y() << "): max |err| " << e.abs);
    }
}

BOOST_AUTO_TEST_CASE(thin_diagonal_wall_is_not_leaked_through) {
    // Walls at 45° and at a shallow slope: the far side is reached round the wall's end only.
    for (const Vec2& dirEnd : {Vec2(10, 10), Vec2(12, 5)}) {
        const Vec2 a = -dirEnd, b = dirEnd;
        const World world(WorldSpec{}, {wall(a, b)});
        for (double cell : {0.1, 0.2, 0.37}) {
            const WalkableGrid grid(world, settings(cell), Vec2(-14, -14), Vec2(14, 14));
            const Vec2 n = Vec2(dirEnd.y(), -dirEnd.x()).normalized();  // normal
            const Vec2 t = 4.0 * n, q = -4.0 * n;                       // either side of the middle
            const DistanceField field(grid, pointTarget(t));
            const double exact = len(t, b) + len(b, q);  // round either end (symmetric)
            BOOST_TEST(std::abs(field.distance(q) - exact) <= 0.01 * exact + 4.0 * cell,
                       "wall to " << b.x() << "," << b.y() << " h " << cell << ": T " << field.distance(q)
                                  << " exact " << exact);
            BOOST_TEST(grid.component(0, 0) == grid.component(grid.nx() - 1, grid.ny() - 1));
        }
    }
}

namespace {

/// Walks from p along direction() in Euler steps of 2 cm; checks every position stays on walkable
/// cells and sets `closest` to the least distance to any of `corners`. True when the target is reached.
bool walk(const DistanceField& field, const TargetShape& target, Vec2 p, const std::vector<Vec2>& corners,
          double& closest) {
    const double step = 0.02;
    closest = kInf;
    for (int k = 0; k < 20000; ++k) {
        if (target.contains(p)) return true;
        const Vec2 d = field.direction(p);
        if (d.isZero()) return false;
        BOOST_TEST(std::abs(d.norm() - 1) < 1e-9);
        p += step * d;
        if (!field.grid().walkable(p)) {
            BOOST_TEST(false, "entered a blocked cell at (" << p.x() << ", " << p.y() << ")");
            return false;
        }
        for (const Vec2& c : corners) closest = std::min(closest, len(p, c));
    }
    return false;
}

}  // namespace

BOOST_AUTO_TEST_CASE(walking_down_the_gradient_rounds_corners_with_clearance) {
    const double clearance = 0.5, cell = 0.2;
    // A thick wall with corners (0, 0) and (1, 0), and a thin wall ending at (0, 0).
    struct Scene {
        std::vector<ObstacleSpec> obstacles;
        std::vector<Vec2> corners;
        Vec2 start, goal;
    };
    const std::vector<Scene> scenes = {
        {{box(0, -20, 1, 0)}, {Vec2(0, 0), Vec2(1, 0)}, Vec2(3, -4), Vec2(-3, -4)},
        {{box(0, -20, 1, 0)}, {Vec2(0, 0), Vec2(1, 0)}, Vec2(1.6, -0.8), Vec2(-0.6, -6)},  // start close to the wall
        {{wall(Vec2(0, -20), Vec2(0, 0))}, {Vec2(0, 0)}, Vec2(2, -3), Vec2(-2, -3)},
        {{wall(Vec2(0, -20), Vec2(0, 0))}, {Vec2(0, 0)}, Vec2(0.7, -0.3), Vec2(-0.7, -0.3)},  // tight U-turn
        {{wall(Vec2(-20, -20), Vec2(0, 0))}, {Vec2(0, 0)}, Vec2(0.5, -3), Vec2(-3, 0.5)},  // diagonal wall end
    };
    for (const Scene& s : scenes) {
        const World world(WorldSpec{}, s.obstacles);
        const WalkableGrid grid(world, settings(cell, clearance, 0.2), Vec2(-8, -12), Vec2(8, 6));
        const TargetShape target = pointTarget(s.goal, 0.3);
        const DistanceField field(grid, target);
        double closest = kInf;
        BOOST_TEST(walk(field, target, s.start, s.corners, closest),
                   "start " << s.start.x() << "," << s.start.y());
        BOOST_TEST(closest >= 0.5 * clearance, "start " << s.start.x() << "," << s.start.y() << ": came within "
                                                        << closest << " m of the corner");
        BOOST_TEST_MESSAGE("corner clearance from " << s.start.x() << "," << s.start.y() << ": " << closest);
    }
}

BOOST_AUTO_TEST_CASE(direction_never_points_into_a_wall) {
    // Pillars, a thin diagonal wall and corridors; points sampled densely, including right next to
    // walls; a step of half a cell along direction() never enters a blocked cell (nor squeezes
    // between two blocked cells diagonally).
    const std::vector<ObstacleSpec> obstacles = {box(-2, -2, 2, 2), wall(Vec2(4, -6), Vec2(9, 5)),
                                                 box(-9, 3, -4, 3.3), wall(Vec2(-8, -8), Vec2(-3, -4)),
                                                 box(5, 6, 5.5, 9)};
    const World world(WorldSpec{}, obstacles);
    for (double clearance : {0.0, 0.5}) {
        const double cell = 0.2;
        const WalkableGrid grid(world, settings(cell, clearance), Vec2(-10, -10), Vec2(10, 10));
        const DistanceField field(grid, pointTarget(Vec2(-6, 8), 0.2));
        int bad = 0, checked = 0;
        for (double y = -9.9; y < 9.9; y += 0.047)
            for (double x = -9.9; x < 9.9; x += 0.047) {
                const Vec2 p(x, y);
                if (!grid.walkable(p)) continue;
                const Vec2 d = field.direction(p);
                if (d.isZero()) continue;
                ++checked;
                int ix, iy, qx, qy;
                grid.cellOf(p, ix, iy);
                const Vec2 q = p + 0.5 * cell * d;
                grid.cellOf(q, qx, qy);
                bool ok = grid.walkable(qx, qy);
                if (qx != ix && qy != iy) ok = ok && grid.walkable(qx, iy) && grid.walkable(ix, qy);
                if (!ok && ++bad <= 5)
                    BOOST_TEST_MESSAGE("into a wall at (" << x << ", " << y << ") dir " << d.x() << "," << d.y());
            }
        BOOST_TEST(bad == 0, bad << " of " << checked << " directions step into a wall (clearance " << clearance << ")");
        BOOST_TEST(checked > 50000);
    }
}

BOOST_AUTO_TEST_CASE(pressed_into_a_wall_the_direction_leads_out_along_the_path) {
    const World world(WorldSpec{}, {box(0, -20, 1, 0)});
    const WalkableGrid grid(world, settings(0.2, 0.5), Vec2(-6, -10), Vec2(6, 6));
    const DistanceField field(grid, pointTarget(Vec2(-3, -4), 0.3));
    const Vec2 p(1.05, -3);  // in the blocked band beside the wall's right face
    BOOST_TEST(!grid.walkable(p));
    const Vec2 d = field.direction(p);
    BOOST_TEST(d.norm() == 1.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(d.y() > 0.5);  // up along the wall, towards the corner to go round
    BOOST_TEST(std::isfinite(field.distance(p)));
}

BOOST_AUTO_TEST_CASE(target_inside_a_wall_is_not_seeded) {
    const World world(WorldSpec{}, {box(-3, -3, 3, 3)});
    const WalkableGrid grid(world, settings(0.2), Vec2(-10, -10), Vec2(10, 10));
    const DistanceField inside(grid, pointTarget(Vec2(0, 0), 0.5));
    BOOST_TEST(!inside.seeded());
    BOOST_TEST(std::isinf(inside.distance(Vec2(6, 6))));
    BOOST_TEST(inside.direction(Vec2(6, 6)).isZero());
    // A target touching the obstacle's face seeds the floor beside it.
    const DistanceField touching(grid, pointTarget(Vec2(3.05, 0), 0.1));
    BOOST_TEST(touching.seeded());
    BOOST_TEST(std::isfinite(touching.distance(Vec2(-6, -6))));
}

BOOST_AUTO_TEST_CASE(closed_room_is_unreachable_and_labelled_apart) {
    // A room [2, 8]² closed by four thin walls; the target outside it.
    const std::vector<ObstacleSpec> walls = {wall(Vec2(2, 2), Vec2(8, 2)), wall(Vec2(8, 2), Vec2(8, 8)),
                                             wall(Vec2(8, 8), Vec2(2, 8)), wall(Vec2(2, 8), Vec2(2, 2))};
    const World world(WorldSpec{}, walls);
    const WalkableGrid grid(world, settings(0.2, 0.3), Vec2(-5, -5), Vec2(12, 12));
    const DistanceField field(grid, pointTarget(Vec2(-3, -3)));
    BOOST_TEST(field.seeded());
    const Vec2 in(5, 5), out(10, 10);
    BOOST_TEST(std::isinf(field.distance(in)));
    BOOST_TEST(std::isfinite(field.distance(out)));
    BOOST_TEST(field.direction(in).isZero());
    int ax, ay, bx, by;
    grid.cellOf(in, ax, ay);
    grid.cellOf(out, bx, by);
    BOOST_TEST(grid.component(ax, ay) >= 0);
    BOOST_TEST(grid.component(bx, by) >= 0);
    BOOST_TEST(grid.component(ax, ay) != grid.component(bx, by));
    // Just inside the wall (a blocked cell): the nearest walkable cell is in the room or outside.
    BOOST_TEST(grid.componentNear(Vec2(2.3, 5), 0.5) == grid.component(ax, ay));
    BOOST_TEST(grid.componentNear(Vec2(1.7, 5), 0.5) == grid.component(bx, by));
    // A target inside the room: the outside is unreachable.
    const DistanceField room(grid, pointTarget(Vec2(4, 4)));
    BOOST_TEST(std::isfinite(room.distance(in)));
    BOOST_TEST(std::isinf(room.distance(out)));
}

BOOST_AUTO_TEST_CASE(planar_bounds_and_polygon_targets) {
    WorldSpec ws;
    ws.type = WorldType::Planar;
    ws.xmin = 0;
    ws.xmax = 10;
    ws.ymin = 0;
    ws.ymax = 6;
    const World world(ws, {});
    const WalkableGrid grid(world, settings(0.25), Vec2(-1, -1), Vec2(11, 7));
    BOOST_TEST(!grid.walkable(Vec2(-0.5, 3)));
    BOOST_TEST(grid.walkable(Vec2(0.2, 3)));
    BOOST_TEST(!grid.walkable(Vec2(5, 6.6)));
    TargetShape exit;
    exit.kind = TargetShape::Kind::Polygon;
    exit.polygon = {Vec2(9, 2), Vec2(10, 2), Vec2(10, 4), Vec2(9, 4)};
    BOOST_TEST(exit.contains(Vec2(9.5, 3)));
    BOOST_TEST(exit.distance(Vec2(5, 3)) == 4.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST((exit.closest(Vec2(5, 5)) - Vec2(9, 4)).norm() < 1e-12);
    BOOST_TEST((exit.centre() - Vec2(9.5, 3)).norm() < 1e-12);
    const DistanceField field(grid, exit);
    BOOST_TEST(field.distance(Vec2(9.5, 3)) == 0.0, boost::test_tools::tolerance(1e-6));
    BOOST_TEST(field.direction(Vec2(9.5, 3)).isZero());
    BOOST_TEST(std::abs(field.distance(Vec2(2, 3)) - 7.0) < 0.02 * 7 + 0.25);
    BOOST_TEST(std::abs(field.distance(Vec2(2, 0.5)) - len(Vec2(2, 0.5), Vec2(9, 2))) < 0.02 * 7 + 0.25);
    const Vec2 d = field.direction(Vec2(2, 3));
    BOOST_TEST(d.x() > 0.99);
    // Near the target the direction aims straight at its nearest point.
    const Vec2 near = field.direction(Vec2(8.8, 1.9));
    BOOST_TEST((near - (Vec2(9, 2) - Vec2(8.8, 1.9)).normalized()).norm() < 1e-9);
}

BOOST_AUTO_TEST_CASE(fields_are_deterministic) {
    // Symmetric scenes are full of equal arrival times. (Breaking ties at random instead of by cell
    // index gives bitwise the same fields in these scenes — checked — so this guards against other
    // sources of non-determinism; ties that did matter would show in the mirror test below.)
    const std::vector<ObstacleSpec> obstacles = {box(-2, -2, 2, 2), box(6, -1, 7, 1), box(-7, -1, -6, 1),
                                                 wall(Vec2(-5, 6), Vec2(5, 6)), wall(Vec2(-5, -6), Vec2(5, -6))};
    const World world(WorldSpec{}, obstacles);
    for (double clearance : {0.0, 0.5}) {
        const WalkableGrid grid(world, settings(0.2, clearance), Vec2(-10, -10), Vec2(10, 10));
        const TargetShape target = pointTarget(Vec2(0, 8.1));  // on the mirror line: pairs of equal seeds
        const DistanceField a(grid, target), b(grid, target);
        std::vector<float> va, vb;
        for (int iy = 0; iy < grid.ny(); ++iy)
            for (int ix = 0; ix < grid.nx(); ++ix) {
                va.push_back(a.value(ix, iy));
                vb.push_back(b.value(ix, iy));
            }
        BOOST_TEST(std::memcmp(va.data(), vb.data(), va.size() * sizeof(float)) == 0);
    }
}

BOOST_AUTO_TEST_CASE(mirror_symmetric_scene_gives_a_mirror_symmetric_field) {
    const std::vector<ObstacleSpec> obstacles = {box(-2, -2, 2, 2), box(6, -1, 7, 1), box(-7, -1, -6, 1),
                                                 wall(Vec2(-5, 6), Vec2(5, 6)), wall(Vec2(-5, -6), Vec2(5, -6))};
    const World world(WorldSpec{}, obstacles);
    for (double clearance : {0.0, 0.5}) {
        const WalkableGrid grid(world, settings(0.2, clearance), Vec2(-10, -10), Vec2(10, 10));
        const TargetShape target = pointTarget(Vec2(0, 8.1));  // on the mirror line: pairs of equal seeds
        const DistanceField a(grid, target);
        // The scene is mirror-symmetric in x about x = 0: so is the field (to rounding).
        double asym = 0;
        for (int iy = 0; iy < grid.ny(); ++iy)
            for (int ix = 0; ix < grid.nx(); ++ix) {
                const float u = a.value(ix, iy), v = a.value(grid.nx() - 1 - ix, iy);
                if (std::isfinite(u) || std::isfinite(v)) asym = std::max(asym, std::abs(double(u) - double(v)));
            }
        BOOST_TEST_MESSAGE("mirror asymmetry (clearance " << clearance << "): " << asym);
        // Measured 0: mirror-image cells tie exactly and their order does not change any value.
        BOOST_TEST(asym < 1e-4);
        // Reachability and component labels agree: a cell is reached iff it is in a seeded component.
        int ax, ay;
        grid.cellOf(target.point, ax, ay);
        const int seededLabel = grid.component(ax, ay);
        int mismatches = 0;
        for (int iy = 0; iy < grid.ny(); ++iy)
            for (int ix = 0; ix < grid.nx(); ++ix)
                if (grid.walkable(ix, iy) && std::isfinite(a.value(ix, iy)) != (grid.component(ix, iy) == seededLabel))
                    ++mismatches;
        BOOST_TEST(mismatches == 0);
    }
}

BOOST_AUTO_TEST_CASE(sample_agrees_with_distance_and_direction_everywhere_including_the_grid_edges) {
    // sample() takes a short way on open floor; it must give what distance() and direction() give,
    // anywhere: open floor, near the pillar, at the grid's edges (no walls there), off the grid.
    const World world(WorldSpec{}, {box(8, 4, 10, 6)});
    const WalkableGrid grid(world, settings(0.2, 0.5), Vec2(0, 0), Vec2(20, 10));
    const DistanceField field(grid, pointTarget(Vec2(17, 5), 0.3));
    int fast = 0;
    for (double y = -0.3; y <= 10.3; y += 0.137)
        for (double x = -0.3; x <= 20.3; x += 0.141) {
            const Vec2 p(x, y);
            double d = -1;
            const Vec2 dir = field.sample(p, d);
            const double expected = field.distance(p);
            const Vec2 expectedDir = field.direction(p);
            if (std::isfinite(expected)) BOOST_TEST(d == expected, boost::test_tools::tolerance(1e-9));
            else BOOST_TEST(!std::isfinite(d));
            // Equal up to rounding (the general rule adds 1e-9 to its weights; near a ridge or the
            // target a direction amplifies such differences).
            BOOST_TEST((dir - expectedDir).norm() < 1e-6, "at (" << x << ", " << y << ") " << dir.transpose() << " vs " << expectedDir.transpose());
            int cx, cy;
            grid.cellOf(p, cx, cy);
            fast += grid.inGrid(cx, cy) && grid.walkable(cx, cy) && grid.wallDistance(cx, cy) > 3.6 * 0.2;
        }
    BOOST_TEST(fast > 1000);  // most of the floor takes the short way
}

BOOST_AUTO_TEST_CASE(open_floor_bits_mark_the_walkable_cells_far_from_every_wall) {
    // WalkableGrid::openFloor is sample()'s short-way test, kept as one bit per cell: walkable and
    // more than 3.6 cells from every wall. Pillars, a diagonal wall and a world edge; every cell,
    // the grid's edges and cells off the grid included (words of 64 bits straddle rows here).
    WorldSpec ws;
    ws.type = WorldType::Planar;
    ws.xmin = 0, ws.xmax = 19.3, ws.ymin = 0, ws.ymax = 9.7;
    const World world(ws, {box(8, 4, 10, 6), box(3, 7, 3.5, 7.5), wall(Vec2(12, 1), Vec2(17, 8))});
    for (const double cell : {0.1, 0.2, 0.3}) {
        const WalkableGrid grid(world, settings(cell, 0.5), Vec2(0, 0), Vec2(19.3, 9.7));
        int open = 0, closed = 0;
        for (int iy = -2; iy < grid.ny() + 2; ++iy)
            for (int ix = -2; ix < grid.nx() + 2; ++ix) {
                const bool expected = grid.walkable(ix, iy) && grid.wallDistance(ix, iy) > 3.6 * cell;
                BOOST_TEST(grid.openFloor(ix, iy) == expected, "cell (" << ix << ", " << iy << ") at h = " << cell);
                (expected ? open : closed) += 1;
            }
        BOOST_TEST(open > 1000);
        BOOST_TEST(closed > 300);
    }
}

BOOST_AUTO_TEST_CASE(a_target_drawn_across_a_door_leads_through_its_middle_not_past_a_post) {
    // A wall along y = 0 with a 1.2 m door at x ∈ [4.4, 5.6]; the target is the door's rectangle
    // (y ∈ [−0.2, 0.2]), as exits are drawn. Walking along the field from far to the side, the path
    // enters the door at least 0.3 m from either post.
    const World world(WorldSpec{}, {wall(Vec2(-10, 0), Vec2(4.4, 0)), wall(Vec2(5.6, 0), Vec2(20, 0))});
    const WalkableGrid grid(world, settings(0.1, 0.5), Vec2(-10, -5), Vec2(20, 10));
    TargetShape door;
    door.kind = TargetShape::Kind::Polygon;
    door.polygon = {Vec2(4.4, -0.2), Vec2(5.6, -0.2), Vec2(5.6, 0.2), Vec2(4.4, 0.2)};
    const DistanceField field(grid, door);
    for (const Vec2& start : {Vec2(-3, 6), Vec2(13, 6), Vec2(0, 1.5), Vec2(10, 1.5)}) {
        Vec2 p = start;
        for (int k = 0; k < 4000 && !door.contains(p); ++k) p += 0.01 * field.direction(p);
        BOOST_TEST_REQUIRE(door.contains(p), "from " << start.transpose());
        BOOST_TEST(p.x() >= 4.4 + 0.3, "from " << start.transpose() << " entered at x = " << p.x());
        BOOST_TEST(p.x() <= 5.6 - 0.3, "from " << start.transpose() << " entered at x = " << p.x());
    }
}

BOOST_AUTO_TEST_CASE(eight_agents_at_once_are_sampled_as_one_by_one_in_every_build) {
    // WalkableGrid::probe8 and DistanceField::sample8 (Navigation's loop over agents): every lane
    // of every build this CPU runs must give probe()'s numbers and, where sample8 takes the short
    // way, sample()'s direction and distance to the last bit; each build must take it in the same
    // lanes. Positions cover a grid with a pillar, a wall, a closed room and two targets, its
    // edges and far off it, with groups of 1 … 8 agents and lanes on different fields or none.
    const World world(WorldSpec{}, {box(8, 4, 10, 6), wall(Vec2(3, 1), Vec2(5, 3.5)), box(12, 7, 12.2, 9.4),
                                    box(12, 9.2, 15, 9.4), box(14.8, 7, 15, 9.4), box(12, 7, 15, 7.2)});
    const WalkableGrid grid(world, settings(0.2, 0.5), Vec2(0, 0), Vec2(20, 10));
    TargetShape room;  // a polygon target
    room.kind = TargetShape::Kind::Polygon;
    room.polygon = {Vec2(1, 7), Vec2(2.5, 7), Vec2(2.5, 9), Vec2(1, 9)};
    const DistanceField east(grid, pointTarget(Vec2(17, 5), 0.3)), west(grid, room);
    const DistanceField* const fieldOf[3] = {&east, &west, nullptr};  // lane l: field (l·7 + group) % 3

    std::vector<Vec2> pos;
    for (double y = -0.31; y <= 10.3; y += 0.137)
        for (double x = -0.33; x <= 20.3; x += 0.141) pos.emplace_back(x, y);
    for (int k = -2; k <= 102; k += 3) pos.emplace_back(k * 0.2, 5.0 + (k % 7) * 0.1);  // on cell edges
    for (int k = 0; k < 60; ++k) pos.emplace_back((k + 0.5) * 0.2 + 2, (k % 30 + 0.5) * 0.2);  // at centres
    for (const double far : {-1e12, -3e9, 3e9, 1e12}) {
        pos.emplace_back(far, 5.0);
        pos.emplace_back(5.0, far);
    }

    const auto bitsOf = [](double v) {
        std::uint64_t b;
        std::memcpy(&b, &v, sizeof b);
        return b;
    };
    const int saved = navigationSamplePath();
    std::vector<unsigned> doneByBuild[2];
    for (const int path : {0, 1}) {
        if (!setNavigationSamplePath(path)) continue;
        int done = 0, lanesSeen = 0;
        std::size_t group = 0;
        for (std::size_t lo = 0; lo < pos.size(); ++group) {
            const int count = static_cast<int>(std::min<std::size_t>(1 + group % 8, pos.size() - lo));
            WalkableGrid::Probe8 q;
            grid.probe8(&pos[lo], count, q);
            const DistanceField* fields[8] = {};
            unsigned lanes = 0;
            for (int l = 0; l < count; ++l) {
                const WalkableGrid::Probe p = grid.probe(pos[lo + static_cast<std::size_t>(l)]);
                BOOST_TEST_REQUIRE(((q.inGrid >> l) & 1u) == static_cast<unsigned>(p.inGrid));
                BOOST_TEST_REQUIRE(((q.open >> l) & 1u) == static_cast<unsigned>(p.open));
                if (p.inGrid) {
                    BOOST_TEST_REQUIRE(bitsOf(q.qx[l]) == bitsOf(p.qx));
                    BOOST_TEST_REQUIRE(bitsOf(q.qy[l]) == bitsOf(p.qy));
                    BOOST_TEST_REQUIRE(q.cx[l] == p.cx);
                    BOOST_TEST_REQUIRE(q.cy[l] == p.cy);
                    BOOST_TEST_REQUIRE(q.i0[l] == p.i0);
                    BOOST_TEST_REQUIRE(q.j0[l] == p.j0);
                    BOOST_TEST_REQUIRE(static_cast<std::size_t>(q.first[l]) == p.first);
                }
                fields[l] = fieldOf[(static_cast<std::size_t>(l) * 7 + group) % 3];
                if (fields[l] != nullptr) lanes |= 1u << l;
            }
            Vec2 dir[8];
            double dist[8];
            const unsigned got = DistanceField::sample8(fields, q, lanes, dir, dist);
            BOOST_TEST_REQUIRE((got & ~lanes) == 0u);
            doneByBuild[path].push_back(got);
            for (int l = 0; l < count; ++l) {
                if (!((got >> l) & 1u)) continue;
                const Vec2& p = pos[lo + static_cast<std::size_t>(l)];
                double d = 0;
                const Vec2 expected = fields[l]->sample(grid.probe(p), p, d);
                BOOST_TEST_REQUIRE(bitsOf(dist[l]) == bitsOf(d), "at (" << p.x() << ", " << p.y() << ") build " << path);
                BOOST_TEST_REQUIRE(bitsOf(dir[l].x()) == bitsOf(expected.x()));
                BOOST_TEST_REQUIRE(bitsOf(dir[l].y()) == bitsOf(expected.y()));
                ++done;
            }
            lanesSeen += __builtin_popcount(lanes);
            lo += static_cast<std::size_t>(count);
        }
        BOOST_TEST_MESSAGE("build " << path << ": " << done << " of " << lanesSeen << " lanes took the short way");
        // Most lanes lie on open floor and take the short way; near walls and targets they do not.
        BOOST_TEST(done > lanesSeen / 2);
        BOOST_TEST(done < lanesSeen * 9 / 10);
    }
    if (!doneByBuild[1].empty()) BOOST_TEST(doneByBuild[0] == doneByBuild[1], boost::test_tools::per_element());
    setNavigationSamplePath(saved);
}
