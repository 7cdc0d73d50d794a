// crowdhealth plot / compare — reading the files of finished runs (DESIGN §6): metrics.csv,
// health.csv, heatmap.csv and summary.json of a run folder, or of every run_XXX of a
// replications folder. Nothing here draws; plot.cpp and compare.cpp do.
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace chplot {

namespace fs = std::filesystem;

/// A CSV file with a header row: numbers by column; an empty or unreadable cell is NaN.
struct Table {
    std::vector<std::string> header;
    std::vector<std::vector<double>> rows;

    /// Index of the column called `name`, or -1.
    int column(std::string_view name) const;
    /// Every value of column `name` (empty when the column is absent).
    std::vector<double> values(std::string_view name) const;
};

/// Reads a CSV file with a header row. Returns an error message, or "" on success.
std::string readCsv(const fs::path& file, Table& table);

/// The fixed columns of metrics.csv; any further column is a ramped parameter (DESIGN §6).
inline constexpr int kFixedMetricsColumns = 14;

/// What summary.json says about one run (only what the plots and tables use).
struct RunSummary {
    bool present = false;
    std::string scenario;
    std::optional<double> evacuationTime;  ///< s
    std::optional<double> flow;            ///< persons/s
    bool interrupted = false;
    std::string verdict;                   ///< "safe", "caution", "dangerous", "critical", or "" if none
};

/// One run folder.
struct RunData {
    std::string name;  ///< the folder's name, e.g. "run_003"
    fs::path dir;
    Table metrics;
    std::optional<Table> health;   ///< health.csv, when present
    std::optional<Table> heatmap;  ///< heatmap.csv, when present
    RunSummary summary;
};

/// A run folder (one run) or a replications folder (run_XXX/ subfolders): an "experiment".
struct Experiment {
    std::string name;  ///< the folder's name
    fs::path dir;
    bool replications = false;
    std::vector<RunData> runs;
};

/// Loads `dir`: a folder holding metrics.csv is one run; else its run_* subfolders holding
/// metrics.csv are the runs (in name order). Returns an error message, or "" on success.
std::string loadExperiment(const fs::path& dir, Experiment& experiment);

/// The name of a folder as the user sees it ("out/base/" → "base", "." → the current folder's name).
std::string folderName(const fs::path& dir);

/// A curve over time: (t, value) points with finite values.
using Curve = std::vector<std::pair<double, double>>;

/// Column `name` of metrics.csv against time (empty when the column is absent).
Curve metricsCurve(const RunData& run, std::string_view name);

/// The mean and sample standard deviation over runs, at each time at which a run has a row
/// (times matched to the millisecond; between two rows a run counts with the earlier one). It
/// stops when the first run ends (a mean over the runs still going would jump there), unless
/// `holdLast`: then a run that has ended keeps its last value (for counts such as the agents
/// remaining) and the mean goes on to the last run's end.
struct MeanPoint {
    double t, mean, sd;
    std::size_t n;
};
std::vector<MeanPoint> meanCurve(const std::vector<Curve>& curves, bool holdLast);

/// The time span over which the ramped parameters of a run (the extra metrics.csv columns)
/// change: from the first row that differs from the first value to the last row that differs
/// from the final value. nullopt if there are no extra columns or none changes.
std::optional<std::pair<double, double>> rampWindow(const RunData& run);

/// The same for one ramped parameter (an extra metrics.csv column, by name): nullopt when the
/// run has no such column or it never changes.
std::optional<std::pair<double, double>> rampWindow(const RunData& run, const std::string& column);

/// The largest finite value of a curve (nullopt if empty).
std::optional<double> peak(const Curve& c);

/// The value at the first row at or after time t (nullopt if the curve ends before).
std::optional<double> valueAt(const Curve& c, double t);

}  // namespace chplot
