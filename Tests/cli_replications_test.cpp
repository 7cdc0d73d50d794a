// `crowdhealth --replications N`: seeds S … S+N−1 run several at a time into OUTDIR/run_000 …,
// each a normal run folder identical to the single run with --seed S+k, plus OUTDIR/summary.csv
// (one row per run, then mean, sd and n) and its table on stdout. Scenario errors exit 2 and
// write nothing; Ctrl-C (the hidden --debug-interrupt-after, a real SIGINT at a known step) marks
// the interrupted run. Tests/data/cli/doorway-small.xml: 42 agents from an <AgentGrid> (radii
// drawn from the seed) leave a small room through a door, seed 11.
#define BOOST_TEST_MODULE cli_replications
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/json.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

using namespace clitest;

namespace {

constexpr std::uint64_t kScenarioSeed = 11;  // Simulation@seed of doorway-small.xml

const std::vector<std::string> kColumns = {
    "run", "seed", "evacuated", "evacuation_time", "flow", "peak_mean_density", "mean_density_at_15s",
    "peak_max_contact_accel", "peak_wall_penetration", "interrupted"};
const std::vector<std::string> kStatColumns = {
    "evacuated", "evacuation_time", "flow", "peak_mean_density", "mean_density_at_15s",
    "peak_max_contact_accel", "peak_wall_penetration"};

std::string scenario() { return testData("doorway-small.xml"); }

/// summary.csv as rows of cells by column name (the header is checked here).
struct SummaryCsv {
    std::vector<std::map<std::string, std::string>> rows;
    explicit SummaryCsv(const std::string& text) {
        const auto all = lines(text);
        BOOST_REQUIRE(!all.empty());
        const auto header = split(all[0], ',');
        BOOST_REQUIRE(header == kColumns);
        for (std::size_t i = 1; i < all.size(); ++i) {
            const auto c = split(all[i], ',');
            BOOST_REQUIRE_MESSAGE(c.size() == kColumns.size(), "summary.csv line " << i << ": " << all[i]);
            std::map<std::string, std::string> row;
            for (std::size_t k = 0; k < c.size(); ++k) row[kColumns[k]] = c[k];
            rows.push_back(row);
        }
    }
};

std::optional<double> number(const std::string& cell) {
    if (cell.empty()) return std::nullopt;
    return std::stod(cell);
}

/// |a − b| small relative to the values (summary.csv has 10 significant digits).
bool close(double a, double b, double scale) {
    return std::abs(a - b) <= 1e-8 * std::max({1.0, std::abs(a), std::abs(b), std::abs(scale)});
}

/// The metrics.csv column `name` by row.
std::vector<std::vector<std::string>> metricsRows(const fs::path& file) {
    std::vector<std::vector<std::string>> rows;
    const auto all = lines(readFile(file));
    for (std::size_t i = 1; i < all.size(); ++i) rows.push_back(split(all[i], ','));
    return rows;
}

/// Everything of summary.json but the lines that may differ between a single run and a
/// replication run (thread count, wall time).
std::string summaryWithoutMachine(const fs::path& file) {
    std::string kept;
    for (const std::string& l : lines(readFile(file)))
        if (l.find("\"threads\"") == std::string::npos && l.find("\"wall_time_s\"") == std::string::npos) kept += l + "\n";
    return kept;
}

/// One run of 3 replications with 2 at a time, shared by the test cases of the suite.
struct ThreeReplications {
    fs::path dir, out;
    Result result;
    ThreeReplications() {
        dir = freshDir("three_replications");
        out = dir / "out";
        result = run(dir, {"-i", scenario(), "-o", "out", "--replications", "3", "-t", "2"});
    }
};

}  // namespace

BOOST_FIXTURE_TEST_SUITE(three_replications, ThreeReplications)

BOOST_AUTO_TEST_CASE(each_run_folder_holds_the_files_of_a_single_run_and_nothing_is_left_half_written) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    for (const char* name : {"run_000", "run_001", "run_002"}) {
        for (const char* f : {"metrics.csv", "evacuations.csv", "summary.json"})
            BOOST_TEST(fs::is_regular_file(out / name / f), name << "/" << f);
        const std::string summary = readFile(out / name / "summary.json");
        BOOST_TEST(summary.find("\"interrupted\": false") != std::string::npos, name);
        BOOST_TEST(jsonValue(summary, "threads") == 1, name);  // each run on one thread
        BOOST_TEST(lines(readFile(out / name / "metrics.csv")).size() > 2u, name);
    }
    BOOST_TEST(!fs::exists(out / "run_003"));
    BOOST_TEST(fs::is_regular_file(out / "summary.csv"));
    BOOST_TEST(tmpFiles(dir).empty());
}

BOOST_AUTO_TEST_CASE(summary_csv_has_one_row_per_run_with_the_values_of_its_folder) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    const SummaryCsv csv(readFile(out / "summary.csv"));
    BOOST_REQUIRE(csv.rows.size() == 6u);  // 3 runs, mean, sd, n
    for (std::size_t k = 0; k < 3; ++k) {
        const auto& row = csv.rows[k];
        const std::string name = "run_00" + std::to_string(k);
        BOOST_TEST(row.at("run") == name);
        BOOST_TEST(row.at("seed") == std::to_string(kScenarioSeed + k));
        BOOST_TEST(row.at("interrupted") == "false");

        // The run's own summary.json says the same.
        const std::string summary = readFile(out / name / "summary.json");
        BOOST_TEST(jsonValue(summary, "seed") == static_cast<double>(kScenarioSeed + k));
        BOOST_TEST(std::stod(row.at("evacuated")) == jsonValue(summary, "evacuated"), name);
        for (const auto& [column, key] : std::vector<std::pair<std::string, std::string>>{
                 {"evacuation_time", "evacuation_time"}, {"flow", "persons_per_second"},
                 {"peak_mean_density", "max_mean_density"}, {"peak_max_contact_accel", "max_contact_accel"},
                 {"peak_wall_penetration", "max_wall_penetration"}}) {
            const double json = jsonValue(summary, key);
            const std::optional<double> cell = number(row.at(column));
            BOOST_TEST(cell.has_value() == !std::isnan(json), name << " " << column);
            if (cell && !std::isnan(json)) BOOST_TEST(close(*cell, json, json), name << " " << column);
        }
        BOOST_TEST(!row.at("evacuation_time").empty(), name << ": everyone leaves before end_time");

        // mean_density_at_15s: the mean_density of the metrics row at t = 15 s (metrics every
        // 0.5 s); empty when the run ended before 15 s.
        std::optional<std::string> at15;
        for (const auto& m : metricsRows(out / name / "metrics.csv"))
            if (std::abs(std::stod(m[0]) - 15.0) < 1e-9) at15 = m[3];
        BOOST_TEST(row.at("mean_density_at_15s").empty() == !at15.has_value(), name);
        if (at15 && !row.at("mean_density_at_15s").empty())
            BOOST_TEST(close(std::stod(row.at("mean_density_at_15s")), std::stod(*at15), 1.0), name);
    }
}

BOOST_AUTO_TEST_CASE(mean_sd_and_n_rows_are_those_of_the_run_rows) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    const SummaryCsv csv(readFile(out / "summary.csv"));
    BOOST_REQUIRE(csv.rows.size() == 6u);
    const auto& mean = csv.rows[3];
    const auto& sd = csv.rows[4];
    const auto& n = csv.rows[5];
    BOOST_TEST(mean.at("run") == "mean");
    BOOST_TEST(sd.at("run") == "sd");
    BOOST_TEST(n.at("run") == "n");
    for (const auto* row : {&mean, &sd, &n}) {
        BOOST_TEST(row->at("seed").empty());
        BOOST_TEST(row->at("interrupted").empty());
    }
    for (const std::string& column : kStatColumns) {
        std::vector<double> values;  // empty cells are ignored
        for (std::size_t k = 0; k < 3; ++k)
            if (const auto v = number(csv.rows[k].at(column))) values.push_back(*v);
        BOOST_TEST(n.at(column) == std::to_string(values.size()), column);
        if (values.empty()) {
            BOOST_TEST(mean.at(column).empty(), column);
            BOOST_TEST(sd.at(column).empty(), column);
            continue;
        }
        double sum = 0;
        for (const double v : values) sum += v;
        const double m = sum / static_cast<double>(values.size());
        BOOST_REQUIRE_MESSAGE(!mean.at(column).empty(), column);
        BOOST_TEST(close(std::stod(mean.at(column)), m, m), column << ": mean " << mean.at(column) << " vs " << m);
        if (values.size() < 2) {
            BOOST_TEST(sd.at(column).empty(), column);  // undefined for one value
            continue;
        }
        double squares = 0;
        for (const double v : values) squares += (v - m) * (v - m);
        const double s = std::sqrt(squares / static_cast<double>(values.size() - 1));  // sample sd, N − 1
        BOOST_REQUIRE_MESSAGE(!sd.at(column).empty(), column);
        BOOST_TEST(close(std::stod(sd.at(column)), s, m), column << ": sd " << sd.at(column) << " vs " << s);
    }
}

BOOST_AUTO_TEST_CASE(run_k_is_byte_identical_to_a_single_run_with_seed_s_plus_k) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    for (std::size_t k = 0; k < 3; ++k) {
        const std::string single = "single" + std::to_string(k);
        const Result r = run(dir, {"-i", scenario(), "-o", single, "--seed", std::to_string(kScenarioSeed + k), "-q"});
        BOOST_TEST_REQUIRE(r.status == 0, r.err);
        const fs::path rep = out / ("run_00" + std::to_string(k));
        BOOST_TEST((readFile(dir / single / "metrics.csv") == readFile(rep / "metrics.csv")), "run " << k);
        BOOST_TEST((readFile(dir / single / "evacuations.csv") == readFile(rep / "evacuations.csv")), "run " << k);
        BOOST_TEST(summaryWithoutMachine(dir / single / "summary.json") == summaryWithoutMachine(rep / "summary.json"),
                   "run " << k);
    }
}

BOOST_AUTO_TEST_CASE(different_seeds_give_different_runs) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    const std::string m0 = readFile(out / "run_000" / "metrics.csv");
    const std::string m1 = readFile(out / "run_001" / "metrics.csv");
    const std::string m2 = readFile(out / "run_002" / "metrics.csv");
    BOOST_TEST((m0 != m1));
    BOOST_TEST((m1 != m2));
    BOOST_TEST((m0 != m2));
    BOOST_TEST((readFile(out / "run_000" / "evacuations.csv") != readFile(out / "run_001" / "evacuations.csv")));
}

BOOST_AUTO_TEST_CASE(stdout_shows_the_table_and_the_total_wall_time) {
    BOOST_TEST_REQUIRE(result.status == 0, result.err);
    const auto out = lines(result.out);
    // The header line of the table names every column but "interrupted" (no run was).
    const auto header = std::find_if(out.begin(), out.end(), [](const std::string& l) { return l.rfind("run ", 0) == 0; });
    BOOST_REQUIRE(header != out.end());
    for (std::size_t c = 0; c + 1 < kColumns.size(); ++c) BOOST_TEST(header->find(kColumns[c]) != std::string::npos);
    BOOST_TEST(header->find("interrupted") == std::string::npos);
    // Aligned: every row of the table is as long as the header at most, the runs and
    // statistics start with their label.
    std::vector<std::string> labels;
    for (auto it = header + 1; it != out.end() && !it->empty(); ++it) {
        BOOST_TEST(it->size() <= header->size() + 0u, *it);
        labels.push_back(it->substr(0, it->find(' ')));
    }
    const std::vector<std::string> expected = {"run_000", "run_001", "run_002", std::string(header->size(), '-'),
                                               "mean", "sd", "n"};
    BOOST_TEST(labels == expected, boost::test_tools::per_element());
    BOOST_TEST(result.out.find("total wall time") != std::string::npos, result.out);
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_CASE(quiet_prints_nothing_on_stdout_and_one_replication_still_writes_a_summary) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", scenario(), "-o", "out", "--replications", "1", "--seed", "5", "-q"});
    BOOST_TEST_REQUIRE(r.status == 0, r.err);
    BOOST_TEST(r.out.empty());
    const SummaryCsv csv(readFile(dir / "out" / "summary.csv"));
    BOOST_REQUIRE(csv.rows.size() == 4u);
    BOOST_TEST(csv.rows[0].at("seed") == "5");
    BOOST_TEST(csv.rows[1].at("evacuated") == csv.rows[0].at("evacuated"));  // the mean of one value
    BOOST_TEST(csv.rows[2].at("evacuated").empty());                         // no sd of one value
    BOOST_TEST(csv.rows[3].at("evacuated") == "1");
}

BOOST_AUTO_TEST_CASE(flow_first_and_last_from_the_command_line_apply_to_every_run) {
    const fs::path dir = freshDir(caseName());
    const Result r =
        run(dir, {"-i", scenario(), "-o", "out", "--replications", "2", "--flow-first", "5", "--flow-last", "30", "-q"});
    BOOST_TEST_REQUIRE(r.status == 0, r.err);
    const SummaryCsv csv(readFile(dir / "out" / "summary.csv"));
    for (std::size_t k = 0; k < 2; ++k) {
        const fs::path folder = dir / "out" / ("run_00" + std::to_string(k));
        const auto evac = lines(readFile(folder / "evacuations.csv"));
        BOOST_REQUIRE(evac.size() > 30u);
        const double t5 = std::stod(split(evac[5], ',')[1]), t30 = std::stod(split(evac[30], ',')[1]);
        const double flow = 25.0 / (t30 - t5);
        BOOST_TEST(close(std::stod(csv.rows[k].at("flow")), flow, flow), "run " << k);
        const std::string summary = readFile(folder / "summary.json");
        const ch::Json flowJson = ch::Json::parse(summary)["flow"];
        BOOST_TEST(flowJson["first"] == 5, summary);
        BOOST_TEST(flowJson["last"] == 30, summary);
    }
}

BOOST_AUTO_TEST_CASE(sigint_stops_the_run_going_starts_no_other_and_marks_it_interrupted) {
    // One run at a time: run_000 gets the SIGINT after 50 coarse steps (t = 5 s); run_001 and
    // run_002 never start.
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", scenario(), "-o", "out", "--replications", "3", "-t", "1",
                               "--debug-interrupt-after", "50", "-q"});
    BOOST_TEST(r.status == 130, r.err);
    BOOST_TEST(r.err.find("interrupted") != std::string::npos, r.err);
    const fs::path out = dir / "out";
    const std::string summary = readFile(out / "run_000" / "summary.json");
    BOOST_TEST(summary.find("\"interrupted\": true") != std::string::npos, summary);
    BOOST_TEST(std::abs(jsonValue(summary, "simulated_time") - 5.0) < 1e-9);
    BOOST_TEST(!fs::exists(out / "run_001"));
    BOOST_TEST(!fs::exists(out / "run_002"));

    const SummaryCsv csv(readFile(out / "summary.csv"));
    BOOST_REQUIRE(csv.rows.size() == 4u);  // run_000, mean, sd, n
    BOOST_TEST(csv.rows[0].at("run") == "run_000");
    BOOST_TEST(csv.rows[0].at("interrupted") == "true");
    BOOST_TEST(csv.rows[0].at("evacuation_time").empty());  // agents were still in the room
    for (const std::string& column : kStatColumns) {  // an interrupted run is not averaged
        BOOST_TEST(csv.rows[1].at(column).empty(), column);
        BOOST_TEST(csv.rows[3].at(column) == "0", column);
    }
    BOOST_TEST(tmpFiles(dir).empty());

    // Its folder is that of a single run interrupted at the same step.
    const Result single = run(dir, {"-i", scenario(), "-o", "single", "--debug-interrupt-after", "50", "-q"});
    BOOST_TEST(single.status == 130, single.err);
    BOOST_TEST((readFile(dir / "single" / "metrics.csv") == readFile(out / "run_000" / "metrics.csv")));
}

BOOST_AUTO_TEST_CASE(broken_scenario_exits_2_and_writes_nothing) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", testData("broken.xml"), "-o", "out", "--replications", "3"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("broken.xml:8: error:") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"));
    BOOST_TEST(r.out.empty());
}

BOOST_AUTO_TEST_CASE(bad_replication_options_exit_2_and_write_nothing) {
    const fs::path dir = freshDir(caseName());
    const std::vector<std::vector<std::string>> bad = {
        {"-i", scenario(), "-o", "out", "--replications", "0"},
        {"-i", scenario(), "-o", "out", "--replications", "three"},
        {"-i", scenario(), "-o", "out", "--replications", "-2"},
        {"-i", scenario(), "--check", "--replications", "2"},
        {"-i", scenario(), "-o", "out", "--replications", "2", "--flow-first", "0"},
        {"-i", scenario(), "-o", "out", "--replications", "2", "--flow-first", "9", "--flow-last", "9"},
        // Only one given: checked against the scenario's other one (flow_last defaults to 350).
        {"-i", scenario(), "-o", "out", "--replications", "2", "--flow-first", "400"},
        // The last seed would not fit in 64 bits.
        {"-i", scenario(), "-o", "out", "--replications", "3", "--seed", "18446744073709551614"},
    };
    for (const auto& args : bad) {
        std::string shown;
        for (const auto& a : args) shown += a + " ";
        const Result r = run(dir, args);
        BOOST_TEST(r.status == 2, "args: " << shown);
        BOOST_TEST(r.err.find("error") != std::string::npos, "args: " << shown << " stderr: " << r.err);
        BOOST_TEST(!fs::exists(dir / "out"), "args: " << shown);
    }
}
