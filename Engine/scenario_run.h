// crowdhealth — the pieces a single run and a set of replications share: loading the scenario
// (with the command line's overrides), deciding the end time and trajectory files, and running one
// simulation into a folder (step loop, Ctrl-C check, atomic outputs, summary.json last).
#pragma once

#include "cli.h"

#include <crowdhealth/io/output.h>
#include <crowdhealth/health/safety.h>
#include <crowdhealth/core/simulation.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace chcli {

/// Loads the scenario of o.input with `seed` (nullopt: Simulation@seed) and applies
/// --flow-first/--flow-last. Prints every error on stderr (and the warnings too when
/// `printWarnings`) and returns nullopt when the scenario is not usable; nothing is written.
std::optional<ch::ScenarioSpec> loadSpec(const Options& o, std::optional<std::uint64_t> seed, bool printWarnings);
/// The same, printing to `err` instead of stderr (the Python module collects the messages).
std::optional<ch::ScenarioSpec> loadSpec(const Options& o, std::optional<std::uint64_t> seed, bool printWarnings,
                                         std::ostream& err);

/// Builds the simulation of a loaded spec; on failure (e.g. a component the registry does not
/// know) prints the reason and returns nullptr. The simulation keeps its own copy of the spec:
/// pass an rvalue (std::move) when the caller no longer needs it, which saves copying every
/// agent's spec (a 10k-agent scene: ~3 MB, ~700 fresh pages; issue 20).
std::unique_ptr<ch::Simulation> buildSimulation(ch::ScenarioSpec spec, const Options& o);
/// The same, printing to `err`.
std::unique_ptr<ch::Simulation> buildSimulation(ch::ScenarioSpec spec, const Options& o, std::ostream& err);

/// How a scenario is run: which trajectory files, and until when.
struct RunPlan {
    ch::TrajectoryFormats trajectories;  ///< --trajectories, else <Output trajectories>
    /// s between trajectory frames (--trajectory-interval, else <Output trajectory_interval>);
    /// 0: every coarse step.
    double trajectoryInterval = 0;
    bool useSafetyCap = false;             ///< no end time at all: stop at kSafetyCapSeconds
    std::optional<double> endTimeOverride; ///< --end-time
    ch::RunInfo info;                      ///< scenario, endTime, endTimeSource filled in
};

/// Decides the plan from the options and the spec. Prints an error and returns nullopt when the
/// trajectory choice is invalid or an agent id does not fit in trajectories.bin; prints the "no
/// end time" warning, and one about a --trajectory-interval off the coarse steps, when `warn`.
std::optional<RunPlan> planRun(const Options& o, const ch::ScenarioSpec& spec, bool warn);
/// The same, printing to `err`.
std::optional<RunPlan> planRun(const Options& o, const ch::ScenarioSpec& spec, bool warn, std::ostream& err);

/// Creates `dir` and checks that a file can be created in it. Returns the reason it cannot be
/// used (a complete message line without a trailing newline), or nullopt when it can.
std::optional<std::string> outputFolderProblem(const std::filesystem::path& dir);

/// Why an output folder cannot be used, and the exit status that calls for.
struct FolderProblem {
    std::string message;  ///< after "crowdhealth: error: ", no trailing newline
    int exitStatus;       ///< kExitInput: files the program does not know; kExitRuntime: not writable
};

/// Before a run into `dir`: unless `overwrite`, refuses a folder that holds files crowdhealth did
/// not write (output_folder.h); then outputFolderProblem(dir). Nothing is written when it refuses.
std::optional<FolderProblem> checkOutputFolder(const std::filesystem::path& dir, bool overwrite);

/// Callbacks and extra measurements of one run.
struct RunHooks {
    /// After every coarse step (progress display).
    std::function<void(const ch::Simulation&)> afterStep;
    /// Once the loop has ended, before the outputs are written (also when the simulation failed).
    std::function<void(const ch::Simulation&)> afterLoop;
    /// Take mean_density at the first coarse step at or after this time (s): the metrics row of
    /// that step when there is one, else a measurement of its own (which changes nothing).
    std::optional<double> probeMeanDensityAt;
    /// Free the simulation's agent specs once every agent is in the world
    /// (ch::Simulation::releaseAgentSpecs: 240 bytes per agent), for callers whose hooks do not
    /// read spec().agents. Nothing the run computes or writes reads them.
    bool releaseAgentSpecs = false;
};

struct RunOutcome {
    /// Empty: the run completed (possibly interrupted) and every output is written. Otherwise the
    /// message (after "crowdhealth: error: ") of the failure; the outputs are then not written.
    std::string error;
    ch::RunInfo info;          ///< the plan's info with interrupted, stoppedAtSafetyCap, wall time, threads
    ch::MetricsPeaks peaks;
    std::optional<double> probedMeanDensity;  ///< 1/m², see RunHooks::probeMeanDensityAt
    ch::Verdict verdict;       ///< the safety verdict (also in summary.json)
    /// Problems that did not stop the run (an earlier run's file that could not be removed).
    std::vector<std::string> warnings;
};

/// One run, step by step: the recorders the program keeps during a run (metrics, safety measures
/// and verdict, measurement lines and areas, trajectories) and the files it writes at the end.
/// simulateAndWrite drives it; the Python module (Engine/python) drives it one step at a time, so
/// that both record exactly the same rows.
class RunSession {
public:
    /// Sets the end time override of the plan and the thread count, and opens the trajectory
    /// files in `trajectoryDir` when the plan asks for trajectories (it must exist). Throws
    /// std::exception when they cannot be created.
    RunSession(ch::Simulation& sim, const RunPlan& plan, const std::filesystem::path& trajectoryDir, int threads);
    ~RunSession();
    RunSession(const RunSession&) = delete;
    RunSession& operator=(const RunSession&) = delete;

    /// The records of t = 0, before the first step. Called once, first.
    void begin();
    /// True when the run is over: the simulation finished, or (no end time) the safety cap is
    /// reached (then info().stoppedAtSafetyCap is set).
    bool done();
    /// One coarse step and its records.
    void step();
    /// The records of the final time (a metrics row and trajectory frame off the interval), and
    /// the verdict. Called once, after the last step; nothing is recorded afterwards.
    void end();
    bool ended() const { return ended_; }

    /// Writes metrics.csv, evacuations.csv, health.csv, heatmap.csv, flows.csv and areas.csv when
    /// there are lines or areas, the trajectories (moved from trajectoryDir) and summary.json (last)
    /// atomically into `outDir`, which must exist, and settles its manifest (output_folder.h).
    /// Calls end() first if it was not called. Returns problems that did not stop the writing;
    /// throws std::exception when a file cannot be written. `beforeSummary` runs just before
    /// summary.json is written (tests: a kill at the worst instant).
    std::vector<std::string> write(const std::filesystem::path& outDir, const std::function<void()>& beforeSummary = {});

    ch::Simulation& simulation() { return sim_; }
    const ch::MetricsRecorder& metrics() const;
    /// The run's info (the plan's, with stoppedAtSafetyCap, threads and wall time of the steps so far).
    ch::RunInfo& info() { return info_; }
    /// The safety verdict: after end(), the run's; before, that of the run so far.
    ch::Verdict verdict() const;
    ch::MetricsPeaks peaks() const;

private:
    struct Recorders;
    ch::Simulation& sim_;
    const RunPlan plan_;
    std::unique_ptr<Recorders> rec_;
    ch::RunInfo info_;
    ch::Verdict verdict_;
    bool ended_ = false;
    double wallSeconds_ = 0;
    double stepSeconds_ = 0, recordSeconds_ = 0;  ///< of wallSeconds_: the steps, the recorders
    /// Of recordSeconds_, each recorder's (RunInfo::safetySeconds …).
    double safetySeconds_ = 0, metricsSeconds_ = 0, measurementSeconds_ = 0, trajectorySeconds_ = 0;
    /// The recorders after a step (or at t = 0: `first`), each one timed.
    void record(bool first);
};

/// Runs `sim` on `threads` OpenMP threads (set in the calling thread) until it finishes, the
/// safety cap, or Ctrl-C, then writes metrics.csv, evacuations.csv, health.csv, heatmap.csv,
/// trajectories and summary.json (last, with the safety verdict) atomically into `outDir`, which
/// must exist; then replaces the folder's manifest by the files written, removing the files of
/// the previous manifest that this run did not write (output_folder.h).
RunOutcome simulateAndWrite(ch::Simulation& sim, const RunPlan& plan, const std::filesystem::path& outDir,
                            int threads, const Options& o, const RunHooks& hooks);

/// "1 agent" / "3 agents".
std::string plural(std::size_t n, const char* word);

}  // namespace chcli
