// crowdhealth — command-line parsing (Boost.Program_options).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace chcli {

/// Largest --replications accepted (run folders are numbered with at least three digits).
inline constexpr std::uint64_t kMaxReplications = 100000;

enum class Command { Run, Check, ListPolicies, Help, Version };
enum class ListFormat { Text, Markdown };

struct Options {
    Command command = Command::Run;
    std::string input;               ///< -i: scenario XML
    std::string output;              ///< -o: output folder
    /// -t: OpenMP threads of the run; with --replications, the number of runs at a time (each
    /// on one thread). 0 = one per hardware thread.
    int threads = 0;
    std::optional<std::uint64_t> seed;     ///< --seed: overrides Simulation@seed
    std::optional<double> endTime;         ///< --end-time (s): overrides Simulation@end_time
    std::optional<std::string> trajectories;  ///< umans|txt|bin|both|none or a list; default from <Output>
    /// --trajectory-interval (s): overrides <Output trajectory_interval>
    std::optional<double> trajectoryInterval;
    /// --replications N: run seeds S … S+N−1 into OUTDIR/run_000 … and write OUTDIR/summary.csv.
    std::optional<std::uint64_t> replications;
    std::optional<int> flowFirst;  ///< --flow-first: overrides <Output flow_first>
    std::optional<int> flowLast;   ///< --flow-last: overrides <Output flow_last>
    /// --plot: after the run(s), draw fig3.png, health.png, schedule.png and heatmap.png into
    /// the output folder (plot.h).
    bool plot = false;
    /// --overwrite: run into OUTDIR even when it holds files crowdhealth did not write (they are
    /// kept; files named as this run's outputs are replaced). See output_folder.h.
    bool overwrite = false;
    bool quiet = false;
    /// --timing: print the wall time split into the simulation's steps and the recorders.
    bool timing = false;
    ListFormat format = ListFormat::Text;
    /// --plugin FILE (repeatable): plugins loaded before anything else (crowdhealth/plugin.h).
    std::vector<std::string> plugins;
    /// Hidden, for tests: raise SIGINT after this many coarse steps (exercises the real
    /// Ctrl-C path deterministically, without timing).
    std::optional<std::uint64_t> interruptAfterSteps;
    /// Hidden, for tests: SIGKILL itself while writing the outputs, after every file but
    /// summary.json (the state a run killed at that instant leaves).
    bool killBeforeSummary = false;
};

/// Parses argv. On success returns the options; on a usage error prints a message (and a hint
/// to --help) to `err` and returns std::nullopt (the caller exits with status 2).
std::optional<Options> parseCommandLine(int argc, const char* const argv[], std::ostream& err);

/// Loads the plugins of --plugin FILE (relative to the working folder, else CROWDHEALTH_PLUGIN_PATH).
/// On the first one refused prints "crowdhealth: error: --plugin 'FILE': why" to `err` and returns
/// false (the caller exits with status 2).
bool loadPlugins(const std::vector<std::string>& files, std::ostream& err);

/// The --help text.
void printHelp(std::ostream& out);
/// The --version line.
void printVersion(std::ostream& out);

}  // namespace chcli
