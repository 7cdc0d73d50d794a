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
    for (std::size_t i = 0; i < c.pos.size(); ++i) {
        const double r = range[static_cast<std::size_t>(c.group[i])];
        BOOST_TEST(lists.radius(i) == r);
        std::vector<int> expected;
        for (std::size_t j = 0; j < c.pos.size(); ++j)
            if (j != i && world.offset(c.pos[i], c.pos[j]).squaredNorm() <= r * r) expected.push_back(static_cast<int>(j));
        for (const NeighbourAgent& nb : lists.agents(i)) {
            out[i].emplace_back(nb.index, Vec2(nb.offset));
            // The offset is the (minimum-image) vector to the neighbour, to the bit.
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
