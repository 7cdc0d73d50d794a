// crowdhealth plot — see plot.h and docs/crowd-health.md ("Plots").
#include "plot.h"

#include "output_folder.h"
#include "plot_measure.h"
#include "plot_paths.h"
#include "plot_venue.h"

#include "exit_codes.h"

#include <crowdhealth/io/output.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <sstream>

namespace chplot {

namespace {

std::string num(double v) { return ch::formatNumber(v, 8); }

/// Light grey of the ramp window.
constexpr const char* kRampColour = "#e6e6e6";

}  // namespace

std::string seriesColour(std::size_t i) {
    // Tableau 10: distinct in colour and in lightness, readable on white.
    static const char* const kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                           "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
    return kColours[i % 10];
}

void addTimePanels(GnuplotJob& job, const std::string& figureTitle, int rows, int cols,
                   const std::vector<Panel>& panels, double tmax, std::optional<std::pair<double, double>> ramp) {
    const bool cairo = hasPngCairo();
    job.cmd("set multiplot layout " + std::to_string(rows) + "," + std::to_string(cols) + " title " +
            gpString(figureTitle) + " noenhanced font ',15'");
    job.cmd("set grid lc rgb '#d0d0d0'");
    job.cmd("set xlabel 'time (s)'");
    job.cmd("set xrange [0:" + num(tmax > 0 ? tmax : 1) + "]");
    job.cmd("set border lw 1");
    job.cmd("set tics nomirror");
    for (const Panel& p : panels) {
        const std::string plain = p.plainText ? " noenhanced" : "";
        job.cmd("set title " + gpString(p.title) + " font ',13'" + plain);
        job.cmd("set ylabel " + gpString(p.ylabel) + plain);
        double largest = 0;
        for (const Series& s : p.series)
            for (const auto& [t, v] : s.points) largest = std::max(largest, std::abs(v));
        // A fixed right margin (and left, so that the panels line up) or gnuplot's automatic ones.
        job.cmd(p.rightMargin > 0 ? "set rmargin at screen " + num(p.rightMargin) : std::string("set rmargin -1"));
        job.cmd(p.rightMargin > 0 ? std::string("set lmargin at screen 0.07") : std::string("set lmargin -1"));
        if (p.yMax > 0) {
            job.cmd("set yrange [0:" + num(p.yMax) + "]");
            job.cmd("set ytics autofreq");
        } else if (p.integerY && largest < 5) {
            job.cmd("set yrange [0:5]");  // whole numbers: no 0.2 steps
            job.cmd("set ytics 1");
        } else {
            job.cmd("set yrange [0:*]");
            job.cmd("set ytics autofreq");
        }
        job.cmd("set format y '% h'");
        if (largest == 0 && !p.zeroLabel.empty())
            job.cmd("set label 8 " + gpString(p.zeroLabel) + " at graph 0.5, graph 0.5 center font ',14' tc rgb '#606060'");
        else
            job.cmd("unset label 8");
        const std::optional<std::pair<double, double>>& shade = p.ownRamp ? p.ramp : ramp;
        if (shade)
            job.cmd("set object 1 rect from " + num(shade->first) + ", graph 0 to " + num(shade->second) +
                    ", graph 1 behind fc rgb '" + kRampColour + "' fs solid 1.0 noborder");
        else
            job.cmd("unset object 1");
        for (int b = 0; b < 12; ++b) {  // the bands of the previous panel
            job.cmd("unset object " + std::to_string(20 + b));
            job.cmd("unset label " + std::to_string(20 + b));
        }
        for (std::size_t b = 0; b < p.bands.size() && b < 12; ++b) {
            const YBand& band = p.bands[b];
            const double top = p.yMax > 0 ? std::min(band.y1, p.yMax) : band.y1;
            if (p.yMax > 0 && band.y0 >= p.yMax) continue;
            const std::string tag = std::to_string(20 + b);
            job.cmd("set object " + tag + " rect from graph 0, first " + num(band.y0) + " to graph 1, first " + num(top) +
                    " behind fc rgb '" + band.colour + "' fs solid 1.0 noborder");
            if (!band.label.empty())
                job.cmd("set label " + tag + " " + gpString(band.label) + " at graph 0.995, first " +
                        num(0.5 * (band.y0 + top)) + " right front noenhanced font ',10' tc rgb '#404040'");
        }
        if (p.key) {
            std::size_t entries = 0;
            for (const Series& s : p.series) entries += !s.title.empty() && !s.points.empty();
            // Inside the panel: two columns at most half as tall; outside (beside it): one column.
            const bool outside = p.keyWhere.rfind("outside", 0) == 0;
            job.cmd("set key " + p.keyWhere + " box opaque samplen 2 spacing 1.1 font ',10' maxrows " +
                    std::to_string(outside ? entries + 2 : std::max<std::size_t>(6, (entries + 2) / 2 + 1)));
        } else {
            job.cmd("unset key");
        }
        std::vector<std::string> elements;
        std::vector<Rows> blocks;
        for (const Series& s : p.series) {
            if (!s.band.empty()) {
                Rows r;
                for (const auto& b : s.band) r.push_back({b[0], b[1], b[2]});
                elements.push_back("'-' using 1:2:3 with filledcurves fc rgb '" + s.colour + "' " +
                                   (cairo ? "fs transparent solid 0.18 noborder" : "fs pattern 4 noborder") +
                                   " notitle");
                blocks.push_back(std::move(r));
            }
        }
        for (const Series& s : p.series) {
            if (s.points.empty()) continue;
            Rows r;
            for (const auto& [t, v] : s.points) r.push_back({t, v});
            elements.push_back("'-' using 1:2 with lines lw " + num(s.width) + (s.dash.empty() ? "" : " dt " + s.dash) +
                               " lc rgb '" + s.colour + "' " +
                               (s.title.empty() ? std::string("notitle") : "title " + gpString(s.title) + " noenhanced"));
            blocks.push_back(std::move(r));
        }
        if (elements.empty()) {
            job.cmd("set label 9 'no data' at graph 0.5, graph 0.5 center");
            job.cmd("set yrange [0:1]");
            job.cmd("plot -1 notitle");
            job.cmd("unset label 9");
            continue;
        }
        if (ramp && p.key) elements.push_back(std::string("keyentry with boxes fc rgb '") + kRampColour +
                                              "' fs solid 1.0 title 'parameter ramp'");
        std::string plot = "plot ";
        for (std::size_t i = 0; i < elements.size(); ++i) plot += (i ? ", " : "") + elements[i];
        job.cmd(plot);
        for (Rows& r : blocks) job.data(std::move(r));
    }
    job.cmd("unset label 8");
    job.cmd("set rmargin -1");
    job.cmd("set lmargin -1");
    job.cmd("unset multiplot");
    for (int b = 0; b < 12; ++b) {
        job.cmd("unset object " + std::to_string(20 + b));
        job.cmd("unset label " + std::to_string(20 + b));
    }
}

namespace {

/// "dangerous (3 runs)" or "critical 1, dangerous 2"; "" when no run has a verdict.
std::string verdictText(const Experiment& e) {
    std::map<std::string, int> count;
    for (const RunData& r : e.runs)
        if (!r.summary.verdict.empty()) ++count[r.summary.verdict];
    if (count.empty()) return "";
    static const char* const kOrder[] = {"critical", "dangerous", "caution", "safe"};
    if (count.size() == 1)
        return count.begin()->first +
               (e.runs.size() > 1 ? " (" + std::to_string(count.begin()->second) + " of " + std::to_string(e.runs.size()) + " runs)" : "");
    std::string s;
    for (const char* level : kOrder)
        if (count.count(level)) s += (s.empty() ? "" : ", ") + std::string(level) + " " + std::to_string(count[level]);
    for (const auto& [level, n] : count)
        if (std::find(std::begin(kOrder), std::end(kOrder), level) == std::end(kOrder))
            s += (s.empty() ? "" : ", ") + level + " " + std::to_string(n);
    return s;
}

std::string figureTitle(const Experiment& e, const std::string& what) {
    std::string t = what + ": " + e.name;
    for (const RunData& r : e.runs)
        if (!r.summary.scenario.empty()) {
            const std::string file = fs::path(r.summary.scenario).filename().string();
            if (file != e.name) t += " (" + file + ")";
            break;
        }
    if (e.runs.size() > 1) t += ", " + std::to_string(e.runs.size()) + " runs";
    if (const std::string v = verdictText(e); !v.empty()) t += ", verdict: " + v;
    return t;
}

double lastTime(const Experiment& e) {
    double t = 0;
    for (const RunData& r : e.runs) {
        const std::vector<double> times = r.metrics.values("time");
        for (const double v : times)
            if (std::isfinite(v)) t = std::max(t, v);
    }
    return t;
}

/// One panel with a curve per run (each in its own colour) and, for several runs, their mean.
Panel runsPanel(const Experiment& e, const std::string& column, std::string title, std::string ylabel, bool holdLast) {
    Panel p;
    p.title = std::move(title);
    p.ylabel = std::move(ylabel);
    std::vector<Curve> curves;
    for (std::size_t i = 0; i < e.runs.size(); ++i) {
        Series s;
        s.title = e.runs.size() > 1 || e.replications ? e.runs[i].name : e.name;
        s.colour = seriesColour(i);
        s.width = e.runs.size() > 1 ? 1.2 : 2.0;
        s.points = metricsCurve(e.runs[i], column);
        curves.push_back(s.points);
        p.series.push_back(std::move(s));
    }
    if (e.runs.size() > 1) {
        Series m;
        m.title = "mean of " + std::to_string(e.runs.size()) + " runs";
        m.colour = "#000000";
        m.width = 2.5;
        for (const MeanPoint& q : meanCurve(curves, holdLast)) m.points.emplace_back(q.t, q.mean);
        p.series.push_back(std::move(m));
    }
    return p;
}

/// The extra columns of metrics.csv (ramped parameters) present in the first run.
std::vector<std::string> rampedColumns(const Experiment& e) {
    std::vector<std::string> cols;
    if (e.runs.empty()) return cols;
    const auto& h = e.runs.front().metrics.header;
    for (std::size_t c = kFixedMetricsColumns; c < h.size(); ++c)
        if (!h[c].empty()) cols.push_back(h[c]);
    return cols;
}

struct Cell {
    double x = 0, y = 0, maxDensity = 0, maxAccel = 0, secDensity = 0, secCrush = 0;
    int runs = 0;
};

/// heatmap.csv of every run on one grid: peaks are the largest over the runs, times the mean.
std::vector<Cell> combinedHeatmap(const Experiment& e, int& runsWithMap) {
    std::map<std::pair<long long, long long>, Cell> cells;
    runsWithMap = 0;
    for (const RunData& r : e.runs) {
        if (!r.heatmap) continue;
        ++runsWithMap;
        const Table& t = *r.heatmap;
        const int cx = t.column("x"), cy = t.column("y"), cd = t.column("max_density"), ca = t.column("max_contact_accel"),
                  csd = t.column("seconds_above_density_threshold"), csc = t.column("seconds_above_crush_threshold");
        if (cx < 0 || cy < 0) continue;
        auto at = [](const std::vector<double>& row, int c) {
            return c >= 0 && std::isfinite(row[static_cast<std::size_t>(c)]) ? row[static_cast<std::size_t>(c)] : 0.0;
        };
        for (const auto& row : t.rows) {
            const double x = row[static_cast<std::size_t>(cx)], y = row[static_cast<std::size_t>(cy)];
            if (!std::isfinite(x) || !std::isfinite(y)) continue;
            Cell& c = cells[{std::llround(x * 1000), std::llround(y * 1000)}];
            c.x = x;
            c.y = y;
            c.maxDensity = std::max(c.maxDensity, at(row, cd));
            c.maxAccel = std::max(c.maxAccel, at(row, ca));
            c.secDensity += at(row, csd);
            c.secCrush += at(row, csc);
            ++c.runs;
        }
    }
    std::vector<Cell> out;
    for (auto& [k, c] : cells) {
        if (runsWithMap > 0) {
            c.secDensity /= runsWithMap;
            c.secCrush /= runsWithMap;
        }
        out.push_back(c);
    }
    return out;
}

}  // namespace

double gridStep(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    double best = 0;
    for (std::size_t i = 1; i < v.size(); ++i) {
        const double d = v[i] - v[i - 1];
        if (d > 1e-6 && (best == 0 || d < best)) best = d;
    }
    return best > 0 ? best : 1.0;
}

namespace {

void addHeatPanel(GnuplotJob& job, const std::vector<Cell>& cells, double dx, double dy, bool density,
                  const std::string& title, const VenueOverlay& venue, const VenueStyle& style) {
    job.cmd("set title " + gpString(title) + " font ',13'");
    job.cmd("set xlabel 'x (m)'");
    job.cmd("set ylabel 'y (m)'");
    job.cmd("set size ratio -1");
    job.cmd("set cbrange [0:*]");
    job.cmd(density ? "set cblabel 'peak density (1/m^2)'" : "set cblabel 'peak contact acceleration (m/s^2)'");
    job.cmd(density ? "set palette defined (0 '#ffffff', 1 '#ffffb2', 2 '#fecc5c', 3 '#fd8d3c', 4 '#f03b20', 5 '#bd0026')"
                    : "set palette defined (0 '#ffffff', 1 '#edf8fb', 2 '#b3cde3', 3 '#8c96c6', 4 '#8856a7', 5 '#810f7c')");
    job.cmd("set key below font ',10'");
    Rows boxes, dots;
    double maxSeconds = 0;
    for (const Cell& c : cells) maxSeconds = std::max(maxSeconds, density ? c.secDensity : c.secCrush);
    for (const Cell& c : cells) {
        boxes.push_back({c.x, c.y, dx / 2, dy / 2, density ? c.maxDensity : c.maxAccel});
        const double s = density ? c.secDensity : c.secCrush;
        if (s > 0) dots.push_back({c.x, c.y, 0.3 + 1.2 * std::sqrt(s / maxSeconds)});
    }
    std::string plot = "plot '-' using 1:2:3:4:5 with boxxyerror fs solid 1.0 noborder lc palette z notitle";
    if (!dots.empty())
        plot += ", '-' using 1:2:3 with points pt 7 ps variable lc rgb '#000000' title " +
                gpString(std::string("time above the ") + (density ? "density" : "crush") +
                       " threshold (dot size; largest " + ch::formatNumber(maxSeconds, 3) + " s)");
    else
        plot += ", keyentry with points pt 7 lc rgb '#ffffff' title " +
                gpString(std::string("never above the ") + (density ? "density" : "crush") + " threshold");
    std::vector<std::string> elements;
    std::vector<Rows> blocks;
    venue.addElements(elements, blocks, style);  // walls, exits, targets, measurement over the cells
    for (const std::string& el : elements) plot += ", " + el;
    job.cmd(plot);
    job.data(std::move(boxes));
    if (!dots.empty()) job.data(std::move(dots));
    for (Rows& r : blocks) job.data(std::move(r));
}

}  // namespace

void drawExperiment(const Experiment& e, std::vector<fs::path>& written, std::vector<std::string>& errors,
                    std::vector<std::string>& notes) {
    const double tmax = lastTime(e);
    const std::optional<std::pair<double, double>> ramp = e.runs.empty() ? std::nullopt : rampWindow(e.runs.front());
    auto draw = [&](const GnuplotJob& job, const std::string& terminal, const std::string& name) {
        const fs::path png = e.dir / name;
        const std::string err = drawPng(job, terminal, png);
        if (err.empty()) written.push_back(png);
        else errors.push_back(err);
    };

    {  // fig3.png
        std::vector<Panel> panels = {
            runsPanel(e, "mean_density", "Mean density", "density (1/m^2)", false),
            runsPanel(e, "agents", "Agents remaining in the world", "agents", true),
            runsPanel(e, "mean_contact_accel", "Mean contact acceleration (crush)", "contact acceleration (m/s^2)", false),
            runsPanel(e, "mean_speed", "Mean speed", "speed (m/s)", false),
        };
        panels[1].key = true;
        panels[1].integerY = true;
        GnuplotJob job;
        addTimePanels(job, figureTitle(e, "Crowd over time"), 2, 2, panels, tmax, ramp);
        draw(job, pngTerminal(1600, 1100), "fig3.png");
    }
    {  // health.png
        std::vector<Panel> panels = {
            runsPanel(e, "max_contact_accel", "Largest contact acceleration (worst-off person)", "contact acceleration (m/s^2)", false),
            runsPanel(e, "injured", "Injured people", "people", true),
            runsPanel(e, "mean_panic", "Mean panic", "panic level (0 to 1)", false),
            runsPanel(e, "crowd_pressure", "Crowd pressure ρ·Var(v), largest", "crowd pressure (1/s^2)", false),
        };
        panels[1].key = true;
        panels[1].integerY = true;
        panels[1].zeroLabel = "nobody injured";
        panels[2].zeroLabel = "no panic";
        GnuplotJob job;
        addTimePanels(job, figureTitle(e, "Health over time"), 2, 2, panels, tmax, ramp);
        draw(job, pngTerminal(1600, 1100), "health.png");
    }
    {  // schedule.png
        const std::vector<std::string> cols = rampedColumns(e);
        std::error_code ec;
        if (cols.empty()) {
            fs::remove(e.dir / "schedule.png", ec);  // a stale one would describe another run
            notes.push_back("no ramped parameters in metrics.csv: no schedule.png");
        } else {
            std::vector<Panel> panels;
            for (const std::string& c : cols) {
                Panel p;
                // Each panel shades its own parameter's ramp: with several parameters ramped at
                // different times, the figure's window (first start to last end) would be wrong.
                p.ownRamp = true;
                p.ramp = rampWindow(e.runs.front(), c);
                p.title = c + " against time" +
                          (e.runs.size() > 1 ? " (" + e.runs.front().name + ", the same schedule in every run)" : "") +
                          (p.ramp ? "; grey: while it changes" : "");
                p.ylabel = c;
                Series s;
                s.title = e.runs.front().name + (e.runs.size() > 1 ? " (the same schedule in every run)" : "");
                s.colour = seriesColour(0);
                s.width = 2.5;
                s.points = metricsCurve(e.runs.front(), c);
                p.series.push_back(std::move(s));
                p.plainText = true;  // no key: the title says it all, and a key would hide the curve
                p.rightMargin = 0.97;  // fixed margins, so that the panels' time axes line up
                panels.push_back(std::move(p));
            }
            const int n = static_cast<int>(panels.size());
            GnuplotJob job;
            addTimePanels(job, figureTitle(e, "Ramped parameters"), n, 1, panels, tmax, ramp);
            draw(job, pngTerminal(1400, std::min(2400, 120 + 380 * n)), "schedule.png");
        }
    }
    {  // heatmap.png
        int runsWithMap = 0;
        const std::vector<Cell> cells = combinedHeatmap(e, runsWithMap);
        if (cells.empty()) {
            notes.push_back("no heatmap.csv in " + e.dir.string() + (e.replications ? "/run_*" : "") + ": no heatmap.png");
        } else {
            std::vector<double> xs, ys;
            for (const Cell& c : cells) {
                xs.push_back(c.x);
                ys.push_back(c.y);
            }
            const double dx = gridStep(xs), dy = gridStep(ys);
            // The venue of the first run with a heat map: walls, exits, targets, measurement.
            const RunData* first = nullptr;
            for (const RunData& r : e.runs)
                if (r.heatmap && !first) first = &r;
            std::string venueNote;
            const VenueOverlay venue = VenueOverlay::load(*first, venueNote);
            if (!venue.has()) notes.push_back("heatmap.png without walls and exits: " + venueNote);
            Extent extent;
            venue.grow(extent);
            for (const Cell& c : cells) {
                extent.grow(c.x - dx / 2, c.y - dy / 2);
                extent.grow(c.x + dx / 2, c.y + dy / 2);
            }
            extent.pad(0.02);
            VenueStyle style;
            style.exitColours = false;
            style.fillInFront = true;
            GnuplotJob job;
            std::string title = "Where density and crush peaked: " + e.name;
            if (runsWithMap > 1) title += " (largest over " + std::to_string(runsWithMap) + " runs; dots: mean time above threshold)";
            job.cmd("set multiplot layout 1,2 title " + gpString(title) + " noenhanced font ',15'");
            job.cmd("set grid front lc rgb '#c0c0c0'");
            job.cmd("set tics out nomirror");
            job.cmd("set xrange [" + num(extent.x0) + ":" + num(extent.x1) + "]");
            job.cmd("set yrange [" + num(extent.y0) + ":" + num(extent.y1) + "]");
            venue.setObjects(job, 1, style, 0.03 * std::max(extent.x1 - extent.x0, extent.y1 - extent.y0));
            addHeatPanel(job, cells, dx, dy, true, "High density", venue, style);
            addHeatPanel(job, cells, dx, dy, false, "Crush (contact acceleration)", venue, style);
            job.cmd("unset multiplot");
            draw(job, pngTerminal(1700, 850), "heatmap.png");
        }
    }
    drawPaths(e, written, errors, notes);  // paths.png
    drawLos(e, written, errors, notes);    // los.png
    drawFlows(e, written, errors, notes);  // flows.png
    drawAreas(e, written, errors, notes);  // areas.png
}

}  // namespace chplot

namespace chcli {

namespace po = boost::program_options;

bool plotAvailable(const char* what) {
    if (chplot::findGnuplot()) return true;
    std::cerr << "crowdhealth: error: " << chplot::missingGnuplotMessage(what) << "\n";
    return false;
}

int plotOutputs(const std::filesystem::path& dir, bool quiet) {
    if (!plotAvailable("plotting")) return kExitRuntime;
    chplot::Experiment e;
    if (const std::string err = chplot::loadExperiment(dir, e); !err.empty()) {
        std::cerr << "crowdhealth plot: error: " << err << "\n";
        return kExitInput;
    }
    std::vector<std::filesystem::path> written;
    std::vector<std::string> errors, notes;
    chplot::drawExperiment(e, written, errors, notes);
    // Into a run folder (one with a manifest): the figures join its manifest, so the next run
    // into it replaces them too rather than refusing them or leaving them stale.
    for (const std::filesystem::path& png : written) {
        if (addToManifest(png)) continue;
        std::string message = "cannot add ";
        message += png.filename().string();
        message += " to ";
        message += (png.parent_path() / kManifestName).string();
        errors.push_back(std::move(message));
    }
    if (!quiet) {
        std::cout << "  plots           ";
        for (std::size_t i = 0; i < written.size(); ++i)
            std::cout << (i ? ", " : "") << (i ? written[i].filename().string() : written[i].string());
        if (written.empty()) std::cout << "none";
        std::cout << "\n";
        for (const std::string& m : notes) std::cout << "                  (" << m << ")\n";
        std::cout.flush();
    }
    for (const std::string& m : errors) std::cerr << "crowdhealth plot: error: " << m << "\n";
    return errors.empty() ? kExitOk : kExitRuntime;
}

bool parseFolderCommand(const std::string& name, const po::options_description& visible, int argc, char* argv[],
                        po::variables_map& vm, std::vector<std::string>& dirs) {
    po::options_description all;
    all.add(visible).add_options()("dir", po::value<std::vector<std::string>>(), "");
    po::positional_options_description pos;
    pos.add("dir", -1);
    try {
        po::store(po::command_line_parser(argc, argv).options(all).positional(pos).run(), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "crowdhealth " << name << ": error: " << e.what() << "\nTry 'crowdhealth " << name
                  << " --help' for more information.\n";
        return false;
    }
    dirs = vm.count("dir") ? vm["dir"].as<std::vector<std::string>>() : std::vector<std::string>{};
    return true;
}

int plotCommand(int argc, char* argv[]) {
    po::options_description visible("Options");
    visible.add_options()("quiet,q", "print nothing but errors")("help,h", "show this help");
    po::variables_map vm;
    std::vector<std::string> dirs;
    if (!parseFolderCommand("plot", visible, argc, argv, vm, dirs)) return kExitInput;
    if (vm.count("help")) {
        std::cout << "Usage: crowdhealth plot DIR [-q]\n\n"
                     "Draws the figures of a finished run (DIR holds metrics.csv) or set of replications\n"
                     "(DIR holds run_000/, run_001/, ...) into DIR, as PNG with gnuplot:\n"
                     "  fig3.png      mean density, mean contact acceleration, mean speed and agents\n"
                     "                remaining over time, one colour per run, and their mean\n"
                     "  health.png    largest contact acceleration, injured, mean panic, crowd pressure\n"
                     "  schedule.png  the ramped parameters, when the scenario has a <Schedule>\n"
                     "  heatmap.png   where high density and crush happened (from heatmap.csv)\n"
                     "  paths.png     every agent's path (from the run's trajectories: trajectories.bin,\n"
                     "                .txt or output_<id>.csv), coloured by the exit it left by (grey:\n"
                     "                none), over the walls, targets and exits of its scenario (named in\n"
                     "                summary.json); of the first run that has trajectories\n"
                     "  los.png       Fruin's level of service per cell: the worst level the local\n"
                     "                density held for <Safety min_duration> (heatmap.csv's worst_los;\n"
                     "                worst over the runs), in Fruin's colours, over the walls, exits,\n"
                     "                targets and measurement lines (arrow: forward) and areas\n"
                     "  flows.png     specific flow through each measurement line and exit over the\n"
                     "                last <Safety flow_window> s against flow_capacity (dashed), and\n"
                     "                the crossings per direction (from flows.csv, when present)\n"
                     "  areas.png     density in each measurement area against Fruin's levels, and\n"
                     "                the mean speed there (from areas.csv, when present)\n"
                     "heatmap.png, paths.png and los.png draw the run's venue (walls, exits, targets,\n"
                     "measurement lines and areas); flows.png and areas.png show the first run that\n"
                     "has the file.\n"
                     "The same as the --plot option of a run. See docs/crowd-health.md, \"Plots\", and\n"
                     "docs/navigation.md, \"Plots\", and docs/measurement.md.\n\n"
                  << visible << "\nExit status: 0 success; 1 gnuplot missing or failed, or DIR not writable;\n"
                                "2 bad command line or DIR holds no run.\n";
        return kExitOk;
    }
    if (dirs.size() != 1) {
        std::cerr << "crowdhealth plot: error: give exactly one folder (a run or replications output folder)\n"
                     "Try 'crowdhealth plot --help' for more information.\n";
        return kExitInput;
    }
    const bool quiet = vm.count("quiet") != 0;
    if (!quiet) std::cout << "crowdhealth plot: " << dirs[0] << "\n";
    return plotOutputs(dirs[0], quiet);
}

}  // namespace chcli
