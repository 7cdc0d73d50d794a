// crowdhealth compare — see compare.h and docs/crowd-health.md ("Plots").
#include "compare.h"

#include "exit_codes.h"
#include "plot.h"
#include "output_folder.h"
#include "plot_gnuplot.h"

#include <crowdhealth/io/output.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <iostream>
#include <map>
#include <set>

namespace chplot {

const std::vector<CompareColumn> kCompareColumns = {
    {"evacuation_time", "evacuation time (s)", 1},
    {"flow", "flow (P/s)", 2},
    {"mean_density_at_15s", "density @15 s (1/m²)", 2},
    {"peak_mean_density", "peak density (1/m²)", 2},
    {"peak_mean_contact_accel", "peak mean contact acc. (m/s²)", 2},
    {"peak_max_contact_accel", "peak max contact acc. (m/s²)", 1},
    {"erraticness", "erraticness (rad/s)", 2},
    {"injured", "injured (people)", 1},
};

namespace {

/// summary.csv's probe time for the density (van Toll et al. 2021, Table 1).
constexpr double kDensityProbeTime = 15.0;

std::string fixed(double v, int decimals) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals);
    if (res.ec != std::errc()) return ch::formatNumber(v);
    std::string s(buf, res.ptr);
    if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
    return s;
}

/// Display width of UTF-8 text (one column per code point).
std::size_t width(const std::string& s) {
    std::size_t w = 0;
    for (const char c : s) w += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
    return w;
}

Stat toStat(const std::vector<std::optional<double>>& values) {
    const ch::SampleStats s = ch::sampleStats(values);
    return {s.count, s.mean, s.sd};
}

/// The values of one run, in kCompareColumns order.
std::vector<std::optional<double>> runValues(const RunData& r) {
    std::vector<std::optional<double>> v;
    v.push_back(r.summary.evacuationTime);
    v.push_back(r.summary.flow);
    v.push_back(valueAt(metricsCurve(r, "mean_density"), kDensityProbeTime));
    v.push_back(peak(metricsCurve(r, "mean_density")));
    v.push_back(peak(metricsCurve(r, "mean_contact_accel")));
    v.push_back(peak(metricsCurve(r, "max_contact_accel")));
    std::optional<double> erratic, injured;
    if (r.health) {
        const std::vector<double> h = r.health->values("mean_abs_heading_change");
        double sum = 0;
        std::size_t n = 0;
        for (const double x : h)
            if (std::isfinite(x)) {
                sum += x;
                ++n;
            }
        if (n > 0) erratic = sum / static_cast<double>(n);
        if (r.health->column("injured_at") >= 0) {
            std::size_t count = 0;
            for (const double x : r.health->values("injured_at")) count += std::isfinite(x);
            injured = static_cast<double>(count);
        }
    }
    if (!injured) injured = peak(metricsCurve(r, "injured"));  // without health.csv: most injured at once
    v.push_back(erratic);
    v.push_back(injured);
    return v;
}

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (const char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

}  // namespace

CompareRow compareRow(const Experiment& e) {
    CompareRow row;
    row.experiment = e.name;
    row.runs = e.runs.size();
    std::vector<std::vector<std::optional<double>>> columns(kCompareColumns.size());
    std::map<std::string, int> verdicts;
    for (const RunData& r : e.runs) {
        const auto v = runValues(r);
        for (std::size_t c = 0; c < v.size(); ++c) columns[c].push_back(v[c]);
        if (!r.summary.verdict.empty()) ++verdicts[r.summary.verdict];
    }
    for (const auto& c : columns) row.stats.push_back(toStat(c));
    static const char* const kOrder[] = {"critical", "dangerous", "caution", "safe"};
    for (const char* level : kOrder)
        if (verdicts.count(level)) row.verdicts += (row.verdicts.empty() ? "" : ", ") + std::string(level) + " " + std::to_string(verdicts[level]);
    for (const auto& [level, n] : verdicts)
        if (std::find(std::begin(kOrder), std::end(kOrder), level) == std::end(kOrder))
            row.verdicts += (row.verdicts.empty() ? "" : ", ") + level + " " + std::to_string(n);
    return row;
}

std::string formatStat(const Stat& s, int decimals, std::size_t runs) {
    if (s.n == 0 || !std::isfinite(s.mean)) return "–";
    std::string text = fixed(s.mean, decimals);
    if (s.n >= 2 && std::isfinite(s.sd)) text += " ± " + fixed(s.sd, decimals);
    if (s.n != runs) text += " (n=" + std::to_string(s.n) + ")";
    return text;
}

std::string compareMarkdownTable(const std::vector<CompareRow>& rows) {
    std::vector<std::vector<std::string>> cells;
    std::vector<std::string> header = {"experiment", "runs"};
    for (const CompareColumn& c : kCompareColumns) header.push_back(c.heading);
    header.push_back("verdict");
    cells.push_back(header);
    for (const CompareRow& r : rows) {
        std::vector<std::string> line = {r.experiment, std::to_string(r.runs)};
        for (std::size_t c = 0; c < kCompareColumns.size(); ++c)
            line.push_back(formatStat(r.stats[c], kCompareColumns[c].decimals, r.runs));
        line.push_back(r.verdicts.empty() ? "–" : r.verdicts);
        cells.push_back(line);
    }
    std::vector<std::size_t> w(header.size(), 3);
    for (const auto& line : cells)
        for (std::size_t c = 0; c < line.size(); ++c) w[c] = std::max(w[c], width(line[c]));
    auto pad = [&](const std::string& s, std::size_t c, bool right) {
        const std::string fill(w[c] - width(s), ' ');
        return right ? fill + s : s + fill;
    };
    std::string out;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        out += "|";
        for (std::size_t c = 0; c < cells[i].size(); ++c) {
            const bool number = i > 0 && c > 0 && c + 1 < cells[i].size();
            out += " " + pad(cells[i][c], c, number) + " |";
        }
        out += "\n";
        if (i == 0) {
            out += "|";
            for (std::size_t c = 0; c < header.size(); ++c) {
                const bool number = c > 0 && c + 1 < header.size();
                out += " " + (number ? std::string(w[c] - 1, '-') + ":" : std::string(w[c], '-')) + " |";
            }
            out += "\n";
        }
    }
    return out;
}

std::string compareCsv(const std::vector<CompareRow>& rows) {
    std::string out = "experiment,runs";
    for (const CompareColumn& c : kCompareColumns)
        out += std::string(",") + c.key + "_mean," + c.key + "_sd," + c.key + "_n";
    out += ",verdicts\n";
    auto number = [](double v) { return std::isfinite(v) ? ch::formatNumber(v, 10) : std::string(); };
    for (const CompareRow& r : rows) {
        out += csvField(r.experiment) + "," + std::to_string(r.runs);
        // Appended piece by piece: GCC 12 raises a false -Wrestrict on `"," + std::string` at -O2.
        for (const Stat& s : r.stats) {
            out += ',';
            if (s.n) out += number(s.mean);
            out += ',';
            if (s.n >= 2) out += number(s.sd);
            out += ',';
            out += std::to_string(s.n);
        }
        out += ',';
        out += csvField(r.verdicts);
        out += '\n';
    }
    return out;
}

namespace {

/// The mean curve of column `column` over the runs of `e`, with its ± sd band.
Series meanSeries(const Experiment& e, const std::string& column, bool holdLast, std::size_t colourIndex) {
    std::vector<Curve> curves;
    for (const RunData& r : e.runs) curves.push_back(metricsCurve(r, column));
    Series s;
    s.title = e.name + (e.runs.size() > 1 ? " (" + std::to_string(e.runs.size()) + " runs)" : "");
    s.colour = seriesColour(colourIndex);
    s.width = 2.2;
    for (const MeanPoint& p : meanCurve(curves, holdLast)) {
        s.points.emplace_back(p.t, p.mean);
        if (e.runs.size() > 1) s.band.push_back({p.t, std::max(0.0, p.mean - p.sd), p.mean + p.sd});
    }
    return s;
}

std::string drawComparison(const std::vector<Experiment>& experiments, const fs::path& png) {
    struct Quantity {
        const char* column;
        const char* title;
        const char* ylabel;
        bool holdLast;
    };
    const Quantity quantities[] = {
        {"mean_density", "Mean density", "density (1/m^2)", false},
        {"agents", "Agents remaining in the world", "agents", true},
        {"mean_contact_accel", "Mean contact acceleration (crush)", "contact acceleration (m/s^2)", false},
        {"mean_speed", "Mean speed", "speed (m/s)", false},
        {"max_contact_accel", "Largest contact acceleration", "contact acceleration (m/s^2)", false},
        {"mean_panic", "Mean panic", "panic level (0 to 1)", false},
    };
    std::vector<Panel> panels;
    double tmax = 0;
    std::optional<std::pair<double, double>> ramp;
    for (const Experiment& e : experiments)
        for (const RunData& r : e.runs) {
            for (const double t : r.metrics.values("time"))
                if (std::isfinite(t)) tmax = std::max(tmax, t);
            if (const auto w = rampWindow(r))
                ramp = ramp ? std::make_pair(std::min(ramp->first, w->first), std::max(ramp->second, w->second)) : *w;
        }
    for (const Quantity& q : quantities) {
        Panel p;
        p.title = q.title;
        p.ylabel = q.ylabel;
        for (std::size_t i = 0; i < experiments.size(); ++i)
            p.series.push_back(meanSeries(experiments[i], q.column, q.holdLast, i));
        panels.push_back(std::move(p));
    }
    panels[1].key = true;
    panels[1].integerY = true;
    panels[5].zeroLabel = "no panic";
    // The names are in the key; list them in the title only while it fits the page width.
    std::string names;
    for (std::size_t i = 0; i < experiments.size(); ++i) names += (i ? ", " : "") + experiments[i].name;
    std::string title = names.size() <= 90 ? "Comparison of " + names
                                           : "Comparison of " + std::to_string(experiments.size()) + " experiments";
    title += ": mean over the runs (shaded: ± 1 sd)";
    GnuplotJob job;
    addTimePanels(job, title, 3, 2, panels, tmax, ramp);
    return drawPng(job, pngTerminal(1600, 1500), png);
}

}  // namespace

}  // namespace chplot

namespace chcli {

namespace po = boost::program_options;
namespace fs = std::filesystem;

int compareCommand(int argc, char* argv[]) {
    po::options_description visible("Options");
    // clang-format off
    visible.add_options()
        ("output,o", po::value<std::string>()->value_name("OUTDIR"),
         "folder for compare.md, compare.csv and compare.png (default: the current folder)")
        ("no-plot", "write the tables only (no compare.png, gnuplot not needed)")
        ("quiet,q", "do not print the table")
        ("help,h", "show this help");
    // clang-format on
    po::variables_map vm;
    std::vector<std::string> dirs;
    if (!chcli::parseFolderCommand("compare", visible, argc, argv, vm, dirs)) return kExitInput;
    if (vm.count("help")) {
        std::cout << "Usage: crowdhealth compare DIR... [-o OUTDIR] [--no-plot] [-q]\n\n"
                     "Compares runs or experiments: each DIR is a run folder (holding metrics.csv) or a\n"
                     "replications folder (holding run_000/, run_001/, ...), named by its folder name.\n"
                     "Prints van Toll et al.'s Table 1 per experiment (mean ± sd over its runs):\n"
                     "evacuation time, flow, mean density at 15 s, peak mean density, peak mean and max\n"
                     "contact acceleration, erraticness, injured, verdicts; writes it to\n"
                     "OUTDIR/compare.md and OUTDIR/compare.csv, and draws the mean curves of every\n"
                     "experiment over time into OUTDIR/compare.png (gnuplot).\n"
                     "See docs/crowd-health.md, \"Plots\".\n\n"
                  << visible
                  << "\nExit status: 0 success; 1 gnuplot missing or failed (the tables are still written)\n"
                     "or OUTDIR not writable; 2 bad command line or a DIR holds no run.\n";
        return kExitOk;
    }
    if (dirs.empty()) {
        std::cerr << "crowdhealth compare: error: give one or more run or replications folders\n"
                     "Try 'crowdhealth compare --help' for more information.\n";
        return kExitInput;
    }
    const bool quiet = vm.count("quiet") != 0, noPlot = vm.count("no-plot") != 0;
    const fs::path outDir = vm.count("output") ? fs::path(vm["output"].as<std::string>()) : fs::path(".");

    std::vector<chplot::Experiment> experiments(dirs.size());
    for (std::size_t i = 0; i < dirs.size(); ++i) {
        if (const std::string err = chplot::loadExperiment(dirs[i], experiments[i]); !err.empty()) {
            std::cerr << "crowdhealth compare: error: " << err << "\n";
            return kExitInput;
        }
    }
    // Two folders with the same name ("x/base", "y/base") are told apart by their path.
    std::map<std::string, int> seen;
    for (const auto& e : experiments) ++seen[e.name];
    for (std::size_t i = 0; i < experiments.size(); ++i)
        if (seen[experiments[i].name] > 1) experiments[i].name = fs::path(dirs[i]).lexically_normal().string();

    std::vector<chplot::CompareRow> rows;
    for (const auto& e : experiments) rows.push_back(chplot::compareRow(e));
    const std::string table = chplot::compareMarkdownTable(rows);
    std::string md = "# Comparison\n\n" + table +
                     "\nMean ± sample standard deviation over each experiment's runs ((n=k): only k runs have a "
                     "value). Evacuation time: the last evacuee, when everyone left; flow: summary.json's "
                     "persons per second; density @15 s: mean_density at the first row at or after 15 s; peak "
                     "density: largest mean_density; peak mean / max contact acc.: largest mean_contact_accel / "
                     "max_contact_accel of metrics.csv; erraticness: the mean of health.csv's "
                     "mean_abs_heading_change over the agents; injured: agents with an injured_at time in "
                     "health.csv. Written by `crowdhealth compare`.\n";
    try {
        fs::create_directories(outDir);
        ch::writeFileAtomic(outDir / "compare.md", md);
        ch::writeFileAtomic(outDir / "compare.csv", chplot::compareCsv(rows));
        addToManifest(outDir / "compare.md");  // into a run folder: its manifest lists them
        addToManifest(outDir / "compare.csv");
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth compare: error: cannot write to " << outDir.string() << ": " << e.what() << "\n";
        return kExitRuntime;
    }
    if (!quiet) std::cout << table << "\n  tables  " << (outDir / "compare.md").string() << ", " << (outDir / "compare.csv").string() << "\n";
    if (noPlot) return kExitOk;
    if (!chplot::findGnuplot()) {
        std::cerr << "crowdhealth compare: error: " << chplot::missingGnuplotMessage("compare.png")
                  << " (the tables were written; use --no-plot to skip the figure)\n";
        return kExitRuntime;
    }
    if (const std::string err = chplot::drawComparison(experiments, outDir / "compare.png"); !err.empty()) {
        std::cerr << "crowdhealth compare: error: " << err << "\n";
        return kExitRuntime;
    }
    addToManifest(outDir / "compare.png");
    if (!quiet) std::cout << "  plot    " << (outDir / "compare.png").string() << "\n";
    return kExitOk;
}

}  // namespace chcli
