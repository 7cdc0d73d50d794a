// crowdhealth calibrate — fits parameters of a scenario so that what its runs measure matches
// experimental data (docs/sweeps.md, Calibration).
//
//  * The data: a CSV whose header names the experimental variables (e.g. `width`), one observable
//    (`flow`, `speed` or `evacuation_time`) and optionally `weight`; `#` lines are comments.
//  * The scenario is a template: every `${EXPR}` in its text is replaced, per distinct row of
//    variable values (a "condition"), by the value of EXPR — a variable of the data file or an
//    arithmetic expression of them (`${4 - width/2}`; + − * /, parentheses, sqrt, floor, ceil,
//    round, abs). The filled-in text is loaded in memory under the template's name.
//  * One evaluation of the objective = every condition × the seeds S … S+N−1 (the same seeds at
//    every evaluation: common random numbers), run as one batch of jobs through JobPool (local
//    threads, or MPI ranks). The objective is Σ weight · (model mean − data)² over the data rows
//    (or of the relative residual, --residuals relative).
//  * The search is nelderMeadInBox (nelder_mead.h) in the box of the --fit ranges.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace chcli {

/// What a run measures that data can be compared with.
enum class Observable { Flow, Speed, EvacuationTime };

/// The experimental data of --data.
struct CalibrationData {
    std::vector<std::string> variables;  ///< the experimental variables, in column order
    Observable observable = Observable::Flow;
    std::string observableName;          ///< "flow", "speed" or "evacuation_time"
    struct Row {
        std::vector<double> x;  ///< one per variable
        double y = 0;           ///< the observed value
        double weight = 1;
        int line = 0;           ///< in the file
        std::size_t condition = 0;
    };
    std::vector<Row> rows;
    /// The distinct variable values, in the order they first appear (each is simulated once per
    /// seed; several rows may share one, as Kretz's repeated runs at one width).
    std::vector<std::vector<double>> conditions;
};

/// Parses the data file's text. On a problem returns nullopt and sets `error` to
/// "PATH:LINE: error: …".
std::optional<CalibrationData> parseCalibrationData(const std::string& text, const std::string& path,
                                                    std::string& error);

/// Replaces every ${EXPR} of `text` by the value of EXPR with `variables` (shortest text that
/// reads back exactly). Names used are added to `used`. On a problem (no closing brace, an unknown
/// name, a syntax error, a result that is not finite) returns nullopt and sets `error` to
/// "PATH:LINE: error: …".
std::optional<std::string> fillPlaceholders(const std::string& text, const std::string& path,
                                            const std::map<std::string, double>& variables,
                                            std::set<std::string>& used, std::string& error);

/// `crowdhealth calibrate …` (argv[0] is "calibrate"). Exit statuses as the program's (exit_codes.h).
int calibrateCommand(int argc, char* argv[]);

}  // namespace chcli
