// NeighbourLists gathers exactly the brute-force neighbourhoods from a grid whose cells are
// smaller than the list radius (the simulation's grid for short ranges: Simulation::stepGridCell),
// as from one whose cells are as wide as the radius, in the plane and on a torus.
#define BOOST_TEST_MODULE core_neighbour_lists
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/neighbours.h"
#include "crowdhealth/core/rng.h"
#include "crowdhealth/core/world.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

using namespace ch;

namespace {

struct Crowd {
    std::vector<Vec2> pos;
    std::vector<int> group;
};

/// n points in [-w/2, w/2) × [-h/2, h/2), in two groups of list radius 1.0 and 0.6 m.
Crowd crowd(int n, double w, double h, std::uint64_t seed) {
    Rng rng(seed);
    Crowd c;
    for (int i = 0; i < n; ++i) {
        c.pos.emplace_back(rng.uniform(-0.5 * w, 0.5 * w), rng.uniform(-0.5 * h, 0.5 * h));
        c.group.push_back(i % 3 == 0 ? 1 : 0);
    }
    return c;
}

/// Each agent's list as (index, offset) pairs sorted by index, checked against brute force.
std::vector<std::vector<std::pair<int, Vec2>>> checkedLists(const Crowd& c, const World& world, double cell,
                                                            const std::vector<double>& range) {
    PointGrid grid;
    const WorldSpec& ws = world.spec();
    grid.build(c.pos, cell, world.periodic(), ws.width, ws.height);
    NeighbourLists lists;
    lists.build(c.pos, grid, world, c.group, range);
    BOOST_TEST_REQUIRE(lists.size() == c.pos.size());
    std::vector<std::vector<std::pair<int, Vec2>>> out(c.pos.size());
    std::vector<NeighbourAgent> scratch;
    for (std::size_t i = 0; i < c.pos.size(); ++i) {
        const double r = range[static_cast<std::size_t>(c.group[i])];
        BOOST_TEST(lists.radius(i) == r);
        std::vector<int> expected;
        for (std::size_t j = 0; j < c.pos.size(); ++j)
            if (j != i && world.offset(c.pos[i], c.pos[j]).squaredNorm() <= r * r) expected.push_back(static_cast<int>(j));
        // The list stores indices; agents() and forEachAgent() give each the (minimum-image)
        // vector to the neighbour, to the bit, in the stored order.
        const std::span<const NeighbourAgent> list = lists.agents(i, scratch);
        BOOST_TEST_REQUIRE(list.size() == lists.indices(i).size());
        std::size_t k = 0;
        lists.forEachAgent(i, [&](int j, const Vec2& d) {
            BOOST_TEST(j == list[k].index);
            BOOST_TEST(j == lists.indices(i)[k]);
            BOOST_TEST((d == Vec2(list[k].offset)));
            ++k;
        });
        for (const NeighbourAgent& nb : list) {
            out[i].emplace_back(nb.index, Vec2(nb.offset));
            const Vec2 d = world.offset(c.pos[i], c.pos[static_cast<std::size_t>(nb.index)]);
            BOOST_TEST((Vec2(nb.offset) == d));
        }
        std::sort(out[i].begin(), out[i].end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        std::vector<int> got;
        for (const auto& e : out[i]) got.push_back(e.first);
        BOOST_TEST(got == expected, "agent " << i << " cell " << cell);
    }
    return out;
}

void sameLists(const std::vector<std::vector<std::pair<int, Vec2>>>& a,
               const std::vector<std::vector<std::pair<int, Vec2>>>& b) {
    BOOST_TEST_REQUIRE(a.size() == b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        BOOST_TEST_REQUIRE(a[i].size() == b[i].size());
        for (std::size_t k = 0; k < a[i].size(); ++k) {
            BOOST_TEST(a[i][k].first == b[i][k].first);
            BOOST_TEST((a[i][k].second == b[i][k].second));
        }
    }
}

}  // namespace

BOOST_AUTO_TEST_CASE(plane_cells_of_half_the_radius_give_the_same_lists) {
    WorldSpec ws;  // infinite plane
    ObstacleSpec wall;
    wall.points = {{-2, -2}, {2, -2}, {2, -1.5}, {-2, -1.5}};
    const World world(ws, {wall});
    const Crowd c = crowd(1500, 24, 16, 21);  // ~4 agents per m²
    const std::vector<double> range = {1.0, 0.6};
    const auto wide = checkedLists(c, world, 1.0, range);
    const auto half = checkedLists(c, world, 0.5, range);
    const auto odd = checkedLists(c, world, 0.35, range);
    sameLists(wide, half);
    sameLists(wide, odd);
    // Wall segments near an agent do not depend on the agent grid.
    PointGrid g1, g2;
    g1.build(c.pos, 1.0);
    g2.build(c.pos, 0.5);
    NeighbourLists l1, l2;
    l1.build(c.pos, g1, world, c.group, range);
    l2.build(c.pos, g2, world, c.group, range);
    std::size_t withWalls = 0;
    for (std::size_t i = 0; i < c.pos.size(); ++i) {
        const auto s1 = l1.segments(i), s2 = l2.segments(i);
        BOOST_TEST(std::vector<int>(s1.begin(), s1.end()) == std::vector<int>(s2.begin(), s2.end()));
        withWalls += s1.empty() ? 0 : 1;
    }
    BOOST_TEST(withWalls > 0);
}

BOOST_AUTO_TEST_CASE(torus_cells_of_half_the_radius_give_the_same_lists) {
    WorldSpec ws;
    ws.type = WorldType::Toric;
    ws.width = 9;
    ws.height = 7;
    const World world(ws, {});
    const Crowd c = crowd(250, ws.width, ws.height, 5);
    const std::vector<double> range = {1.0, 0.6};
    const auto wide = checkedLists(c, world, 1.0, range);
    const auto half = checkedLists(c, world, 0.5, range);
    sameLists(wide, half);
    // The random crowd has neighbours across the border.
    std::size_t across = 0;
    for (std::size_t i = 0; i < c.pos.size(); ++i)
        for (const auto& [j, d] : half[i])
            across += (c.pos[static_cast<std::size_t>(j)] - c.pos[i]).norm() > 1.0 ? 1 : 0;
    BOOST_TEST(across > 0);
}

namespace {

/// A crowd that probes the edges of the gather paths (issue 20): random points, duplicates, points
/// at exactly r (and at r along other directions) from others, points on cell borders and, if
/// `farFlung`, agents kilometres away (the grid's cells then grow past the requested size).
Crowd edgyCrowd(int n, double w, double h, double r, double cell, bool farFlung, std::uint64_t seed) {
    Crowd c = crowd(n, w, h, seed);
    Rng rng(seed + 1);
    // The lowest, leftmost point: the plane grid's origin, so that k·cell from it is a cell border.
    const Vec2 corner(-0.5 * w - 1, -0.5 * h - 1);
    c.pos.push_back(corner);
    for (int k = 0; k < 40; ++k) {
        const double bx = corner.x() + cell * std::floor(rng.uniform(0, std::floor(w / cell)));
        const double by = corner.y() + cell * std::floor(rng.uniform(0, std::floor(h / cell)));
        c.pos.emplace_back(bx, corner.y() + rng.uniform(0, h));
        c.pos.emplace_back(corner.x() + rng.uniform(0, w), by);
        c.pos.emplace_back(bx, by);
        c.pos.emplace_back(bx + r, by);  // exactly r away along x (if the sum is exact)
    }
    for (int k = 0; k < 30; ++k) {
        const Vec2 p = c.pos[static_cast<std::size_t>(k)];
        c.pos.push_back(p);  // a duplicate
        c.pos.emplace_back(p.x() + r, p.y());
        c.pos.emplace_back(p.x(), p.y() - r);
        c.pos.emplace_back(p.x() - 0.6 * r, p.y() + 0.8 * r);
        const double a = rng.uniform(0, 6.283185307179586);
        c.pos.emplace_back(p.x() + r * std::cos(a), p.y() + r * std::sin(a));  // near the chord's end
        c.pos.emplace_back(p.x() + 0.6 * r * std::cos(a), p.y() + 0.6 * r * std::sin(a));
    }
    if (farFlung) {
        c.pos.emplace_back(5e4, 3e4);
        c.pos.emplace_back(5e4 + r, 3e4);
        c.pos.emplace_back(-2e4, 1e2);
    }
    c.group.resize(c.pos.size());
    for (std::size_t i = 0; i < c.pos.size(); ++i) c.group[i] = i % 3 == 0 ? 1 : 0;
    return c;
}

/// Agent i's list as (index, offset) in list order.
std::vector<std::vector<std::pair<int, Vec2>>> listsOf(const NeighbourLists& lists) {
    std::vector<std::vector<std::pair<int, Vec2>>> out(lists.size());
    std::vector<NeighbourAgent> scratch;
    for (std::size_t i = 0; i < lists.size(); ++i)
        for (const NeighbourAgent& nb : lists.agents(i, scratch)) out[i].emplace_back(nb.index, Vec2(nb.offset));
    return out;
}

/// One agent's two lists, equal entry by entry: the same indices and the offsets to the bit.
void sameEntries(const std::vector<std::pair<int, Vec2>>& mine, const std::vector<std::pair<int, Vec2>>& reference,
                 int path, std::size_t agent) {
    BOOST_TEST_REQUIRE(mine.size() == reference.size(), "path " << path << " agent " << agent);
    for (std::size_t k = 0; k < mine.size(); ++k) {
        BOOST_TEST(mine[k].first == reference[k].first);
        BOOST_TEST(std::memcmp(mine[k].second.data(), reference[k].second.data(), 2 * sizeof(double)) == 0);
    }
}

}  // namespace

BOOST_AUTO_TEST_CASE(every_gather_path_gives_the_same_lists) {
    const int original = NeighbourLists::gatherPath();
    const World world(WorldSpec{}, {});
    int pathsRun = 0;
    for (const double r : {1.0, 5.0}) {
        for (const bool farFlung : {false, true}) {
            // The grid the lists use: the step grid (cells r/2) for 1 m, their own (r/4) for 5 m.
            const double cell = r >= NeighbourLists::kFineGridFrom ? r / NeighbourLists::kFineGridCells : 0.5 * r;
            const Crowd c = edgyCrowd(r < 2 ? 1500 : 800, 24, 16, r, cell, farFlung, farFlung ? 77 : 78);
            const std::vector<double> range = {r, 0.6 * r};
            // Path 0 (generic) against brute force, the others against path 0 entry by entry.
            BOOST_TEST_REQUIRE(NeighbourLists::setGatherPath(0));
            std::vector<std::vector<std::pair<int, Vec2>>> reference;
            PointGrid grid;
            grid.build(c.pos, 0.5 * r);
            {
                NeighbourLists lists;
                lists.build(c.pos, grid, world, c.group, range);
                reference = listsOf(lists);
            }
            std::size_t atExactlyR = 0;
            for (std::size_t i = 0; i < c.pos.size(); ++i) {
                const double ri = range[static_cast<std::size_t>(c.group[i])];
                std::vector<int> expected, got;
                for (std::size_t j = 0; j < c.pos.size(); ++j) {
                    const double d2 = (c.pos[j] - c.pos[i]).squaredNorm();
                    if (j != i && d2 <= ri * ri) expected.push_back(static_cast<int>(j));
                    atExactlyR += j != i && d2 == ri * ri ? 1 : 0;
                }
                for (const auto& e : reference[i]) got.push_back(e.first);
                std::sort(got.begin(), got.end());
                BOOST_TEST(got == expected, "agent " << i << " r " << r);
            }
            BOOST_TEST(atExactlyR > 0);  // the crowd does probe the boundary
            for (int path = 1; path <= 2; ++path) {
                if (!NeighbourLists::setGatherPath(path)) {
                    BOOST_TEST_MESSAGE("gather path " << path << " not run: this CPU lacks it");
                    continue;
                }
                ++pathsRun;
                NeighbourLists lists;
                lists.build(c.pos, grid, world, c.group, range);
                const auto mine = listsOf(lists);
                BOOST_TEST_REQUIRE(mine.size() == reference.size());
                for (std::size_t i = 0; i < mine.size(); ++i) sameEntries(mine[i], reference[i], path, i);
            }
        }
    }
    BOOST_TEST_MESSAGE("gather paths compared: " << pathsRun << " (of 8)");
    NeighbourLists::setGatherPath(original);
}

BOOST_AUTO_TEST_CASE(row_runs_are_what_forEachCandidate_scans) {
    // Points at the centres of 1 m cells of a 11 × 11 grid from (0, 0), and on cell borders.
    std::vector<Vec2> pts;
    for (int y = 0; y <= 10; ++y)
        for (int x = 0; x <= 10; ++x) pts.emplace_back(x + 0.5, y + 0.5);
    pts.emplace_back(0, 0);  // origin
    for (int k = 1; k < 10; ++k) pts.emplace_back(k, 5.5), pts.emplace_back(5.5, k), pts.emplace_back(k, k);
    PointGrid g;
    g.build(pts, 1.0);
    // Points at exactly 2 m from (5.5, 5.5) in the box's edge rows and columns are found.
    const Vec2 p(5.5, 5.5);
    const std::vector<int> in = g.within(p, 2.0);
    for (const int j : {7 * 11 + 5, 3 * 11 + 5, 5 * 11 + 7, 5 * 11 + 3})  // (5.5, 7.5), (5.5, 3.5), ...
        BOOST_TEST((std::find(in.begin(), in.end(), j) != in.end()));
    Rng rng(9);
    for (int q = 0; q < 3000; ++q) {
        const Vec2 qp(rng.uniform(-3, 14), rng.uniform(-3, 14));
        const double r = q % 5 == 0 ? 2.0 : rng.uniform(0.1, 4.0);
        // The runs hold exactly what forEachCandidate visits, in its order.
        std::vector<int> visited, found;
        g.forEachCandidate(qp, r, [&](int j, const Vec2&, double d2) {
            visited.push_back(j);
            if (d2 <= r * r) found.push_back(j);
        });
        PointGrid::Run runs[16];
        int nRuns = -1;
        std::size_t total = 0;
        BOOST_TEST_REQUIRE(g.rowRuns(qp, r, runs, 16, nRuns, total));
        std::vector<int> fromRuns;
        for (int k = 0; k < nRuns; ++k) {
            BOOST_TEST(runs[k].begin < runs[k].end);
            for (int m = runs[k].begin; m < runs[k].end; ++m) fromRuns.push_back(g.order()[static_cast<std::size_t>(m)]);
        }
        BOOST_TEST(fromRuns == visited);
        BOOST_TEST(total == visited.size());
        BOOST_TEST(total == g.candidateCount(qp, r));
        // Every point within r is visited.
        std::vector<int> expected;
        for (std::size_t j = 0; j < pts.size(); ++j)
            if ((pts[j] - qp).squaredNorm() <= r * r) expected.push_back(static_cast<int>(j));
        std::sort(found.begin(), found.end());
        BOOST_TEST(found == expected);
    }
    // More rows than the caller has room for: false.
    PointGrid::Run few[2];
    int nRuns = 0;
    std::size_t total = 0;
    BOOST_TEST(!g.rowRuns(p, 2.0, few, 2, nRuns, total));
}

BOOST_AUTO_TEST_CASE(lists_past_the_first_block_are_exact_and_survive_a_rebuild) {
    // ~1.4 million entries (5.6 MB of 4-byte indices): the first block of 65,536 entries, then the 2-MiB-multiple
    // blocks of bigAllocate (core/big_alloc.h), each list contiguous in one of them.
    WorldSpec ws;
    const World world(ws, {});
    const Crowd c = crowd(3000, 24, 16, 5);
    const std::vector<double> range = {5.0, 3.0};
    const auto first = checkedLists(c, world, 2.5, range);
    std::size_t entries = 0;
    for (const auto& l : first) entries += l.size();
    BOOST_TEST(entries > 1000000u);
    // Rebuilding into the same buffers (kept from step to step) gives the same lists.
    PointGrid grid;
    grid.build(c.pos, 2.5);
    NeighbourLists lists;
    lists.build(c.pos, grid, world, c.group, range);
    lists.build(c.pos, grid, world, c.group, range);
    std::vector<NeighbourAgent> scratch;
    for (std::size_t i = 0; i < c.pos.size(); ++i) {
        std::vector<std::pair<int, Vec2>> got;
        for (const NeighbourAgent& nb : lists.agents(i, scratch)) got.emplace_back(nb.index, Vec2(nb.offset));
        std::sort(got.begin(), got.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        BOOST_TEST_REQUIRE(got.size() == first[i].size());
        for (std::size_t k = 0; k < got.size(); ++k) {
            BOOST_TEST(got[k].first == first[i][k].first);
            BOOST_TEST((got[k].second == first[i][k].second));
        }
    }
}

namespace {

/// Agent i's lists from a streaming NeighbourLists (bind, then gather agent by agent with one
/// scratch that grows as it goes), as listsOf gives them and the segments.
std::pair<std::vector<std::vector<std::pair<int, Vec2>>>, std::vector<std::vector<int>>>
gatheredLists(const Crowd& c, const PointGrid& grid, const World& world, const std::vector<double>& range) {
    NeighbourLists lists;
    lists.bind(c.pos, grid, world, c.group, range);
    BOOST_TEST(lists.streaming());
    BOOST_TEST(lists.size() == 0u);  // nothing stored: StepContext's helpers query the grid
    NeighbourLists::Scratch scratch;
    std::vector<std::vector<std::pair<int, Vec2>>> agents(c.pos.size());
    std::vector<std::vector<int>> segments(c.pos.size());
    for (std::size_t i = 0; i < c.pos.size(); ++i) {
        std::span<const NeighbourAgent> a;
        std::span<const int> s;
        lists.gather(i, scratch, a, s);
        for (const NeighbourAgent& nb : a) agents[i].emplace_back(nb.index, Vec2(nb.offset));
        segments[i].assign(s.begin(), s.end());
    }
    return {agents, segments};
}

}  // namespace

// Simulation::setStoreNeighbourLists(false): each agent's lists gathered just before its calls
// must be those build() stores, entry by entry, offsets to the bit, in the same order (sums over
// them then give the same bits), and the same wall segments: for short ranges from the step grid,
// for long ones from the lists' own finer grid, on a torus, with every gather path.
BOOST_AUTO_TEST_CASE(gathering_agent_by_agent_gives_the_stored_lists) {
    const int original = NeighbourLists::gatherPath();
    ObstacleSpec wall;
    wall.points = {{-2, -2}, {2, -2}, {2, -1.5}, {-2, -1.5}};
    const World plane(WorldSpec{}, {wall});
    WorldSpec ts;
    ts.type = WorldType::Toric;
    ts.width = 9;
    ts.height = 7;
    const World torus(ts, {});
    std::size_t compared = 0, withWalls = 0;
    for (int path = 0; path <= 2; ++path) {
        if (!NeighbourLists::setGatherPath(path)) continue;
        for (const double r : {1.0, 5.0}) {
            const Crowd c = edgyCrowd(r < 2 ? 1500 : 800, 24, 16, r, 0.5 * r, r < 2, 91);
            const std::vector<double> range = {r, 0.6 * r};
            for (const World* world : {&plane, &torus}) {
                if (world->periodic() && r > 2) continue;  // the 9 × 7 torus holds no 5-m disc
                const Crowd& cc = world->periodic() ? crowd(250, ts.width, ts.height, 5) : c;
                PointGrid grid;
                grid.build(cc.pos, 0.5 * r, world->periodic(), ts.width, ts.height);
                NeighbourLists stored;
                stored.build(cc.pos, grid, *world, cc.group, range);
                BOOST_TEST(!stored.streaming());
                const auto [agents, segments] = gatheredLists(cc, grid, *world, range);
                const auto reference = listsOf(stored);
                BOOST_TEST_REQUIRE(agents.size() == reference.size());
                for (std::size_t i = 0; i < agents.size(); ++i) {
                    sameEntries(agents[i], reference[i], path, i);
                    const auto s = stored.segments(i);
                    BOOST_TEST(segments[i] == std::vector<int>(s.begin(), s.end()));
                    withWalls += segments[i].empty() ? 0 : 1;
                    compared += agents[i].size();
                }
            }
        }
    }
    BOOST_TEST(compared > 100000u);
    BOOST_TEST(withWalls > 0u);
    NeighbourLists::setGatherPath(original);
}

// The vector gathers write whole blocks of candidates past a list's last entry (up to the slack
// NeighbourLists asks room for). Where every candidate is kept — agents stacked on one point —
// the list reaches the end of the room it asked for, so a slack too small writes past a fresh
// scratch of exactly that size: AddressSanitizer (scripts/test.sh --sanitize) reports it. In
// every build the stacked lists must hold every other agent, in both modes, on every path.
BOOST_AUTO_TEST_CASE(a_gather_of_stacked_agents_keeps_them_all_within_its_buffer) {
    const int original = NeighbourLists::gatherPath();
    const World world(WorldSpec{}, {});
    for (const int stacked : {1, 7, 8, 9, 63, 64, 65, 200}) {
        Crowd c;
        for (int k = 0; k < stacked; ++k) c.pos.emplace_back(3.0, 4.0);
        c.pos.emplace_back(40.0, 40.0);  // far away: the grid spans more than one cell
        c.group.assign(c.pos.size(), 0);
        for (int path = 0; path <= 2; ++path) {
            if (!NeighbourLists::setGatherPath(path)) continue;
            for (const double r : {1.0, 5.0}) {
                PointGrid grid;
                grid.build(c.pos, 0.5 * r);
                NeighbourLists lists;
                lists.bind(c.pos, grid, world, c.group, {r});
                NeighbourLists::Scratch scratch;  // fresh: sized by this one gather
                std::span<const NeighbourAgent> a;
                std::span<const int> s;
                lists.gather(0, scratch, a, s);
                BOOST_TEST(a.size() == static_cast<std::size_t>(stacked - 1), "path " << path << " r " << r);
                NeighbourLists stored;
                stored.build(c.pos, grid, world, c.group, {r});
                for (std::size_t i = 0; i < static_cast<std::size_t>(stacked); ++i)
                    BOOST_TEST(stored.indices(i).size() == static_cast<std::size_t>(stacked - 1));
            }
        }
    }
    NeighbourLists::setGatherPath(original);
}
