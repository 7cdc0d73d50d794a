// CrowdHealth tests — the crowd field's scatter of separable Gaussian weights and the safety
// recorder's flat grid of cells (issue 20): the field against the Gaussian sum written out, and the
// heat map of crowds that move the grid (it grows, or moves to the map for a crowd scattered far
// apart) against the peaks of the fields the test computes itself.
#define BOOST_TEST_MODULE health_safety_grid
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/health/safety.h"
#include "crowdhealth/io/output.h"

#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>

using namespace ch;
using namespace ch::test;

namespace {

/// n agents uniformly in [x0, x0 + w) × [y0, y0 + h) with velocities in [−1.5, 1.5)² m/s.
AgentStore randomCrowd(std::size_t n, double x0, double y0, double w, double h, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    AgentStore a;
    for (std::size_t i = 0; i < n; ++i) {
        a.add(agent(static_cast<AgentId>(i), {x0 + w * u(rng), y0 + h * u(rng)}, {1000, 0}), 0);
        a.vel.back() = Vec2(3 * u(rng) - 1.5, 3 * u(rng) - 1.5);
    }
    return a;
}

/// The (x, y, max_density) columns of heatmap.csv, one line per row.
std::string peaksOf(const std::string& heatmap) {
    std::istringstream in(heatmap);
    std::string line, out;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        std::size_t comma = 0;
        for (int k = 0; k < 3 && comma != std::string::npos; ++k) comma = line.find(',', comma + (k > 0));
        out += line.substr(0, comma) + "\n";
    }
    return out;
}

/// The same columns from the peaks the test kept: the rectangle of the cells, y then x, when
/// `full`; the cells themselves otherwise.
std::string expectedPeaks(const std::map<std::pair<int, int>, double>& peak, double c, bool full) {
    std::string out;
    auto row = [&](int x, int y, double v) {
        appendNumber(out, (x + 0.5) * c);
        out += ',';
        appendNumber(out, (y + 0.5) * c);
        out += ',';
        appendNumber(out, v);
        out += '\n';
    };
    if (!full) {
        for (const auto& [key, v] : peak) row(key.second, key.first, v);
        return out;
    }
    int x0 = peak.begin()->first.second, x1 = x0;
    for (const auto& [key, v] : peak) x0 = std::min(x0, key.second), x1 = std::max(x1, key.second);
    for (int y = peak.begin()->first.first; y <= peak.rbegin()->first.first; ++y)
        for (int x = x0; x <= x1; ++x) {
            const auto it = peak.find({y, x});
            row(x, y, it == peak.end() ? 0.0 : it->second);
        }
    return out;
}

/// Records `a` `records` times, 0.1 s apart after the recorder's last time `t` (s; returned, moved
/// on), after moving it by `shift(k)` before record k, keeping in `peak` the largest density of
/// every cell the fields evaluated.
template <class Shift>
void follow(SafetyRecorder& r, AgentStore& a, double& t, int records, Shift shift,
            std::map<std::pair<int, int>, double>& peak) {
    for (int k = 0; k < records; ++k) {
        const Vec2 d = shift(k);
        for (Vec2& p : a.pos) p += d;
        const CrowdField f = crowdField(a, r.thresholds().cellSize, r.thresholds().gaussianRadius);
        for (std::size_t c = 0; c < f.size(); ++c) {
            double& v = peak[{f.iy[c], f.ix[c]}];
            v = std::max(v, f.density[c]);
        }
        t += 0.1;
        r.recordCrowd(a, t);
    }
}

}  // namespace

BOOST_AUTO_TEST_CASE(crowd_field_is_the_gaussian_sum_over_the_agents_within_reach) {
    // Cell sizes and radii for which the reach box has 3 to 13 columns (every remainder of the
    // four lanes), against Σ_j e^{−d²/R²} written out with std::exp over the agents within 3R.
    for (const auto& [cell, R] : {std::pair{1.0, 0.7}, {0.5, 1.1}, {2.0, 0.4}, {0.25, 0.9}, {1.0, 1.3}}) {
        const AgentStore a = randomCrowd(300, -3.2, 4.1, 14, 11, 7);
        const CrowdField f = crowdField(a, cell, R);
        BOOST_REQUIRE(f.size() > 0);
        const double reach2 = 9 * R * R;
        std::size_t withinReach = 0;
        for (std::size_t c = 0; c < f.size(); ++c) {
            const Vec2 centre = f.centre(f.ix[c], f.iy[c]);
            double sw = 0;
            Vec2 swv(0, 0);
            int people = 0;
            for (std::size_t j = 0; j < a.size(); ++j) {
                const Vec2 d = a.pos[j] - centre;
                if (std::floor(a.pos[j].x() / cell) == f.ix[c] && std::floor(a.pos[j].y() / cell) == f.iy[c]) ++people;
                if (d.squaredNorm() > reach2) continue;
                const double w = std::exp(-d.squaredNorm() / (R * R));
                sw += w;
                swv += w * a.vel[j];
            }
            BOOST_TEST(f.people[c] == people);
            BOOST_TEST(static_cast<bool>(f.weighted[c]) == (sw > 0));
            if (!(sw > 0)) {
                BOOST_TEST(f.density[c] == 0.0);
                continue;
            }
            ++withinReach;
            const double density = sw / (kPi * R * R);
            BOOST_TEST(std::abs(f.density[c] - density) <= 1e-14 * density,
                       "cell " << cell << " R " << R << ": " << f.density[c] << " vs " << density);
            BOOST_TEST((f.velocity[c] - swv / sw).norm() <= 1e-14,
                       "cell " << cell << " R " << R << ": " << (f.velocity[c] - swv / sw).norm());
        }
        BOOST_TEST(withinReach > f.size() / 2);
    }
}

BOOST_AUTO_TEST_CASE(heat_map_of_a_crowd_walking_away_keeps_every_cell_it_left) {
    // 200 people walking 1.5 m per record east and 0.4 m north for 60 records: the flat grid grows
    // several times; every cell keeps its peak density.
    SafetyRecorder r;
    AgentStore a = randomCrowd(200, 0, 0, 12, 8, 3);
    std::map<std::pair<int, int>, double> peak;
    double t = 0;
    follow(r, a, t, 60, [](int) { return Vec2(1.5, 0.4); }, peak);
    const std::string want = expectedPeaks(peak, r.thresholds().cellSize, true);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == want);
    // And walking back west and south, past where it started.
    follow(r, a, t, 80, [](int) { return Vec2(-1.6, -0.5); }, peak);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, true));
}

BOOST_AUTO_TEST_CASE(heat_map_moves_to_the_map_when_the_crowd_scatters_far_apart) {
    // A group on the flat grid, then half of it jumps 3 km away (a rectangle of ~9M cells, above
    // the 4M of a flat grid): the cells move to the map and the heat map lists only the cells
    // evaluated, the first ones with their peaks.
    SafetyRecorder r;
    AgentStore a = randomCrowd(100, 5, 5, 6, 6, 11);
    std::map<std::pair<int, int>, double> peak;
    double t = 0;
    follow(r, a, t, 5, [](int) { return Vec2(0.3, 0.0); }, peak);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, true));
    for (std::size_t i = 0; i < a.size(); i += 2) a.pos[i] += Vec2(3000, 3000);
    follow(r, a, t, 5, [](int) { return Vec2(0.0, 0.3); }, peak);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, false));
}
