// The files a `crowdhealth` run writes (DESIGN §6): metrics.csv, evacuations.csv, summary.json,
// UMANS output_<id>.csv and PedPy trajectories.txt — their format and their consistency.
#define BOOST_TEST_MODULE cli_outputs
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/json.h>

#include <cmath>
#include <map>
#include <set>

using namespace clitest;

namespace {

constexpr double kDt = 0.1;  // delta_time of evacuation.xml and the UMANS examples (s)

const char* kHeader =
    "time,agents,evacuated,mean_density,max_density,mean_rest_density,mean_speed,max_speed,"
    "mean_contact_accel,max_contact_accel,max_wall_penetration,mean_panic,injured,crowd_pressure";

struct Row { double t, x, y, dx, dy; };

std::vector<Row> readUmans(const fs::path& file) {
    std::vector<Row> rows;
    for (const std::string& l : lines(readFile(file))) {
        const auto c = split(l, ',');
        BOOST_REQUIRE_MESSAGE(c.size() == 5u, file << ": row '" << l << "' has " << c.size() << " columns");
        // std::stod throws on a header word: no header allowed.
        rows.push_back({std::stod(c[0]), std::stod(c[1]), std::stod(c[2]), std::stod(c[3]), std::stod(c[4])});
    }
    return rows;
}

/// One run of evacuation.xml with both trajectory formats, shared by the test cases.
struct EvacuationRun {
    fs::path dir, out;
    Result result;
    EvacuationRun() {
        dir = freshDir("evacuation_run");
        out = dir / "out";
        result = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--trajectories", "both", "-q"});
    }
};

}  // namespace

BOOST_FIXTURE_TEST_SUITE(evacuation, EvacuationRun)

BOOST_AUTO_TEST_CASE(run_succeeds_and_writes_every_file_without_leftover_tmp) {
    BOOST_TEST(result.status == 0, result.err);
    for (const char* f : {"metrics.csv", "evacuations.csv", "summary.json", "trajectories.txt"})
        BOOST_TEST(fs::is_regular_file(out / f), f);
    BOOST_TEST(tmpFiles(dir).empty());
}

BOOST_AUTO_TEST_CASE(metrics_has_the_header_a_t0_row_and_one_row_per_interval) {
    const auto rows = lines(readFile(out / "metrics.csv"));
    BOOST_REQUIRE(rows.size() >= 3u);
    BOOST_TEST(rows[0] == kHeader);
    const auto first = split(rows[1], ',');
    BOOST_REQUIRE(first.size() == 14u);
    BOOST_TEST(first[0] == "0");
    BOOST_TEST(first[1] == "9");  // active agents: agent 8 only appears at t = 2 s
    BOOST_TEST(first[2] == "0");
    // evacuation.xml: <Output metrics_interval="0.5"/>; the run ends at the last evacuation,
    // which is not on the interval, so the final row is extra.
    std::vector<double> times;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto c = split(rows[i], ',');
        BOOST_REQUIRE_MESSAGE(c.size() == 14u, "row " << i << ": " << rows[i]);
        for (std::size_t k = 0; k < c.size(); ++k) {
            if (k == 5) continue;  // mean_rest_density: empty without an SPH component
            BOOST_TEST(!c[k].empty(), "row " << i << " column " << k);
            BOOST_TEST(std::isfinite(std::stod(c[k])), "row " << i << " column " << k);
        }
        BOOST_TEST(c[5].empty());  // no component provides "rest_density" in this scenario
        times.push_back(std::stod(c[0]));
    }
    for (std::size_t i = 1; i + 1 < times.size(); ++i)
        BOOST_TEST(std::abs(times[i] - times[i - 1] - 0.5) < 1e-9, "row " << i);
    const std::string summary = readFile(out / "summary.json");
    BOOST_TEST(std::abs(times.back() - jsonValue(summary, "simulated_time")) < 1e-9);
    BOOST_TEST(times.back() > times[times.size() - 2]);
    // The last row: nobody left, all 10 evacuated.
    const auto last = split(rows.back(), ',');
    BOOST_TEST(last[1] == "0");
    BOOST_TEST(last[2] == "10");
}

BOOST_AUTO_TEST_CASE(evacuations_are_sorted_by_time_and_match_the_summary) {
    const auto rows = lines(readFile(out / "evacuations.csv"));
    BOOST_REQUIRE(!rows.empty());
    BOOST_TEST(rows[0] == "id,time");
    BOOST_REQUIRE(rows.size() == 11u);  // all ten agents reach their goal
    std::set<long> ids;
    double previous = -1;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto c = split(rows[i], ',');
        BOOST_REQUIRE(c.size() == 2u);
        const double t = std::stod(c[1]);
        BOOST_TEST(t >= previous, "row " << i);
        previous = t;
        ids.insert(std::stol(c[0]));
    }
    BOOST_TEST(ids.size() == 10u);
    // Not all at once: the scenario spreads arrivals over several seconds.
    BOOST_TEST(previous - std::stod(split(rows[1], ',')[1]) > 1.0);

    const std::string summary = readFile(out / "summary.json");
    BOOST_TEST(jsonValue(summary, "agents_total") == 10);
    BOOST_TEST(jsonValue(summary, "evacuated") == 10);
    BOOST_TEST(std::abs(jsonValue(summary, "evacuation_time") - previous) < 1e-9);
    const double t1 = std::stod(split(rows[1], ',')[1]);
    BOOST_TEST(std::abs(jsonValue(summary, "persons_per_second") - 9.0 / (previous - t1)) < 1e-6);
    BOOST_TEST(summary.find("\"interrupted\": false") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(umans_trajectories_one_file_per_agent_no_header_rows_every_delta_time) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(out))
        if (e.path().filename().string().rfind("output_", 0) == 0) names.insert(e.path().filename().string());
    std::set<std::string> expected;
    for (int id = 0; id < 10; ++id) expected.insert("output_" + std::to_string(id) + ".csv");
    BOOST_TEST(names == expected);

    // Evacuation time per agent, to check that rows stop when the agent leaves.
    std::map<long, double> evacuatedAt;
    const auto evac = lines(readFile(out / "evacuations.csv"));
    for (std::size_t i = 1; i < evac.size(); ++i) {
        const auto c = split(evac[i], ',');
        evacuatedAt[std::stol(c[0])] = std::stod(c[1]);
    }

    for (int id = 0; id < 10; ++id) {
        const auto rows = readUmans(out / ("output_" + std::to_string(id) + ".csv"));
        BOOST_REQUIRE_MESSAGE(rows.size() > 5u, "agent " << id);
        if (id != 8) BOOST_TEST(std::abs(rows.front().t - kDt) < 1e-9, "agent " << id);  // no t = 0 row
        else BOOST_TEST(rows.front().t > 2.0 - 1e-9);  // agent 8 appears at start_time = 2 s
        for (std::size_t k = 1; k < rows.size(); ++k)
            BOOST_TEST(std::abs(rows[k].t - rows[k - 1].t - kDt) < 1e-6, "agent " << id << " row " << k);
        for (const Row& r : rows) {
            BOOST_TEST((std::isfinite(r.x) && std::isfinite(r.y) && std::isfinite(r.dx) && std::isfinite(r.dy)),
                       "agent " << id << " t " << r.t);
            // The viewing direction is a unit vector (6 significant digits).
            BOOST_TEST(std::abs(std::hypot(r.dx, r.dy) - 1.0) < 1e-4, "agent " << id << " t " << r.t);
        }
        // The last row is the last step the agent spent in the world.
        BOOST_REQUIRE(evacuatedAt.count(id));
        BOOST_TEST(std::abs(rows.back().t - (evacuatedAt[id] - kDt)) < 1e-6, "agent " << id);
    }
}

BOOST_AUTO_TEST_CASE(pedpy_text_has_its_header_and_matches_the_umans_files) {
    const auto text = lines(readFile(out / "trajectories.txt"));
    BOOST_REQUIRE(text.size() > 5u);
    BOOST_TEST(text[0] == "# framerate: 10");
    BOOST_TEST(text[1] == "# x/m");
    BOOST_TEST(text[2] == "# y/m");
    BOOST_TEST(text[3] == "# z/m");
    std::map<long, std::map<long, std::pair<double, double>>> byId;  // id → frame → (x, y)
    long previousFrame = 0;
    for (const std::string& l : text) {
        if (l.empty() || l[0] == '#') continue;
        std::istringstream in(l);
        long id = -1, frame = -1;
        double x, y, z;
        BOOST_REQUIRE_MESSAGE(static_cast<bool>(in >> id >> frame >> x >> y >> z), "row: " << l);
        BOOST_TEST(z == 0.0);
        BOOST_TEST(frame >= previousFrame);  // frame order
        previousFrame = frame;
        byId[id][frame] = {x, y};
    }
    BOOST_TEST(byId.size() == 10u);
    for (auto& [id, frames] : byId) {
        const auto rows = readUmans(out / ("output_" + std::to_string(id) + ".csv"));
        // Frame 0 is the initial state (PedPy wants it); UMANS files start one step later.
        const bool hasFrame0 = frames.count(0) != 0;
        BOOST_TEST(hasFrame0 == (id != 8), "agent " << id);
        BOOST_TEST(frames.size() == rows.size() + (hasFrame0 ? 1u : 0u), "agent " << id);
        for (const Row& r : rows) {
            const long frame = std::lround(r.t / kDt);
            BOOST_REQUIRE_MESSAGE(frames.count(frame), "agent " << id << " frame " << frame);
            BOOST_TEST(std::abs(frames[frame].first - r.x) < 1e-3, "agent " << id << " frame " << frame);
            BOOST_TEST(std::abs(frames[frame].second - r.y) < 1e-3, "agent " << id << " frame " << frame);
        }
    }
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_CASE(end_time_and_seed_from_the_command_line_override_the_scenario) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", umansExample("Circle50-SocialForces.xml"), "-o", "out", "--end-time", "3",
                               "--seed", "42", "-t", "1"});
    BOOST_TEST(r.status == 0, r.err);
    const std::string summary = readFile(dir / "out" / "summary.json");
    BOOST_TEST(jsonValue(summary, "simulated_time") == 3.0);
    BOOST_TEST(jsonValue(summary, "end_time") == 3.0);
    BOOST_TEST(jsonValue(summary, "seed") == 42.0);
    BOOST_TEST(summary.find("\"evacuation_time\": null") != std::string::npos);  // nobody left
    const auto metrics = lines(readFile(dir / "out" / "metrics.csv"));
    BOOST_TEST(metrics.size() == 5u);  // header + t = 0, 1, 2, 3
    BOOST_TEST(metrics.back().rfind("3,50,0,", 0) == 0u, metrics.back());
    // The closing summary on stdout names the essentials.
    BOOST_TEST(r.out.find("30 steps") != std::string::npos, r.out);
    BOOST_TEST(r.out.find("50 total") != std::string::npos, r.out);
    BOOST_TEST(r.out.find("out") != std::string::npos, r.out);
    // Default trajectories: none.
    BOOST_TEST(!fs::exists(dir / "out" / "output_0.csv"));
    BOOST_TEST(!fs::exists(dir / "out" / "trajectories.txt"));
}

BOOST_AUTO_TEST_CASE(trajectories_option_selects_exactly_the_formats_asked_for) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario = umansExample("Circle50-SocialForces.xml");
    const auto countUmansFiles = [](const fs::path& out) {
        std::size_t n = 0;
        for (const auto& e : fs::directory_iterator(out))
            if (e.path().filename().string().rfind("output_", 0) == 0) ++n;
        return n;
    };
    const Result u = run(dir, {"-i", scenario, "-o", "umans", "--end-time", "1", "--trajectories", "umans", "-q"});
    BOOST_TEST(u.status == 0, u.err);
    BOOST_TEST(countUmansFiles(dir / "umans") == 50u);  // one per agent of Circle50
    BOOST_TEST(!fs::exists(dir / "umans" / "trajectories.txt"));
    BOOST_TEST(lines(readFile(dir / "umans" / "output_49.csv")).size() == 10u);  // t = 0.1 … 1

    const Result t = run(dir, {"-i", scenario, "-o", "txt", "--end-time", "1", "--trajectories", "txt", "-q"});
    BOOST_TEST(t.status == 0, t.err);
    BOOST_TEST(countUmansFiles(dir / "txt") == 0u);
    // 4 header lines + the column comment + 50 agents × frames 0 … 10.
    const auto text = lines(readFile(dir / "txt" / "trajectories.txt"));
    std::size_t dataRows = 0;
    for (const auto& l : text) dataRows += (!l.empty() && l[0] != '#') ? 1 : 0;
    BOOST_TEST(dataRows == 50u * 11u);
}

BOOST_AUTO_TEST_CASE(safety_thresholds_of_the_scenario_reach_the_verdict_and_the_heat_map) {
    // Tests/data/health/safety.xml sets <Safety> far below the defaults (2 m cells, dangerous
    // above 0.1 persons/m²): the program's summary.json and heatmap.csv follow it.
    const fs::path dir = freshDir(caseName());
    const std::string scenario = (fs::path(CH_SOURCE_DIR) / "Tests" / "data" / "health" / "safety.xml").string();
    const Result r = run(dir, {"-i", scenario, "-o", "out", "-t", "1", "-q"});
    BOOST_TEST(r.status == 0, r.err);
    const std::string summary = readFile(dir / "out" / "summary.json");
    BOOST_TEST(ch::Json::parse(summary)["verdict"]["level"] == "dangerous", summary);
    BOOST_TEST(jsonValue(summary, "threshold") == 0.1);
    BOOST_TEST(jsonValue(summary, "density_dangerous") == 0.1);  // "safety_thresholds": what judged it
    BOOST_TEST(jsonValue(summary, "cell_size") == 2.0);
    const auto heat = lines(readFile(dir / "out" / "heatmap.csv"));
    BOOST_REQUIRE(heat.size() > 1u);
    const double x = std::stod(split(heat[1], ',')[0]);
    BOOST_TEST(std::fmod(std::abs(x), 2.0) == 1.0, "first heat-map row " << heat[1]);
}

BOOST_AUTO_TEST_CASE(timing_splits_the_wall_time_into_steps_recording_and_the_rest) {
    // --timing adds two lines to the closing summary (and prints them alone with --quiet): seconds
    // in the simulation's steps, in recording, and the rest, which add up to the wall time printed;
    // then the recording by recorder.
    // The doorway base case for 10 s with PedPy trajectories: ~13 % of its loop is recording.
    const fs::path dir = freshDir(caseName());
    const std::string scenario = (fs::path(CH_SOURCE_DIR) / "Examples" / "doorway" / "base-case.xml").string();
    const Result r = run(dir, {"-i", scenario, "-o", "out", "-t", "1", "-q", "--timing", "--end-time", "10",
                               "--trajectories", "txt"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    double wall = -1, steps = -1, recording = -1, other = -1;
    double safety = -1, metrics = -1, measurement = -1, trajectories = -1;
    for (const std::string& l : lines(r.out)) {
        if (l.rfind("  of which ", 0) == 0) {
            BOOST_TEST(std::sscanf(l.c_str(), "  of which %lf s in steps (%*f %%), %lf s recording (%*f %%), %lf s other",
                                   &steps, &recording, &other) == 3, l);
        }
        if (l.rfind("  recording ", 0) == 0) {
            BOOST_TEST(std::sscanf(l.c_str(),
                                   "  recording %lf s safety grid (%*f %%), %lf s metrics (%*f %%), %lf s measurement "
                                   "(%*f %%), %lf s trajectories (%*f %%)",
                                   &safety, &metrics, &measurement, &trajectories) == 4, l);
        }
    }
    wall = steps + recording + other;
    BOOST_TEST(steps > 0, r.out);
    BOOST_TEST(recording > 0, r.out);  // metrics, the safety grid and the verdict's records
    BOOST_TEST(other >= 0, r.out);
    // The recording's parts, each where it runs: the safety grid's records, the metrics rows and
    // the text trajectories every coarse step take time; this scene measures nothing. They add up
    // to the recording (3 significant digits each, and clock readings a few ns apart).
    BOOST_TEST(safety > 0, r.out);
    BOOST_TEST(metrics > 0, r.out);
    BOOST_TEST(trajectories > 0, r.out);
    // (No bound on the measurement's share, whose recorder returns at once without lines or
    // areas: a time of its own is speed, and a preemption of 0.2 ms failed `< 1 %` once under a
    // parallel ctest.)
    BOOST_TEST(measurement >= 0, r.out);
    BOOST_TEST(std::abs(safety + metrics + measurement + trajectories - recording) <= 0.01 * recording, r.out);
    // The loop does nothing else with --quiet: the rest is tiny (~0.1 %; the bound leaves room for
    // the odd preemption between two clock readings), so the recording is counted where it runs.
    BOOST_TEST(other <= 0.05 * wall, r.out);
    BOOST_TEST(r.out.find("wall time") == std::string::npos, r.out);  // --quiet: that line alone
    // Without --quiet it follows the wall time and adds up to it (3 significant digits each).
    const Result full = run(dir, {"-i", testData("evacuation.xml"), "-o", "out2", "-t", "1", "--timing"});
    BOOST_REQUIRE_MESSAGE(full.status == 0, full.err);
    const auto rows = lines(full.out);
    double shownWall = -1, a = -1, b = -1, c = -1;
    for (std::size_t k = 0; k + 1 < rows.size(); ++k)
        if (rows[k].rfind("  wall time ", 0) == 0) {
            shownWall = std::stod(rows[k].substr(rows[k].find('(') + 1));
            BOOST_TEST(std::sscanf(rows[k + 1].c_str(), "  of which %lf s in steps (%*f %%), %lf s recording (%*f %%), %lf s other",
                                   &a, &b, &c) == 3, rows[k + 1]);
        }
    BOOST_TEST(shownWall > 0, full.out);
    BOOST_TEST(std::abs(a + b + c - shownWall) <= 0.01 * shownWall, full.out);
    const Result plain = run(dir, {"-i", testData("evacuation.xml"), "-o", "out3", "-t", "1"});
    BOOST_TEST(plain.out.find("of which") == std::string::npos, plain.out);
}
