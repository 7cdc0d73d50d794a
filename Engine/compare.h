// crowdhealth compare — several runs or experiments side by side (van Toll et al. 2021, Table 1):
//
//   crowdhealth compare DIR... [-o OUTDIR] [--no-plot] [-q]
//
// Each DIR is a run folder (metrics.csv) or a replications folder (run_XXX/); it is named by its
// folder name. Writes into OUTDIR (default: the current folder):
//   compare.md / compare.csv  per experiment: evacuation time, flow, mean density at 15 s, peak
//                             mean density, peak mean and max contact acceleration, erraticness,
//                             injured and the verdicts, as mean ± sd over the runs
//   compare.png               the mean curves of every experiment over time (± sd shaded)
// and prints the table. See docs/crowd-health.md, "Plots".
#pragma once

#include "plot_data.h"

#include <string>
#include <vector>

namespace chcli {

/// Runs the `compare` subcommand; argv[0] is "compare". Exit status (exit_codes.h): 0; 1 when
/// gnuplot is missing or fails (the tables are written all the same) or OUTDIR cannot be
/// written; 2 for a bad command line or a DIR that holds no run.
int compareCommand(int argc, char* argv[]);

}  // namespace chcli

namespace chplot {

/// One statistic of one experiment over its runs.
struct Stat {
    std::size_t n = 0;  ///< runs with a value
    double mean = 0, sd = 0;  ///< sd is NaN when n < 2
};

/// One row of the comparison table.
struct CompareRow {
    std::string experiment;
    std::size_t runs = 0;
    std::vector<Stat> stats;  ///< in kCompareColumns order
    std::string verdicts;     ///< e.g. "dangerous 3" or "critical 1, dangerous 2"
};

/// A column of the comparison: the CSV key, the Markdown heading (with unit) and the decimals shown.
struct CompareColumn {
    const char* key;
    const char* heading;
    int decimals;
};
extern const std::vector<CompareColumn> kCompareColumns;

/// The table row of an experiment.
CompareRow compareRow(const Experiment& e);

/// "12.35 ± 0.41", "12.35" (one value), "12.35 ± 0.41 (n=8)" (fewer values than runs), "–" (none).
std::string formatStat(const Stat& s, int decimals, std::size_t runs);

/// compare.md's table (Markdown, columns padded so that it reads as text too) and compare.csv.
std::string compareMarkdownTable(const std::vector<CompareRow>& rows);
std::string compareCsv(const std::vector<CompareRow>& rows);

}  // namespace chplot
