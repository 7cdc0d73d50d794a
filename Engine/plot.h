// crowdhealth plot — the figures of a run or of a set of replications, as PNG (gnuplot):
//
//   crowdhealth plot DIR [-q]                      (also: crowdhealth -i … -o DIR --plot)
//
// Writes into DIR (a run folder, or a replications folder holding run_XXX/):
//   fig3.png      van Toll et al.'s Fig. 3: mean density, mean contact acceleration, mean speed
//                 and agents remaining over time, one colour per run (and their mean)
//   health.png    max contact acceleration, mean panic, injured and crowd pressure over time
//   schedule.png  the ramped parameters (metrics.csv's extra columns), when there are any
//   heatmap.png   where high density and crush happened (heatmap.csv), when present
//   paths.png     every agent's path coloured by its exit, over the venue, when the run wrote
//                 trajectories (plot_paths.h)
//   los.png       Fruin's level of service per cell (heatmap.csv's worst_los) over the venue
//   flows.png     specific flow through each measurement line and exit (flows.csv)
//   areas.png     density in each measurement area against Fruin's levels (areas.csv)
//                 (the last three: plot_measure.h, docs/measurement.md)
// See docs/crowd-health.md, "Plots".
#pragma once

#include "plot_data.h"
#include "plot_gnuplot.h"

#include <boost/program_options.hpp>

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace chcli {

/// Runs the `plot` subcommand; argv[0] is "plot". Exit status (exit_codes.h): 0; 1 when gnuplot
/// is missing or fails or DIR cannot be written; 2 for a bad command line or a DIR that holds no
/// run.
int plotCommand(int argc, char* argv[]);

/// Parses the command line of a subcommand that takes folders (`plot`, `compare`): the `visible`
/// options plus any number of DIR arguments, into vm and dirs. On a bad command line prints
/// "crowdhealth NAME: error: …" with the --help hint and returns false.
bool parseFolderCommand(const std::string& name, const boost::program_options::options_description& visible, int argc,
                        char* argv[], boost::program_options::variables_map& vm, std::vector<std::string>& dirs);

/// --plot, before anything runs: prints the error and returns false when gnuplot is missing.
bool plotAvailable(const char* what);

/// --plot, after the run(s): draws the figures of `dir`. Prints what it wrote (unless quiet)
/// or why it could not; returns an exit status as plotCommand.
int plotOutputs(const std::filesystem::path& dir, bool quiet);

}  // namespace chcli

namespace chplot {

/// One line of a time-series panel, optionally with a band (t, low, high) behind it.
struct Series {
    std::string title;  ///< key entry ("" = none)
    std::string colour; ///< "#rrggbb"
    double width = 1.5;
    Curve points;
    std::vector<std::array<double, 3>> band;
    std::string dash;   ///< gnuplot dash type, e.g. "2" (dashed); "" = solid
};

/// A horizontal band of a panel (values y0 to y1, in the panel's units) behind the curves, with a
/// label at its right end (e.g. Fruin's levels in areas.png).
struct YBand {
    double y0 = 0, y1 = 0;
    std::string colour;  ///< "#rrggbb" (give a pale one: the curves are drawn over it)
    std::string label;
};

/// One panel of values against time.
struct Panel {
    std::string title, ylabel;
    std::vector<Series> series;
    bool key = false;  ///< show the key in this panel
    std::string keyWhere = "top right";  ///< gnuplot's key position, e.g. "below"
    bool integerY = false;
    bool plainText = false;  ///< title and ylabel without enhanced-text markup (e.g. '_')
    std::string zeroLabel;   ///< written across the panel when every value is 0 (e.g. "nobody injured")
    std::vector<YBand> bands;  ///< behind the curves; the y range then ends at yMax
    double yMax = 0;           ///< > 0: the y range is [0, yMax] (else from the data)
    double rightMargin = 0;    ///< > 0: the plot ends at this fraction of the width (room for an outside
                               ///< key) and begins at 0.07, so that panels line up; 0: automatic
    bool ownRamp = false;      ///< shade `ramp` (this panel's own window, or nothing) instead of the figure's
    std::optional<std::pair<double, double>> ramp;  ///< with ownRamp: the time span shaded grey (s)
};

/// The smallest positive gap between the sorted distinct values (a grid's cell size), else 1.
double gridStep(std::vector<double> v);

/// The i-th colour of the qualitative palette used for runs and experiments.
std::string seriesColour(std::size_t i);

/// Adds a multiplot of `panels` (rows × cols, filled row by row) sharing the time axis
/// [0, tmax], with `ramp` (when given) shaded in every panel.
void addTimePanels(GnuplotJob& job, const std::string& figureTitle, int rows, int cols,
                   const std::vector<Panel>& panels, double tmax, std::optional<std::pair<double, double>> ramp);

/// Draws every figure of `e` into e.dir; appends the PNGs written to `written`, failures to
/// `errors` and remarks (a figure without data) to `notes`.
void drawExperiment(const Experiment& e, std::vector<std::filesystem::path>& written, std::vector<std::string>& errors,
                    std::vector<std::string>& notes);

}  // namespace chplot
