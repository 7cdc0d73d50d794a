// crowdhealth verify — one kind of figure for every test: an x–y chart of several series (a model's
// mean over the seeds with its spread, experimental data as points, a reference curve as a line),
// drawn by gnuplot into a PNG. A test's `figure` (verify_suite.h) fills a Chart from its outcomes.
#pragma once

#include "verify_suite.h"

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace chverify {

struct ChartSeries {
    std::string title;
    /// "lines" (x y), "linespoints" (x y), "points" (x y), "errorbars" (x y ylo yhi: drawn as
    /// points with bars and joined by a line), "steps" (x y).
    std::string style = "linespoints";
    std::string colour;  ///< "#rrggbb"; empty: the model's or the series' place in the palette
    std::vector<std::vector<double>> points;
    bool dashed = false;
};

struct Chart {
    std::string title, xlabel, ylabel;
    std::vector<ChartSeries> series;
    std::optional<std::pair<double, double>> xrange, yrange;
    std::string keyPosition = "top right";  ///< gnuplot `set key` position, or "off"
    bool equalAxes = false;  ///< one metre is as long on both axes (trajectories, plans)
};

/// Draws `chart` into `png` (1000 × 650); "" on success, else an error (e.g. no gnuplot).
std::string drawChart(const Chart& chart, const std::filesystem::path& png);

/// Small multiples: `charts` side by side, `columns` to a row (as many rows as needed), under one
/// `title`, in one PNG of width × height; "" on success, else an error. A chart without series
/// leaves its place empty.
std::string drawChartGrid(const std::vector<Chart>& charts, std::size_t columns, const std::string& title,
                          const std::filesystem::path& png, int width = 1400, int height = 1000);

/// The colour of a model in every figure (its place in modelNames()); data and references use
/// black and greys.
std::string modelColour(const std::string& model);

/// Mean, smallest and largest of `v` (NaNs skipped); nullopt when nothing is left.
struct Spread {
    double mean = 0, min = 0, max = 0;
    std::size_t n = 0;
};
std::optional<Spread> spreadOf(const std::vector<double>& v);

/// For a figure of one value per variant: per model, the points (x of the variant, mean, min,
/// max) over the seeds of outcome.values[key]; xOf gives the variant's x.
std::vector<ChartSeries> perModelSeries(const FigureInput& in, const std::string& key,
                                        const std::function<double(std::size_t variant)>& xOf);

}  // namespace chverify
