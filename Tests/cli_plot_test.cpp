// `crowdhealth plot DIR`, `crowdhealth compare DIR…` and `--plot` (Engine/plot*.{h,cpp},
// Engine/compare.{h,cpp}): the PNGs are drawn, have the expected size and show the runs (their
// pixels are decoded with zlib by png_support.h, independently of gnuplot, and the runs' colours counted);
// the comparison table holds mean ± sd of the inputs; a missing gnuplot is a clear error with
// exit status 1. The run folders are small fake ones written here (metrics.csv, health.csv,
// heatmap.csv, summary.json as DESIGN §6 describes them), so the figures' inputs are known.
#define BOOST_TEST_MODULE cli_plot
#include <boost/test/unit_test.hpp>

#include "cli_support.h"
#include "png_support.h"

#include <zlib.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>

using namespace clitest;

namespace {

// ---- fake run folders ----

void write(const fs::path& file, const std::string& text) { writeText(file, text); }

std::string num(double v) {
    std::ostringstream s;
    s.precision(10);
    s << v;
    return s.str();
}

/// What a fake run is made of.
struct FakeRun {
    double evacuationTime = 60;  ///< s; the metrics rows go up to it (every second)
    double flow = 3;             ///< persons/s
    double densityScale = 1;     ///< mean_density = densityScale · (1 + t/10) until the end
    double contactScale = 1;     ///< mean_contact_accel = contactScale · t / 10
    std::vector<double> headingChanges = {0.1, 0.3};  ///< health.csv mean_abs_heading_change per agent
    int injured = 0;             ///< agents with an injured_at time
    std::string verdict = "caution";
    bool ramp = false;           ///< an extra column SPH.restDensityMax ramping 3 → 7 over 20–40 s
    bool secondRamp = false;     ///< an extra column agents.pref_speed ramping 1 → 1.8 over 45–55 s
};

/// Writes a run folder with metrics.csv, health.csv, heatmap.csv, summary.json.
void writeRun(const fs::path& dir, const FakeRun& r) {
    const int agents = 40;
    std::string m =
        "time,agents,evacuated,mean_density,max_density,mean_rest_density,mean_speed,max_speed,mean_contact_accel,"
        "max_contact_accel,max_wall_penetration,mean_panic,injured,crowd_pressure";
    if (r.ramp) m += ",SPH.restDensityMax";
    if (r.secondRamp) m += ",agents.pref_speed";
    m += "\n";
    const int steps = static_cast<int>(r.evacuationTime);
    for (int k = 0; k <= steps; ++k) {
        const double t = k;
        const int left = agents - agents * k / steps;
        const double density = r.densityScale * (1 + t / 10), contact = r.contactScale * t / 10;
        m += num(t) + "," + std::to_string(left) + "," + std::to_string(agents - left) + "," + num(density) + "," +
             num(2 * density) + ",5," + num(1.0 + 0.2 * std::sin(t / 5)) + ",1.8," + num(contact) + "," +
             num(3 * contact) + ",0.1," + num(0.5 * t / r.evacuationTime) + "," +
             std::to_string(r.injured * k / steps) + "," + num(0.01 * t);
        if (r.ramp) m += "," + num(t <= 20 ? 3.0 : t >= 40 ? 7.0 : 3 + 4 * (t - 20) / 20);
        if (r.secondRamp) m += "," + num(t <= 45 ? 1.0 : t >= 55 ? 1.8 : 1 + 0.8 * (t - 45) / 10);
        m += "\n";
    }
    write(dir / "metrics.csv", m);

    std::string h = "id,peak_contact_accel,peak_force,time_above_threshold,dose,injured_at,peak_panic,exit_time,"
                    "mean_abs_heading_change\n";
    for (std::size_t i = 0; i < std::max<std::size_t>(r.headingChanges.size(), std::size_t(r.injured)); ++i) {
        const bool injured = static_cast<int>(i) < r.injured;
        h += std::to_string(i) + ",5,400,1,10," + (injured ? std::string("12.5") : std::string()) + ",0.4,30," +
             (i < r.headingChanges.size() ? num(r.headingChanges[i]) : std::string()) + "\n";
    }
    write(dir / "health.csv", h);

    std::string g = "x,y,max_density,max_contact_accel,seconds_above_density_threshold,seconds_above_crush_threshold\n";
    for (int j = 0; j < 10; ++j)
        for (int i = 0; i < 12; ++i) {
            const double x = 0.5 + i, y = 0.5 + j;
            const double near = std::exp(-((x - 10) * (x - 10) + (y - 5) * (y - 5)) / 8);
            g += num(x) + "," + num(y) + "," + num(7 * near) + "," + num(30 * near) + "," + num(near > 0.5 ? 20 * near : 0) +
                 "," + num(near > 0.7 ? 10 * near : 0) + "\n";
        }
    write(dir / "heatmap.csv", g);

    write(dir / "summary.json", "{\n  \"scenario\": \"fake.xml\",\n  \"seed\": 1,\n  \"interrupted\": false,\n"
                                "  \"evacuation_time\": " + num(r.evacuationTime) + ",\n"
                                "  \"flow\": {\"first\": 1, \"last\": 35, \"persons_per_second\": " + num(r.flow) + "},\n"
                                "  \"verdict\": {\"level\": \"" + r.verdict + "\", \"reasons\": []}\n}\n");
}

/// A replications folder with the runs `runs` (run_000 …) and nothing else.
void writeReplications(const fs::path& dir, const std::vector<FakeRun>& runs) {
    for (std::size_t k = 0; k < runs.size(); ++k) {
        std::string name = std::to_string(k);
        name = "run_" + std::string(3 - name.size(), '0') + name;
        writeRun(dir / name, runs[k]);
    }
}

/// Runs the program with gnuplot out of reach: PATH holds only an empty folder.
Result runWithoutGnuplot(const fs::path& dir, const std::vector<std::string>& args) {
    const fs::path empty = dir / "empty-path";
    fs::create_directories(empty);
    std::string prefix = "env -u CROWDHEALTH_GNUPLOT PATH=";
    prefix += shellQuote(empty.string());
    return runIn(dir, prefix, CH_BINARY, args);
}

constexpr std::uint32_t kRun0Colour = 0x1f77b4, kRun1Colour = 0xff7f0e, kRun2Colour = 0x2ca02c;

/// A CSV line's cells ("…" quoting, "" inside quotes).
std::vector<std::string> csvCells(const std::string& line) {
    std::vector<std::string> cells(1);
    bool inQuotes = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (inQuotes && c == '"' && i + 1 < line.size() && line[i + 1] == '"') cells.back() += '"', ++i;
        else if (c == '"') inQuotes = !inQuotes;
        else if (c == ',' && !inQuotes) cells.emplace_back();
        else cells.back() += c;
    }
    return cells;
}

/// compare.csv as rows of cells by column name.
std::vector<std::map<std::string, std::string>> readCompareCsv(const fs::path& file) {
    const auto all = lines(readFile(file));
    BOOST_REQUIRE(!all.empty());
    const auto header = split(all[0], ',');
    std::vector<std::map<std::string, std::string>> rows;
    for (std::size_t i = 1; i < all.size(); ++i) {
        const auto c = csvCells(all[i]);
        BOOST_REQUIRE_EQUAL(c.size(), header.size());
        std::map<std::string, std::string> row;
        for (std::size_t k = 0; k < c.size(); ++k) row[header[k]] = c[k];
        rows.push_back(row);
    }
    return rows;
}

}  // namespace

BOOST_AUTO_TEST_CASE(plot_draws_every_figure_of_replications) {
    const fs::path dir = freshDir(caseName());
    FakeRun a, b, c;
    a.ramp = b.ramp = c.ramp = true;
    b.evacuationTime = 70;
    b.densityScale = 1.2;
    c.evacuationTime = 50;
    c.contactScale = 2;
    writeReplications(dir / "reps", {a, b, c});

    const Result r = run(dir, {"plot", "reps"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);
    BOOST_TEST(r.out.find("fig3.png") != std::string::npos);

    const std::map<std::string, std::pair<std::uint32_t, std::uint32_t>> expected = {
        {"fig3.png", {1600, 1100}}, {"health.png", {1600, 1100}}, {"schedule.png", {1400, 500}}, {"heatmap.png", {1700, 850}}};
    for (const auto& [name, size] : expected) {
        BOOST_TEST_CONTEXT(name) {
            const fs::path png = dir / "reps" / name;
            BOOST_REQUIRE(fs::exists(png));
            BOOST_TEST(!fs::exists(png.string() + ".tmp"));
            const Image img = decodePng(png);
            BOOST_TEST(img.width == size.first);
            BOOST_TEST(img.height == size.second);
            // Not blank: far more than the white background, the black text and the grid.
            BOOST_TEST(img.distinctColours() > 20u);
            if (name == "fig3.png" || name == "health.png") {
                // Each replication in its own colour: every run's colour is drawn (its curves and key sample).
                BOOST_TEST(img.count(kRun0Colour) > 200u);
                BOOST_TEST(img.count(kRun1Colour) > 200u);
                BOOST_TEST(img.count(kRun2Colour) > 200u);
            }
            if (name == "fig3.png") BOOST_TEST(img.count(0xe6e6e6) > 5000u);  // the ramp window, shaded
        }
    }
    // A second `plot` replaces the figures (and a run folder on its own works too).
    BOOST_REQUIRE_EQUAL(run(dir, {"plot", "reps/run_001", "-q"}).status, 0);
    BOOST_TEST(fs::exists(dir / "reps" / "run_001" / "fig3.png"));
    BOOST_TEST(fs::exists(dir / "reps" / "run_001" / "heatmap.png"));
}

BOOST_AUTO_TEST_CASE(schedule_shades_each_parameters_own_ramp) {
    // Two parameters ramped one after the other (20–40 s, then 45–55 s, of a 60 s run): each panel
    // of schedule.png shades its own parameter's ramp, not the span from the first start to the
    // last end, and the two panels' time axes line up.
    const fs::path dir = freshDir(caseName());
    FakeRun a;
    a.ramp = a.secondRamp = true;
    writeRun(dir / "one", a);
    const Result r = run(dir, {"plot", "one", "-q"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);
    const Image img = decodePng(dir / "one" / "schedule.png");
    BOOST_REQUIRE(img.width > 0u);
    // The shaded columns of each half of the figure (over 100 pixels of the band's grey 0xe6e6e6:
    // antialiased text and lines have a few), and each half's x axis: the columns of its longest
    // run of black pixels along a row (a border).
    auto shaded = [&](std::uint32_t y0, std::uint32_t y1) {
        std::pair<std::uint32_t, std::uint32_t> span{img.width, 0};
        for (std::uint32_t x = 0; x < img.width; ++x) {
            std::size_t grey = 0;
            for (std::uint32_t y = y0; y < y1; ++y) {
                const auto& p = img.pixels[std::size_t(y) * img.width + x];
                grey += p[0] == 0xe6 && p[1] == 0xe6 && p[2] == 0xe6;
            }
            if (grey > 100) span = {std::min(span.first, x), std::max(span.second, x)};
        }
        return span;
    };
    auto axis = [&](std::uint32_t y0, std::uint32_t y1) {
        std::pair<std::uint32_t, std::uint32_t> best{0, 0};
        for (std::uint32_t y = y0; y < y1; ++y)
            for (std::uint32_t x = 0, run = 0; x < img.width; ++x) {
                const auto& p = img.pixels[std::size_t(y) * img.width + x];
                run = (p[0] < 0x40 && p[1] < 0x40 && p[2] < 0x40) ? run + 1 : 0;
                if (run > best.second - best.first) best = {x + 1 - run, x};
            }
        return best;
    };
    const std::uint32_t mid = img.height / 2;
    const auto top = shaded(0, mid), bottom = shaded(mid, img.height);
    const auto topAxis = axis(0, mid), bottomAxis = axis(mid, img.height);
    BOOST_REQUIRE(top.first < top.second);
    BOOST_REQUIRE(bottom.first < bottom.second);
    BOOST_TEST(top.second < bottom.first);  // 20–40 s lies wholly left of 45–55 s
    const double pxPerSecond = double(topAxis.second - topAxis.first) / 60;
    BOOST_TEST(std::abs(double(top.second - top.first) - 20 * pxPerSecond) < 4);      // 20 s wide
    BOOST_TEST(std::abs(double(bottom.second - bottom.first) - 10 * pxPerSecond) < 4);  // 10 s wide
    BOOST_TEST(std::abs(double(topAxis.first) - double(bottomAxis.first)) <= 1);  // the axes line up
    BOOST_TEST(std::abs(double(topAxis.second) - double(bottomAxis.second)) <= 1);
}

BOOST_AUTO_TEST_CASE(plot_without_schedule_or_heatmap) {
    const fs::path dir = freshDir(caseName());
    writeRun(dir / "one", FakeRun{});
    fs::remove(dir / "one" / "heatmap.csv");
    write(dir / "one" / "schedule.png", "stale");
    const Result r = run(dir, {"plot", "one"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);
    BOOST_TEST(fs::exists(dir / "one" / "fig3.png"));
    BOOST_TEST(fs::exists(dir / "one" / "health.png"));
    BOOST_TEST(!fs::exists(dir / "one" / "schedule.png"));  // no ramp: the stale one is gone
    BOOST_TEST(!fs::exists(dir / "one" / "heatmap.png"));
    BOOST_TEST(r.out.find("no heatmap.csv") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(plot_rejects_a_folder_without_runs) {
    const fs::path dir = freshDir(caseName());
    fs::create_directories(dir / "nothing");
    Result r = run(dir, {"plot", "nothing"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("not a crowdhealth output folder") != std::string::npos);
    r = run(dir, {"plot"});
    BOOST_TEST(r.status == 2);
    r = run(dir, {"compare", "missing"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("no such folder") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(compare_writes_mean_and_sd) {
    const fs::path dir = freshDir(caseName());
    // alpha: three runs. Evacuation 90/100/110 s → 100 ± 10; flow 2/3/4 → 3 ± 1;
    // density @15 s = scale·2.5 with scales 1, 1.2, 1.4 → 3 ± 0.5; peak mean contact = scale·T/10.
    std::vector<FakeRun> alpha(3);
    const double scales[] = {1.0, 1.2, 1.4};
    for (int k = 0; k < 3; ++k) {
        alpha[k].evacuationTime = 90 + 10 * k;
        alpha[k].flow = 2 + k;
        alpha[k].densityScale = scales[k];
        alpha[k].headingChanges = {0.1 * (k + 1), 0.3 * (k + 1)};  // run means 0.2, 0.4, 0.6 → 0.4 ± 0.2
        alpha[k].injured = 2 * k;                                   // 0, 2, 4 → 2 ± 2
        alpha[k].verdict = k == 2 ? "critical" : "dangerous";
    }
    writeReplications(dir / "alpha", alpha);
    FakeRun beta;
    beta.evacuationTime = 50;
    beta.flow = 5;
    writeRun(dir / "beta", beta);

    const Result r = run(dir, {"compare", "alpha", "beta/", "-o", "cmp"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);

    // Printed and written as Markdown.
    const std::string md = readFile(dir / "cmp" / "compare.md");
    for (const std::string& text : {r.out, md}) {
        BOOST_TEST(text.find("| alpha ") != std::string::npos);
        BOOST_TEST(text.find("| beta ") != std::string::npos);
        BOOST_TEST(text.find("100.0 ± 10.0") != std::string::npos);  // evacuation time
        BOOST_TEST(text.find("3.00 ± 1.00") != std::string::npos);    // flow
        BOOST_TEST(text.find("3.00 ± 0.50") != std::string::npos);    // density @15 s
        BOOST_TEST(text.find("0.40 ± 0.20") != std::string::npos);    // erraticness
        BOOST_TEST(text.find("2.0 ± 2.0") != std::string::npos);      // injured
        BOOST_TEST(text.find("critical 1, dangerous 2") != std::string::npos);
        BOOST_TEST(text.find("evacuation time (s)") != std::string::npos);
    }

    const auto rows = readCompareCsv(dir / "cmp" / "compare.csv");
    BOOST_REQUIRE_EQUAL(rows.size(), 2u);
    const auto& a = rows[0];
    BOOST_TEST(a.at("experiment") == "alpha");
    BOOST_TEST(a.at("runs") == "3");
    auto value = [](const std::map<std::string, std::string>& row, const std::string& key) { return std::stod(row.at(key)); };
    BOOST_TEST(value(a, "evacuation_time_mean") == 100.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "evacuation_time_sd") == 10.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "flow_mean") == 3.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "flow_sd") == 1.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "mean_density_at_15s_mean") == 3.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "mean_density_at_15s_sd") == 0.5, boost::test_tools::tolerance(1e-9));
    // Peaks are over the rows with people in the world: the last row (t = T, nobody left) has no
    // crowd to measure, so the peak is at t = T − 1. Peak mean density: scale·(1 + (T−1)/10) =
    // 9.9, 13.08, 16.66.
    BOOST_TEST(value(a, "peak_mean_density_mean") == (9.9 + 13.08 + 16.66) / 3, boost::test_tools::tolerance(1e-9));
    // Peak mean / max contact acceleration: (T−1)/10 = 8.9, 9.9, 10.9 and three times that.
    BOOST_TEST(value(a, "peak_mean_contact_accel_mean") == 9.9, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "peak_mean_contact_accel_sd") == 1.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "peak_max_contact_accel_mean") == 29.7, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "erraticness_mean") == 0.4, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "erraticness_sd") == 0.2, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "injured_mean") == 2.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(value(a, "injured_sd") == 2.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(a.at("evacuation_time_n") == "3");
    BOOST_TEST(a.at("verdicts") == "critical 1, dangerous 2");

    const auto& b = rows[1];
    BOOST_TEST(b.at("experiment") == "beta");
    BOOST_TEST(b.at("runs") == "1");
    BOOST_TEST(value(b, "evacuation_time_mean") == 50.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(b.at("evacuation_time_sd").empty());  // one run: no sd
    BOOST_TEST(value(b, "flow_mean") == 5.0, boost::test_tools::tolerance(1e-9));

    // The overlay of the mean curves: one colour per experiment.
    const Image img = decodePng(dir / "cmp" / "compare.png");
    BOOST_TEST(img.width == 1600u);
    BOOST_TEST(img.height == 1500u);
    BOOST_TEST(img.count(kRun0Colour) > 200u);
    BOOST_TEST(img.count(kRun1Colour) > 200u);
}

BOOST_AUTO_TEST_CASE(missing_gnuplot_is_a_clear_error) {
    const fs::path dir = freshDir(caseName());
    writeRun(dir / "one", FakeRun{});

    Result r = runWithoutGnuplot(dir, {"plot", "one"});
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("needs gnuplot") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "one" / "fig3.png"));

    // --plot says so before anything is simulated or written.
    r = runWithoutGnuplot(dir, {"-i", testData("doorway-small.xml"), "-o", "out", "--plot", "-q"});
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("--plot needs gnuplot") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"));
    r = runWithoutGnuplot(dir, {"-i", testData("doorway-small.xml"), "-o", "out", "--replications", "2", "--plot"});
    BOOST_TEST(r.status == 1);
    BOOST_TEST(!fs::exists(dir / "out"));

    // compare writes its tables all the same, and needs no gnuplot with --no-plot.
    r = runWithoutGnuplot(dir, {"compare", "one", "-o", "cmp"});
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("needs gnuplot") != std::string::npos, r.err);
    BOOST_TEST(fs::exists(dir / "cmp" / "compare.md"));
    BOOST_TEST(!fs::exists(dir / "cmp" / "compare.png"));
    r = runWithoutGnuplot(dir, {"compare", "one", "-o", "cmp2", "--no-plot"});
    BOOST_TEST(r.status == 0);
    BOOST_TEST(fs::exists(dir / "cmp2" / "compare.csv"));

    // CROWDHEALTH_GNUPLOT naming a missing program is reported as such.
    std::string cmd = "cd ";
    cmd += shellQuote(dir.string());
    cmd += " && CROWDHEALTH_GNUPLOT=/nonexistent/gnuplot ";
    cmd += shellQuote(CH_BINARY);
    cmd += " plot one 2>err.txt >/dev/null";
    const int raw = std::system(cmd.c_str());
    BOOST_TEST((WIFEXITED(raw) && WEXITSTATUS(raw) == 1));
    BOOST_TEST(readFile(dir / "err.txt").find("CROWDHEALTH_GNUPLOT") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(run_and_replications_with_plot) {
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"-i", testData("doorway-small.xml"), "-o", "single", "--plot", "--end-time", "20", "-q"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);
    BOOST_TEST(fs::exists(dir / "single" / "fig3.png"));
    BOOST_TEST(fs::exists(dir / "single" / "health.png"));
    // A run always writes heatmap.csv, so --plot must draw heatmap.png (a check of the form
    // exists(png) == exists(csv) would also pass when neither was written).
    BOOST_TEST(fs::exists(dir / "single" / "heatmap.csv"));
    BOOST_TEST(fs::exists(dir / "single" / "heatmap.png"));
    if (fs::exists(dir / "single" / "heatmap.png")) {
        const Image heat = decodePng(dir / "single" / "heatmap.png");
        BOOST_TEST(heat.width == 1700u);
        BOOST_TEST(heat.distinctColours() > 20u);  // a map, not a blank page
    }

    r = run(dir, {"-i", testData("doorway-small.xml"), "-o", "reps", "--replications", "2", "--plot", "--end-time", "20"});
    BOOST_TEST_INFO("stderr: " << r.err);
    BOOST_REQUIRE_EQUAL(r.status, 0);
    BOOST_TEST(r.out.find("plots") != std::string::npos);
    const Image img = decodePng(dir / "reps" / "fig3.png");
    BOOST_TEST(img.width == 1600u);
    BOOST_TEST(img.count(kRun0Colour) > 200u);
    BOOST_TEST(img.count(kRun1Colour) > 200u);
    BOOST_TEST(!fs::exists(dir / "reps" / "run_000" / "fig3.png"));  // the figures of the set, in OUTDIR

    // --plot with --check is a usage error.
    r = run(dir, {"-i", testData("doorway-small.xml"), "--check", "--plot"});
    BOOST_TEST(r.status == 2);
}
