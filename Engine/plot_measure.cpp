// crowdhealth plot — los.png, flows.png and areas.png (see plot_measure.h).
#include "plot_measure.h"

#include "plot.h"
#include "plot_gnuplot.h"
#include "plot_measure_data.h"
#include "plot_venue.h"

#include <crowdhealth/health/safety.h>
#include <crowdhealth/io/output.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace chplot {

namespace {

std::string num(double v) { return ch::formatNumber(v, 10); }

/// gnuplot's dash type 2 (a function: GCC 12 raises a false -Wrestrict on assigning a literal).
const std::string& dashed() {
    static const std::string d = "2";
    return d;
}

/// `e`'s folder (with /run_* for replications), for the notes.
std::string folderOf(const Experiment& e) { return e.dir.string() + (e.replications ? "/run_*" : ""); }

/// A colour blended towards white (fraction 0: the colour, 1: white).
std::string pale(unsigned rgb, double fraction) {
    const auto mix = [&](unsigned c) { return static_cast<unsigned>(std::lround(c + (255.0 - c) * fraction)); };
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", mix((rgb >> 16) & 255), mix((rgb >> 8) & 255), mix(rgb & 255));
    return buf;
}

void drawInto(const GnuplotJob& job, const std::string& terminal, const fs::path& png, std::vector<fs::path>& written,
              std::vector<std::string>& errors) {
    const std::string err = drawPng(job, terminal, png);
    if (err.empty()) written.push_back(png);
    else errors.push_back(err);
}

/// The first run of `e` holding `file`, or nullptr (a stale `png` is then removed with a note).
const RunData* firstWith(const Experiment& e, const std::string& file, const std::string& png, const std::string& why,
                         std::vector<std::string>& notes) {
    for (const RunData& r : e.runs)
        if (fs::exists(r.dir / file)) return &r;
    std::error_code ec;
    fs::remove(e.dir / png, ec);  // a stale one would describe another run
    notes.push_back("no " + file + " in " + folderOf(e) + ": no " + png + " (" + why + ")");
    return nullptr;
}

std::string figureName(const Experiment& e, const RunData& run, const VenueOverlay& venue) {
    std::string t = e.name;
    if (venue.has()) t += " (" + fs::path(venue.spec()->sourceFile).filename().string() + ")";
    if (e.runs.size() > 1) t += ", " + run.name;
    return t;
}

}  // namespace

void drawLos(const Experiment& e, std::vector<fs::path>& written, std::vector<std::string>& errors,
             std::vector<std::string>& notes) {
    const fs::path png = e.dir / "los.png";
    std::vector<std::vector<LosCell>> grids;
    const RunData* first = nullptr;
    bool anyHeatmap = false;
    for (const RunData& r : e.runs) {
        if (!r.heatmap) continue;
        anyHeatmap = true;
        std::vector<LosCell> cells;
        bool hasLos = false;
        if (const std::string err = readLosGrid(r.dir / "heatmap.csv", cells, hasLos); !err.empty()) {
            errors.push_back("los.png: " + err);
            return;
        }
        if (!hasLos) continue;
        if (!first) first = &r;
        grids.push_back(std::move(cells));
    }
    std::error_code ec;
    if (!first) {
        fs::remove(png, ec);
        notes.push_back(anyHeatmap ? "no worst_los column in " + folderOf(e) +
                                         "/heatmap.csv (a run older than the level-of-service map): no los.png"
                                   : "no heatmap.csv in " + folderOf(e) + ": no los.png");
        return;
    }
    const std::vector<LosCell> cells = combineLos(grids);
    std::string note;
    const VenueOverlay venue = VenueOverlay::load(*first, note);
    if (!venue.has()) notes.push_back("los.png without walls and exits: " + note);

    std::vector<double> xs, ys;
    for (const LosCell& c : cells) xs.push_back(c.x), ys.push_back(c.y);
    const double dx = gridStep(xs), dy = gridStep(ys);
    Extent extent;
    venue.grow(extent);
    for (const LosCell& c : cells)
        if (c.reached) {
            extent.grow(c.x - dx / 2, c.y - dy / 2);
            extent.grow(c.x + dx / 2, c.y + dy / 2);
        }
    extent.pad(0.03);

    const double minDuration = venue.has() ? venue.spec()->safety.minDuration : ch::SafetyThresholds{}.minDuration;
    std::string title = "Level of service (Fruin, walkways): " + figureName(e, *first, venue);
    if (grids.size() > 1) title = "Level of service (Fruin, walkways): " + e.name + ", worst of " +
                                  std::to_string(grids.size()) + " runs";
    const std::string subtitle = "each cell: the worst level its local density held for " +
                                 ch::formatNumber(minDuration, 4) + " s without a break" +
                                 (venue.has() ? "" : " (the default <Safety min_duration>)");

    GnuplotJob job;
    job.cmd("set title " + gpString(title) + " noenhanced font ',15' offset 0,1");
    job.cmd("set label 99 " + gpString(subtitle) + " at graph 0.5, graph 1 center offset 0,1 noenhanced font ',11'");
    job.cmd("set size ratio -1");
    job.cmd("set xrange [" + num(extent.x0) + ":" + num(extent.x1) + "]");
    job.cmd("set yrange [" + num(extent.y0) + ":" + num(extent.y1) + "]");
    job.cmd("set xlabel 'x (m)'");
    job.cmd("set ylabel 'y (m)'");
    job.cmd("set tics out nomirror");
    job.cmd("set grid front lc rgb '#c8c8c8' lw 0.5");
    job.cmd("set key outside right top box opaque samplen 2 spacing 1.2 font ',11' noenhanced");
    VenueStyle style;
    style.exitColours = false;
    style.fillInFront = true;
    venue.setObjects(job, 1, style, 0.03 * std::max(extent.x1 - extent.x0, extent.y1 - extent.y0));

    std::vector<std::string> elements;
    std::vector<Rows> blocks;
    Rows boxes;
    for (const LosCell& c : cells)
        if (c.reached) boxes.push_back({c.x, c.y, dx / 2, dy / 2, static_cast<double>(losColour(c.level))});
    if (!boxes.empty()) {
        elements.push_back("'-' using 1:2:3:4:5 with boxxyerror fs solid 1.0 noborder lc rgb variable notitle");
        blocks.push_back(std::move(boxes));
    }
    for (const char level : {'A', 'B', 'C', 'D', 'E', 'F'})
        elements.push_back("keyentry with boxes fs solid 1.0 noborder fc rgb '" + losColourHex(level) + "' title " +
                           gpString(losLegend(level)));
    elements.push_back("keyentry with boxes fs solid 1.0 border lc rgb '#606060' fc rgb '#ffffff' title 'white: nobody within reach'");
    venue.addElements(elements, blocks, style);
    std::string plot = "plot ";
    for (std::size_t i = 0; i < elements.size(); ++i) plot += (i ? ", " : "") + elements[i];
    job.cmd(plot);
    for (Rows& r : blocks) job.data(std::move(r));

    const double aspect = (extent.y1 - extent.y0) / std::max(1e-9, extent.x1 - extent.x0);
    const int plotWidth = 1100;
    const int height = std::clamp(static_cast<int>(std::lround(plotWidth * aspect)) + 180, 650, 1800);
    drawInto(job, pngTerminal(plotWidth + 520, height), png, written, errors);
}

void drawFlows(const Experiment& e, std::vector<fs::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes) {
    const RunData* run = firstWith(e, "flows.csv", "flows.png", "the scenario has no exit and no measurement line", notes);
    if (!run) return;
    std::vector<FlowSeries> series;
    if (const std::string err = readFlows(run->dir / "flows.csv", series); !err.empty()) {
        errors.push_back("flows.png: " + err);
        return;
    }
    std::string note;
    const VenueOverlay venue = VenueOverlay::load(*run, note);
    const ch::SafetyThresholds safety = venue.has() ? venue.spec()->safety : ch::SafetyThresholds{};
    if (!venue.has()) notes.push_back("flows.png with the default flow_capacity and flow_window: " + note);

    double tmax = 0;
    for (const FlowSeries& s : series)
        if (!s.specificFlow.empty()) tmax = std::max(tmax, s.specificFlow.back().first);
    Panel flow, counts;
    flow.title = "Specific flow over the last " + ch::formatNumber(safety.flowWindow, 4) + " s (flow_window)";
    flow.ylabel = "specific flow (P/(m·s))";
    flow.key = true;
    flow.plainText = true;
    counts.title = "Crossings since the start (solid: forward, dashed: backward)";
    counts.ylabel = "people";
    counts.key = true;
    counts.plainText = true;
    flow.keyWhere = counts.keyWhere = "outside right top";
    flow.rightMargin = counts.rightMargin = 0.70;  // both panels equally wide, whatever their keys
    for (std::size_t i = 0; i < series.size(); ++i) {
        const FlowSeries& s = series[i];
        std::string name = s.exit ? "exit " : "line ";  // += : GCC 12 warns (-Wrestrict) on "literal" + string
        name += s.name;
        Series f;
        f.title = name + (s.width > 0 ? " (" + ch::formatNumber(s.width, 3) + " m)" : " (no crossing)");
        f.colour = seriesColour(i);
        f.width = 2;
        f.points = windowedSpecificFlow(s, safety.flowWindow);
        if (f.points.empty())
            for (const auto& [t, v] : s.specificFlow) f.points.emplace_back(t, v);
        flow.series.push_back(std::move(f));
        Series fw, bw;
        fw.title = name;
        fw.colour = bw.colour = seriesColour(i);
        fw.width = bw.width = 2;
        bw.dash = dashed();
        double sum = 0;
        for (const auto& [t, v] : s.forward) fw.points.emplace_back(t, sum += v);
        sum = 0;
        for (const auto& [t, v] : s.backward) bw.points.emplace_back(t, sum += v);
        counts.series.push_back(std::move(fw));
        if (s.totalBackward > 0) counts.series.push_back(std::move(bw));
    }
    Series cap;
    cap.title = "capacity " + ch::formatNumber(safety.flowCapacity, 4) + " P/(m·s) (<Safety flow_capacity>)";
    cap.colour = "#000000";
    cap.width = 1.5;
    cap.dash = dashed();
    cap.points = {{0.0, safety.flowCapacity}, {std::max(tmax, 1.0), safety.flowCapacity}};
    flow.series.push_back(std::move(cap));
    GnuplotJob job;
    addTimePanels(job, "Flows: " + figureName(e, *run, venue), 2, 1, {flow, counts}, tmax, std::nullopt);
    drawInto(job, pngTerminal(1500, 1100), e.dir / "flows.png", written, errors);
}

void drawAreas(const Experiment& e, std::vector<fs::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes) {
    const RunData* run = firstWith(e, "areas.csv", "areas.png", "the scenario has no measurement area", notes);
    if (!run) return;
    std::vector<AreaSeries> series;
    if (const std::string err = readAreas(run->dir / "areas.csv", series); !err.empty()) {
        errors.push_back("areas.png: " + err);
        return;
    }
    std::string note;
    const VenueOverlay venue = VenueOverlay::load(*run, note);
    double tmax = 0, peakDensity = 0;
    for (const AreaSeries& s : series) {
        if (!s.density.empty()) tmax = std::max(tmax, s.density.back().first);
        if (const auto p = peak(s.density)) peakDensity = std::max(peakDensity, *p);
    }
    Panel density, speed;
    density.title = "Density in each area (people inside / area), against Fruin's walkway levels";
    density.ylabel = "density (P/m²)";
    density.key = true;
    density.plainText = true;
    density.yMax = std::max(1.15 * peakDensity, 1.2 * ch::fruinLowerDensity('C'));
    for (const char level : {'A', 'B', 'C', 'D', 'E', 'F'}) {
        YBand b;
        b.y0 = level == 'A' ? 0.0 : ch::fruinLowerDensity(level);
        b.y1 = level == 'F' ? 1e9 : ch::fruinLowerDensity(static_cast<char>(level + 1));
        b.colour = pale(losColour(level), 0.72);
        b.label = std::string(1, level);
        density.bands.push_back(b);
    }
    speed.title = "Mean speed of the people in each area";
    speed.ylabel = "speed (m/s)";
    speed.plainText = true;
    for (std::size_t i = 0; i < series.size(); ++i) {
        Series d, v;
        d.title = v.title = series[i].name;
        d.colour = v.colour = seriesColour(i);
        d.width = v.width = 2;
        d.points = series[i].density;
        // No speed while the area is empty (areas.csv writes 0 there).
        for (std::size_t k = 0; k < series[i].speed.size() && k < series[i].people.size(); ++k)
            if (series[i].people[k].second > 0) v.points.push_back(series[i].speed[k]);
            else v.points.emplace_back(series[i].speed[k].first, std::nan(""));
        density.series.push_back(std::move(d));
        speed.series.push_back(std::move(v));
    }
    GnuplotJob job;
    addTimePanels(job, "Measurement areas: " + figureName(e, *run, venue), 2, 1, {density, speed}, tmax, std::nullopt);
    drawInto(job, pngTerminal(1500, 1100), e.dir / "areas.png", written, errors);
}

}  // namespace chplot
