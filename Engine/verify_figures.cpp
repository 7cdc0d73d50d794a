// crowdhealth verify — charts of the tests (verify_figures.h).
#include "verify_figures.h"

#include "plot.h"
#include "plot_gnuplot.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace chverify {

namespace {

std::string withStyle(const ChartSeries& s, const std::string& colour) {
    const std::string lc = " lc rgb '" + colour + "'";
    const std::string dash = s.dashed ? " dt 2" : "";
    if (s.style == "lines") return "with lines lw 2" + dash + lc;
    if (s.style == "points") return "with points pt 7 ps 1.1" + lc;
    if (s.style == "steps") return "with steps lw 2" + dash + lc;
    if (s.style == "errorbars") return "with yerrorlines lw 2 pt 7 ps 0.9" + dash + lc;
    return "with linespoints lw 2 pt 7 ps 0.9" + dash + lc;
}

}  // namespace

std::string modelColour(const std::string& model) {
    const auto& names = modelNames();
    const auto it = std::find(names.begin(), names.end(), model);
    return chplot::seriesColour(it == names.end() ? names.size() : static_cast<std::size_t>(it - names.begin()));
}

namespace {

/// The commands and data of one chart (one `plot`) into `job`; the number of series drawn. Every
/// setting a chart may change is set, so that charts of one multiplot do not inherit each other's.
std::size_t addChart(chplot::GnuplotJob& job, const Chart& chart) {
    job.cmd("set title " + chplot::gpString(chart.title) + " noenhanced font ',14'");
    job.cmd("set xlabel " + chplot::gpString(chart.xlabel) + " noenhanced");
    job.cmd("set ylabel " + chplot::gpString(chart.ylabel) + " noenhanced");
    job.cmd("set grid lc rgb '#d0d0d0'");
    job.cmd(chart.keyPosition == "off" ? "set key off" : "set key " + chart.keyPosition + " noenhanced box opaque");
    if (chart.xrange) job.cmd("set xrange [" + std::to_string(chart.xrange->first) + ":" + std::to_string(chart.xrange->second) + "]");
    else job.cmd("set autoscale x");
    if (chart.yrange) job.cmd("set yrange [" + std::to_string(chart.yrange->first) + ":" + std::to_string(chart.yrange->second) + "]");
    else job.cmd("set autoscale y");
    job.cmd(chart.equalAxes ? "set size ratio -1" : "set size noratio");
    std::string plot;
    std::size_t drawn = 0;
    for (std::size_t i = 0; i < chart.series.size(); ++i) {
        const ChartSeries& s = chart.series[i];
        if (s.points.empty()) continue;
        const std::string colour = s.colour.empty() ? chplot::seriesColour(i) : s.colour;
        plot += std::string(drawn++ ? ", " : "plot ") + "'-' " + withStyle(s, colour) + " title " + chplot::gpString(s.title);
    }
    if (!drawn) return 0;
    job.cmd(plot);
    for (const ChartSeries& s : chart.series)
        if (!s.points.empty()) job.data(s.points);
    return drawn;
}

}  // namespace

std::string drawChart(const Chart& chart, const std::filesystem::path& png) {
    chplot::GnuplotJob job;
    if (!addChart(job, chart)) return "nothing to draw";
    return chplot::drawPng(job, chplot::pngTerminal(1000, 650), png);
}

std::string drawChartGrid(const std::vector<Chart>& charts, std::size_t columns, const std::string& title,
                          const std::filesystem::path& png, int width, int height) {
    if (charts.empty() || columns == 0) return "nothing to draw";
    const std::size_t rows = (charts.size() + columns - 1) / columns;
    chplot::GnuplotJob job;
    job.cmd("set multiplot layout " + std::to_string(rows) + "," + std::to_string(columns) + " title " +
            chplot::gpString(title) + " noenhanced font ',15'");
    std::size_t drawn = 0;
    for (const Chart& c : charts) {
        const std::size_t n = addChart(job, c);
        if (!n) job.cmd("set multiplot next");
        drawn += n;
    }
    if (!drawn) return "nothing to draw";
    return chplot::drawPng(job, chplot::pngTerminal(width, height), png);
}

std::optional<Spread> spreadOf(const std::vector<double>& v) {
    Spread s;
    double sum = 0;
    for (double x : v) {
        if (!std::isfinite(x)) continue;
        s.min = s.n ? std::min(s.min, x) : x;
        s.max = s.n ? std::max(s.max, x) : x;
        sum += x;
        ++s.n;
    }
    if (!s.n) return std::nullopt;
    s.mean = sum / static_cast<double>(s.n);
    return s;
}

std::vector<ChartSeries> perModelSeries(const FigureInput& in, const std::string& key,
                                        const std::function<double(std::size_t variant)>& xOf) {
    std::vector<ChartSeries> out;
    for (const std::string& m : in.models) {
        std::map<std::size_t, std::vector<double>> byVariant;
        for (const FigureRun& r : in.runs) {
            if (r.model != m || !r.outcome) continue;
            const auto it = r.outcome->values.find(key);
            if (it != r.outcome->values.end()) byVariant[r.variant].push_back(it->second);
        }
        ChartSeries s;
        s.title = m;
        s.style = "errorbars";
        s.colour = modelColour(m);
        for (const auto& [v, values] : byVariant)
            if (const auto sp = spreadOf(values)) s.points.push_back({xOf(v), sp->mean, sp->min, sp->max});
        std::sort(s.points.begin(), s.points.end());
        if (!s.points.empty()) out.push_back(std::move(s));
    }
    return out;
}

}  // namespace chverify
