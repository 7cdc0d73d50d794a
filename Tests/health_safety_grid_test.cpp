// CrowdHealth tests — the crowd field's scatter of separable Gaussian weights and the safety
// recorder's tiles of cells (issue 20): the field against the Gaussian sum written out, and the
// heat map of crowds that move over the tiles (their index grows, or the cells move to the map for
// a crowd scattered very far apart) against the peaks of the fields the test computes itself.
#define BOOST_TEST_MODULE health_safety_grid
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/simd.h"
#include "crowdhealth/health/safety.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/io/xml.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstring>
#include <iomanip>
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

namespace {
/// Cell sizes and radii for which an agent's reach box (floor(2·3R/c) + 1 columns) has 2, 4, 5, 8,
/// 9, 14 and 22 columns: one vector of four or eight lanes, full or not, and several.
const std::pair<double, double> kBoxes[] = {{1.0, 0.7}, {0.5, 1.1}, {2.0, 0.4}, {0.25, 0.9},
                                            {1.0, 1.3}, {1.0, 1.4}, {1.0, 0.6}};

/// The builds of the scatter this CPU runs (0 generic, 1 AVX2, 2 AVX-512).
std::vector<int> scatterPaths() {
    const int before = crowdFieldPath();
    std::vector<int> paths;
    for (int path = 0; path <= 2; ++path)
        if (setCrowdFieldPath(path)) paths.push_back(path);
    setCrowdFieldPath(before);
    return paths;
}
}  // namespace

BOOST_AUTO_TEST_CASE(crowd_field_is_the_gaussian_sum_over_the_agents_within_reach) {
    // Every build of the scatter, for reach boxes of 2 to 22 columns, against Σ_j e^{−d²/R²}
    // written out with std::exp over the agents within 3R.
    const int before = crowdFieldPath();
    for (const auto& [path, box] : [] {
             std::vector<std::pair<int, std::pair<double, double>>> cases;
             for (const int path : scatterPaths())
                 for (const auto& box : kBoxes) cases.emplace_back(path, box);
             return cases;
         }()) {
        const auto [cell, R] = box;
        BOOST_REQUIRE(setCrowdFieldPath(path));
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
                       "build " << path << " cell " << cell << " R " << R << ": " << f.density[c] << " vs " << density);
            BOOST_TEST((f.velocity[c] - swv / sw).norm() <= 1e-14,
                       "build " << path << " cell " << cell << " R " << R << ": " << (f.velocity[c] - swv / sw).norm());
        }
        BOOST_TEST(withinReach > f.size() / 2);
    }
    setCrowdFieldPath(before);
}

namespace {
/// The bits of a double (to compare fields bit for bit: == would take −0 for +0).
std::uint64_t bitsOf(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
}

/// Entries of two fields of the same crowd that differ in a bit of density or velocity, in their
/// flag or count, or in their cell (every entry when the sizes differ).
std::size_t entriesDiffering(const CrowdField& f, const CrowdField& g) {
    if (f.size() != g.size()) return std::max(f.size(), g.size());
    std::size_t differ = 0;
    for (std::size_t c = 0; c < f.size(); ++c)
        if (f.ix[c] != g.ix[c] || f.iy[c] != g.iy[c] || bitsOf(f.density[c]) != bitsOf(g.density[c]) ||
            bitsOf(f.velocity[c].x()) != bitsOf(g.velocity[c].x()) ||
            bitsOf(f.velocity[c].y()) != bitsOf(g.velocity[c].y()) || f.weighted[c] != g.weighted[c] ||
            f.people[c] != g.people[c])
            ++differ;
    return differ;
}
}  // namespace

BOOST_AUTO_TEST_CASE(every_build_of_the_scatter_gives_the_same_bits) {
    // The generic, AVX2 and AVX-512 builds (those this CPU runs) do the same operations lane by
    // lane without fused multiply-add: the same field to the last bit, for boxes of one vector or
    // several, full or not, and on 1 and 3 threads (bands that split the boxes).
    const int before = crowdFieldPath(), threads = omp_get_max_threads();
    const std::vector<int> paths = scatterPaths();
    BOOST_TEST_MESSAGE("scatter builds this CPU runs: " << paths.size());
    for (const int team : {1, 3}) {
        omp_set_num_threads(team);
        for (const auto& [cell, R] : kBoxes) {
            const AgentStore a = randomCrowd(2000, -3.2, 4.1, 30, 40, 11);
            BOOST_REQUIRE(setCrowdFieldPath(0));
            const CrowdField generic = crowdField(a, cell, R);
            BOOST_REQUIRE(generic.size() > 0);
            for (const int path : paths) {
                BOOST_REQUIRE(setCrowdFieldPath(path));
                BOOST_TEST(entriesDiffering(crowdField(a, cell, R), generic) == 0u,
                           "build " << path << ", cell " << cell << ", R " << R << ", " << team << " threads");
            }
        }
    }
    omp_set_num_threads(threads);
    setCrowdFieldPath(before);
}

BOOST_AUTO_TEST_CASE(crowd_field_has_the_same_bits_for_any_thread_count) {
    // The scatter shares the rows among the threads (each owns a band and adds the agents within
    // reach of it in agent order): every density, velocity, flag and count must be the same bits
    // with 1 to 4 threads, for reach boxes of 2 to 22 columns and bands that split them. (The
    // suite runs with CROWDHEALTH_PARALLEL_MIN_AGENTS=1, so even small crowds use the team.)
    const int before = omp_get_max_threads();
    for (const auto& [cell, R] : kBoxes) {
        const AgentStore a = randomCrowd(2500, -3.2, 4.1, 30, 40, 5);
        omp_set_num_threads(1);
        const CrowdField one = crowdField(a, cell, R);
        BOOST_REQUIRE(one.size() > 0);
        for (int threads = 2; threads <= 4; ++threads) {
            omp_set_num_threads(threads);
            const CrowdField f = crowdField(a, cell, R);
            BOOST_REQUIRE(f.size() == one.size());
            BOOST_TEST(entriesDiffering(f, one) == 0u, "cell " << cell << " R " << R << ", " << threads << " threads");
            BOOST_TEST(f.cellOfAgent == one.cellOfAgent);
        }
    }
    omp_set_num_threads(before);
}

BOOST_AUTO_TEST_CASE(safety_records_are_the_same_for_any_thread_count) {
    // The base-case door (dense in front of the door: the density and crowd pressure conditions
    // hold) for 40 s, recorded at every coarse step by four recorders, on 1 to 4 threads (the
    // scatter's bands and the cells of a record shared out, every crowd on the team): the heat
    // map, the crowd_pressure column and the verdict are the same bytes.
    const std::size_t minAgents = parallelMinAgents();
    setParallelMinAgents(1);
    const int before = omp_get_max_threads();
    Diagnostics diags;
    auto spec = loadScenario(std::string(CH_SOURCE_DIR) + "/Examples/doorway/base-case.xml", diags);
    BOOST_REQUIRE(spec.has_value());
    spec->endTime = 40;
    Simulation sim(*spec);
    std::vector<SafetyRecorder> recorders(4, SafetyRecorder(spec->safety));
    std::size_t records = 0, pressureDiffers = 0;
    std::map<std::pair<int, int>, double> contact;  // (x, y) → the largest |contact acceleration| there
    const double c = spec->safety.cellSize;
    while (true) {
        const AgentStore& a = sim.agents();
        for (std::size_t i = 0; i < a.size(); ++i) {
            double& m = contact[{static_cast<int>(std::floor(a.pos[i].x() / c)), static_cast<int>(std::floor(a.pos[i].y() / c))}];
            m = std::max(m, a.contactAccel[i].norm());
        }
        for (int k = 0; k < 4; ++k) {
            omp_set_num_threads(k + 1);
            recorders[static_cast<std::size_t>(k)].record(sim);
        }
        ++records;
        for (const SafetyRecorder& r : recorders)
            if (bitsOf(r.maxPressure()) != bitsOf(recorders[0].maxPressure())) ++pressureDiffers;
        if (sim.finished()) break;
        sim.setThreads(1);
        sim.stepCoarse();
    }
    BOOST_TEST(records == 401u);
    BOOST_TEST(pressureDiffers == 0u);
    // The max_contact_accel column: each cell's largest contact acceleration of the agents in it.
    std::istringstream heat(recorders[0].heatmapCsv());
    std::string line;
    std::getline(heat, line);
    std::size_t rows = 0, withContact = 0, wrong = 0;
    while (std::getline(heat, line)) {
        std::istringstream row(line);
        std::string x, y, density, accel;
        std::getline(row, x, ',');
        std::getline(row, y, ',');
        std::getline(row, density, ',');
        std::getline(row, accel, ',');
        const auto it = contact.find({static_cast<int>(std::floor(std::stod(x) / c)), static_cast<int>(std::floor(std::stod(y) / c))});
        std::string want;
        appendNumber(want, it == contact.end() ? 0.0 : it->second);
        if (accel != want) ++wrong;
        ++rows;
        if (it != contact.end() && it->second > 0) ++withContact;
    }
    BOOST_TEST(wrong == 0u);
    BOOST_TEST(withContact > 10u);
    BOOST_TEST(rows > withContact);
    const Verdict one = recorders[0].verdict(sim);
    BOOST_TEST(one.reasons.size() >= 2u);  // density and crowd pressure
    for (int k = 1; k < 4; ++k) {
        const SafetyRecorder& r = recorders[static_cast<std::size_t>(k)];
        BOOST_TEST(r.heatmapCsv() == recorders[0].heatmapCsv(), k + 1 << " threads");
        BOOST_TEST(verdictJson(r.verdict(sim)) == verdictJson(one), k + 1 << " threads");
    }
    omp_set_num_threads(before);
    setParallelMinAgents(minAgents);
}

BOOST_AUTO_TEST_CASE(crowd_field_knows_each_agents_cell) {
    // cellOfAgent: the entry of the cell each agent's centre lies in, on the dense rectangle and
    // on the cells of a crowd scattered far apart.
    AgentStore a = randomCrowd(400, -5.5, 2.0, 20, 9, 13);
    for (int scattered = 0; scattered < 2; ++scattered) {
        if (scattered == 1)
            for (std::size_t i = 0; i < a.size(); i += 3) a.pos[i] += Vec2(4000, -2500);
        const CrowdField f = crowdField(a, 0.5, 0.7);
        BOOST_REQUIRE(f.cellOfAgent.size() == a.size());
        for (std::size_t i = 0; i < a.size(); ++i) {
            const std::size_t k = f.cellOfAgent[i];
            BOOST_REQUIRE(k < f.size());
            BOOST_TEST(f.ix[k] == static_cast<int>(std::floor(a.pos[i].x() / 0.5)));
            BOOST_TEST(f.iy[k] == static_cast<int>(std::floor(a.pos[i].y() / 0.5)));
            BOOST_TEST(f.find(f.ix[k], f.iy[k]) == k);
        }
        // find(): every entry at its place; cells beyond the rectangle (or not evaluated) are not.
        for (std::size_t k = 0; k < f.size(); k += 7) BOOST_TEST_REQUIRE(f.find(f.ix[k], f.iy[k]) == k);
        const int x0 = *std::min_element(f.ix.begin(), f.ix.end()), x1 = *std::max_element(f.ix.begin(), f.ix.end());
        const int y0 = f.iy.front(), y1 = f.iy.back();
        for (const auto& [x, y] : {std::pair{x0 - 1, y0}, std::pair{x1 + 1, y0}, std::pair{x0, y0 - 1}, std::pair{x0, y1 + 1},
                                   std::pair{x1 + 1, y1}})
            BOOST_TEST(f.find(x, y) == f.size(), "scattered " << scattered << " cell " << x << ", " << y);
    }
}

BOOST_AUTO_TEST_CASE(fruin_level_by_comparisons_is_the_level_by_area_to_the_last_bit) {
    // fruinLevel compares the density with five bounds found from the definition (the first level
    // whose lower bound of area per person, 35, 25, 15, 10, 5 ft², the area 1/density reaches);
    // here the definition written out, at the doubles next to each bound and at random densities.
    auto byArea = [](double density) {
        if (!(density > 0)) return 'A';
        const double feet = 1.0 / density / 0.09290304;
        const double bounds[] = {35, 25, 15, 10, 5};
        for (int k = 0; k < 5; ++k)
            if (feet >= bounds[k]) return static_cast<char>('A' + k);
        return 'F';
    };
    std::size_t checked = 0;
    for (const double feet : {35.0, 25.0, 15.0, 10.0, 5.0}) {
        double d = 1.0 / (feet * 0.09290304);
        for (int k = 0; k < 40; ++k) d = std::nextafter(d, 0.0);
        for (int k = 0; k < 80; ++k, d = std::nextafter(d, 1e9), ++checked)
            BOOST_TEST(fruinLevel(d) == byArea(d), feet << " ft2, density " << d);
    }
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-1.0, 12.0);
    for (int k = 0; k < 20000; ++k, ++checked) {
        const double d = u(rng);
        BOOST_TEST(fruinLevel(d) == byArea(d), d);
    }
    for (const double d : {0.0, -0.0, 1e-300, 5e-324, 1e300, std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()})
        BOOST_TEST(fruinLevel(d) == byArea(d), d);
    BOOST_TEST(checked == 20400u);
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

BOOST_AUTO_TEST_CASE(heat_map_of_a_crowd_scattered_far_apart_lists_only_its_cells) {
    // A group, then half of it jumps 3 km away (a rectangle of ~9M cells, above the 4M the heat
    // map writes in full): the tiles keep both places, and the heat map lists only the cells
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

BOOST_AUTO_TEST_CASE(heat_map_moves_to_the_map_when_the_crowd_scatters_very_far_apart) {
    // Half of a group jumps 2000 km away, past what an index of tiles covers (~16 km a side): the
    // cells move to the map, those evaluated before the jump with their peaks, and the records
    // go on there (south and west of the origin too).
    SafetyRecorder r;
    AgentStore a = randomCrowd(100, -3, -4, 6, 6, 5);
    std::map<std::pair<int, int>, double> peak;
    double t = 0;
    follow(r, a, t, 5, [](int) { return Vec2(-0.3, 0.2); }, peak);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, true));
    for (std::size_t i = 0; i < a.size(); i += 2) a.pos[i] += Vec2(2.0e6, -1.5e6);
    follow(r, a, t, 5, [](int) { return Vec2(0.0, -0.3); }, peak);
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, false));
}

BOOST_AUTO_TEST_CASE(a_copied_recorder_keeps_its_cells_and_goes_on_alone) {
    // A copy has the cells of the original (not shared: recording into one leaves the other as it
    // was), and both go on as the original would.
    SafetyRecorder r;
    AgentStore a = randomCrowd(300, 0, 0, 40, 30, 8);
    std::map<std::pair<int, int>, double> peak;
    double t = 0;
    follow(r, a, t, 10, [](int) { return Vec2(1.0, 0.5); }, peak);
    const std::string before = r.heatmapCsv();
    SafetyRecorder copy = r;
    BOOST_TEST(copy.heatmapCsv() == before);
    AgentStore b = a;
    double tb = t;
    std::map<std::pair<int, int>, double> peakCopy = peak;
    follow(r, a, t, 10, [](int) { return Vec2(-2.0, 0.0); }, peak);
    BOOST_TEST(copy.heatmapCsv() == before);
    follow(copy, b, tb, 10, [](int) { return Vec2(-2.0, 0.0); }, peakCopy);
    BOOST_TEST(copy.heatmapCsv() == r.heatmapCsv());
    BOOST_TEST(peaksOf(r.heatmapCsv()) == expectedPeaks(peak, r.thresholds().cellSize, true));
    SafetyRecorder assigned;
    assigned = copy;
    BOOST_TEST(assigned.heatmapCsv() == r.heatmapCsv());
}

namespace {
/// One cell as the recorder follows it, written out here one cell at a time from the definitions
/// (safety.h): the peak density, the seconds above each density level and the crowd pressure's,
/// the worst of Fruin's levels held for minDuration without a break, and the time averages of the
/// crowd pressure.
struct ReferenceCell {
    double maxDensity = 0;
    double seconds[4] = {0, 0, 0, 0};  ///< above caution, dangerous, critical; turbulent
    double run[5] = {0, 0, 0, 0, 0};   ///< seconds level B + l (or worse) has held without a break
    double lastSeen = std::numeric_limits<double>::quiet_NaN();     ///< time of the last record here
    double lastSampled = std::numeric_limits<double>::quiet_NaN();  ///< … with someone within reach
    char worst = 'A';
    double meanDensity = 0, meanSquaredSpeed = 0;
    Vec2 meanVelocity{0, 0};
};

/// When a condition first held anywhere, for how many seconds, and the most people in its cells
/// at once.
struct ReferenceTimeline {
    double first = std::numeric_limits<double>::quiet_NaN(), seconds = 0;
    std::size_t people = 0;
};

struct Reference {
    std::map<std::pair<int, int>, ReferenceCell> cells;
    ReferenceTimeline timeline[4];
};

/// The record at time t (the previous at `previous`, NaN for none) of field f; returns the
/// largest crowd pressure of the record.
double referenceRecord(Reference& ref, const CrowdField& f, const SafetyThresholds& th, double t, double previous) {
    const double dt = previous == previous ? t - previous : 0.0;
    const double alpha = std::min(1.0, dt / th.pressureWindow);
    const double levels[3] = {th.densityCaution, th.densityDangerous, th.densityCritical};
    double largest = 0;
    bool held[4] = {false, false, false, false};
    std::size_t people[4] = {0, 0, 0, 0};
    const auto holds = [&](ReferenceCell& c, int condition, std::size_t k) {
        c.seconds[condition] += dt;
        held[condition] = true;
        people[condition] += static_cast<std::size_t>(f.people[k]);
    };
    for (std::size_t k = 0; k < f.size(); ++k) {
        ReferenceCell& c = ref.cells[{f.iy[k], f.ix[k]}];
        const double d = f.density[k];
        c.maxDensity = std::max(c.maxDensity, d);
        const int level = fruinLevel(d) - 'A';
        for (int l = 1; l <= 5; ++l) {
            c.run[l - 1] = level >= l && c.lastSeen == previous ? c.run[l - 1] + dt : 0.0;
            if (level >= l && c.run[l - 1] >= th.minDuration) c.worst = std::max(c.worst, static_cast<char>('A' + l));
        }
        c.lastSeen = t;
        for (int l = 0; l < 3; ++l)
            if (d > levels[l]) holds(c, l, k);
        double pressure = 0;
        if (f.weighted[k]) {
            const Vec2 v = f.velocity[k];
            const double w = c.lastSampled == previous ? alpha : 1.0;
            c.meanDensity += w * (d - c.meanDensity);
            c.meanVelocity += w * (v - c.meanVelocity);
            c.meanSquaredSpeed += w * (v.squaredNorm() - c.meanSquaredSpeed);
            c.lastSampled = t;
            pressure = c.meanDensity * std::max(0.0, c.meanSquaredSpeed - c.meanVelocity.squaredNorm());
            largest = std::max(largest, pressure);
        }
        if (pressure > th.crowdPressureCritical && c.meanDensity > th.densityCaution) holds(c, 3, k);
    }
    for (int c = 0; c < 4; ++c) {
        ReferenceTimeline& tl = ref.timeline[c];
        if (!held[c]) continue;
        if (!(tl.first == tl.first)) tl.first = t;
        tl.seconds += dt;
        tl.people = std::max(tl.people, people[c]);
    }
    return largest;
}

/// heatmap.csv of the reference cells (no contact, no crush): the rectangle of the cells when it
/// is at most 4M cells, else the cells themselves.
std::string referenceHeatmap(const Reference& ref, double size) {
    std::string out =
        "x,y,max_density,max_contact_accel,seconds_above_density_threshold,seconds_above_crush_threshold,worst_los\n";
    const auto row = [&](int x, int y, const ReferenceCell& c) {
        for (const double v : {(x + 0.5) * size, (y + 0.5) * size, c.maxDensity, 0.0, c.seconds[1], 0.0}) {
            appendNumber(out, v);
            out += ',';
        }
        out += c.worst;
        out += '\n';
    };
    const auto& cells = ref.cells;
    int x0 = cells.begin()->first.second, x1 = x0;
    for (const auto& [key, c] : cells) x0 = std::min(x0, key.second), x1 = std::max(x1, key.second);
    const int y0 = cells.begin()->first.first, y1 = cells.rbegin()->first.first;
    if ((static_cast<double>(x1) - x0 + 1) * (static_cast<double>(y1) - y0 + 1) > (1 << 22)) {
        for (const auto& [key, c] : cells) row(key.second, key.first, c);
        return out;
    }
    const ReferenceCell empty;
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
            const auto it = cells.find({y, x});
            row(x, y, it == cells.end() ? empty : it->second);
        }
    return out;
}

/// "level duration people first x y xmin xmax ymin ymax" of a reason, each number to the last bit.
std::string placeOf(const VerdictReason& r) {
    std::ostringstream out;
    out << r.level << std::setprecision(17);
    for (const double v : {r.duration, static_cast<double>(r.people), r.firstTime, r.x, r.y, r.xmin, r.xmax, r.ymin,
                           r.ymax})
        out << ' ' << v;
    return out.str();
}

/// The same for the reference's condition c: its timeline, and the centroid of its cells weighted
/// by their seconds (in the heat map's order) and their bounds.
std::string referencePlace(const Reference& ref, int c, const char* level, double size) {
    VerdictReason r;
    r.level = level;
    r.duration = ref.timeline[c].seconds;
    r.people = ref.timeline[c].people;
    r.firstTime = ref.timeline[c].first;
    double sw = 0, sx = 0, sy = 0;
    bool any = false;
    for (const auto& [key, cell] : ref.cells) {
        const double s = cell.seconds[c];
        if (!(s > 0)) continue;
        const double x = (key.second + 0.5) * size, y = (key.first + 0.5) * size, h = 0.5 * size;
        r.xmin = any ? std::min(r.xmin, x - h) : x - h;
        r.xmax = any ? std::max(r.xmax, x + h) : x + h;
        r.ymin = any ? std::min(r.ymin, y - h) : y - h;
        r.ymax = any ? std::max(r.ymax, y + h) : y + h;
        any = true;
        sw += s, sx += s * x, sy += s * y;
    }
    if (sw > 0) r.x = sx / sw, r.y = sy / sw;
    return placeOf(r);
}
}  // namespace

BOOST_AUTO_TEST_CASE(every_cell_follows_its_definition_record_by_record_in_every_build) {
    // Two dense crowds 5 m apart (Fruin's levels up to F, densities above the dangerous level,
    // cells between them with nobody within reach) with scattered velocities (crowd pressure)
    // stepping back and forth by 0.75 m, the second by 2.5 m more: the cells at the edges of the
    // field leave it and come back, and cells at the gap's edges fall out of everyone's reach and
    // come back at once at Fruin's level B or worse. The recorder updates cells eight at a time, and
    // a block at an edge of the field has lanes outside it, which must be left as they were.
    // Then half of it jumps 3 km away (the field's cells no longer a rectangle) and 2000 km away
    // (the cells in the map). Against the cells followed one at a time here, in every build this
    // CPU runs, on 1 and 3 threads: every record's largest crowd pressure, the whole heat map, and
    // the verdict's density and crowd-pressure reasons (when, how long, how many, where); and with
    // each lower density level in turn the highest that held (thresholds raised), once.
    const int before = crowdFieldPath(), threads = omp_get_max_threads();
    const Simulation empty(scenario({}, {policy(0, OptimisationMethod::Gradient,
                                                {component("GoalReachingForce", {{"range", 0.0}})})}));
    const std::vector<int> paths = scatterPaths();
    for (const int top : {2, 1, 0})
        for (const int path : paths)
            for (const int team : {1, 3}) {
                if (top < 2 && (path != paths.back() || team != 1)) continue;  // the lower levels once
                SafetyThresholds th;
                th.cellSize = 0.5;
                th.minDuration = 0.1;     // one record: a cell back in the field must start its runs again
                th.pressureWindow = 0.5;  // each record weighs 0.2 in the averages
                if (top < 2) th.densityCritical = 1e3;
                if (top < 1) th.densityDangerous = 1e3;
                BOOST_REQUIRE(setCrowdFieldPath(path));
                omp_set_num_threads(team);
                SafetyRecorder r(th);
                Reference ref;
                AgentStore a = randomCrowd(800, 0.13, -0.41, 11, 9, 17);
                for (std::size_t i = 0; i < a.size(); i += 3) a.pos[i] += Vec2(16, 0);  // a gap of 5 m
                double t = 0, previous = std::numeric_limits<double>::quiet_NaN();
                std::size_t pressures = 0, positive = 0;
                for (int k = 0; k < 36; ++k) {
                    if (k == 20)
                        for (std::size_t i = 0; i < a.size(); i += 2) a.pos[i] += Vec2(3000, 3000);
                    if (k == 28)
                        for (std::size_t i = 1; i < a.size(); i += 2) a.pos[i] += Vec2(2.0e6, -1.5e6);
                    const double step = k % 2 == 0 ? 0.75 : -0.75;
                    for (std::size_t i = 0; i < a.size(); ++i)
                        a.pos[i] += Vec2(step + 0.05 + (i % 3 == 0 ? 3.3 * step : 0.0), 0.6 * step);
                    r.recordCrowd(a, t);
                    const CrowdField f = crowdField(a, th.cellSize, th.gaussianRadius);
                    const double want = referenceRecord(ref, f, th, t, previous);
                    pressures += bitsOf(r.maxPressure()) == bitsOf(want);
                    positive += want > 0;
                    previous = t;
                    t += 0.1;
                }
                const std::string label = "top level " + std::to_string(top) + ", build " + std::to_string(path) +
                                          ", " + std::to_string(team) + " threads";
                BOOST_TEST(pressures == 36u, label);
                BOOST_TEST(positive > 30u, label);
                const std::string want = referenceHeatmap(ref, th.cellSize);
                BOOST_TEST((r.heatmapCsv() == want), label);
                // The crowd reached level F, the top density level and crowd turbulence somewhere.
                BOOST_TEST(want.find(",F\n") != std::string::npos, label);
                BOOST_TEST(std::count(want.begin(), want.end(), '\n') > 1000, label);
                const Verdict v = r.verdict(empty);
                const char* const levels[] = {"caution", "dangerous", "critical"};
                std::string density, pressure;
                for (const VerdictReason& reason : v.reasons) {
                    if (reason.measure == "density") density = placeOf(reason);
                    if (reason.measure == "crowd_pressure") pressure = placeOf(reason);
                }
                BOOST_TEST(density == referencePlace(ref, top, levels[top], th.cellSize), label);
                BOOST_TEST(pressure == referencePlace(ref, 3, "dangerous", th.cellSize), label);
                BOOST_TEST(ref.timeline[top].seconds >= 1.0, label);
                BOOST_TEST(ref.timeline[3].seconds >= 1.0, label);
            }
    omp_set_num_threads(threads);
    setCrowdFieldPath(before);
}
