// crowdhealth sweep — a parameter study: the Cartesian product of --vary values × N seeds, run on
// the cores of this machine or, under mpirun/srun, on MPI ranks (docs/sweeps.md).
//
// The work is cut in four pieces; the runs go through the JobPool (job_pool.h: local threads or
// MPI ranks), a job being a run id and its result the record text (d):
//  (a) expandSweep: the ordered list of runs with stable ids (first --vary slowest, seed fastest);
//  (b) executeSweepRun: one run id → one SweepResult (single-threaded, deterministic), on
//      whichever thread or rank the pool gives it to;
//  (c) sweepCsv / sweepSummaryCsv: the outputs from the results in run-id order (never in
//      completion order), written by the controller (rank 0) only;
//  (d) records: one small file per finished run (OUTDIR/.sweep/runs/), written atomically by the
//      controller as results arrive, from which a second call with the same arguments resumes.
#pragma once

#include <crowdhealth/core/scenario.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace chcli {

/// One --vary TARGET=VALUES.
struct SweepAxis {
    std::string target;        ///< as given: "0.SPH.restDensityMax", "agents.pref_speed"
    ch::RampSpec ramp;         ///< the target as a ramp (from/to set per run)
    std::vector<double> values;
};

/// One run of the sweep.
struct SweepRun {
    std::size_t id = 0;           ///< position in the list (= row of sweep.csv)
    std::size_t combination = 0;  ///< index of the value combination (= row of sweep-summary.csv)
    std::vector<double> values;   ///< one per axis
    std::uint64_t seed = 0;
};

/// What one run gives (one row of sweep.csv).
struct SweepResult {
    bool ok = false;
    std::string error;                    ///< why it failed (not ok)
    std::size_t evacuated = 0;
    std::optional<double> evacuationTime; ///< s; empty when agents remain
    std::optional<double> flow;           ///< persons/s
    double peakDensity = 0;               ///< 1/m², largest max_density of metrics.csv
    double peakContactAccel = 0;          ///< m/s², largest max_contact_accel
    std::size_t injured = 0;
    std::string verdict;                  ///< safe, caution, dangerous, critical
    double wallTime = 0;                  ///< s (the only column that varies between calls)
};

/// Parses VALUES: "3,5,7" or "a:b:step" (b included within 1e-9 of a step). Returns the reason
/// when it is not valid (empty, not a number, step ≤ 0, b < a, a repeated value, over 100000).
std::optional<std::string> parseSweepValues(const std::string& text, std::vector<double>& values);

/// Parses TARGET of `--vary TARGET=VALUES` (and of `calibrate --fit TARGET=LO:HI`) into a ramp:
/// POLICY.COMPONENT.PARAMETER or agents.ATTRIBUTE. Returns the reason when it is malformed; the
/// check against the scenario's tables is ch::rampTargetProblem's.
std::optional<std::string> parseSweepTarget(const std::string& target, ch::RampSpec& ramp);

/// (a) The runs: combination-major (the first axis varies slowest), seeds S … S+N−1 innermost.
std::vector<SweepRun> expandSweep(const std::vector<SweepAxis>& axes, std::uint64_t firstSeed,
                                  std::size_t replications);

/// (d) A result as a record file (every number to 17 digits, so it reads back exactly) and back.
std::string sweepRecordText(const SweepRun& run, const SweepResult& r);
std::optional<SweepResult> parseSweepRecord(const std::string& text, const SweepRun& run);

/// (c) sweep.csv and sweep-summary.csv from results indexed by run id (nullopt: not run).
std::string sweepCsv(const std::vector<SweepAxis>& axes, const std::vector<SweepRun>& runs,
                     const std::vector<std::optional<SweepResult>>& results);
std::string sweepSummaryCsv(const std::vector<SweepAxis>& axes, const std::vector<SweepRun>& runs,
                            const std::vector<std::optional<SweepResult>>& results);

/// FNV-1a of a file's bytes, as 16 hex digits (resume refuses a scenario or data file that
/// changed since the first call: sweep's and calibrate's `arguments` files).
std::string fileHash(const std::filesystem::path& p);

/// `path` made absolute and canonical where it can be (the files as `arguments` names them).
std::string canonicalPath(const std::string& path);

/// Lines naming, with their content hashes, the files a scenario reads besides its main file
/// (`included`: ScenarioSpec::includedFiles) and every plugin loaded (--plugin and <Plugin file>), for the
/// `arguments` files: a resumed sweep or calibration refuses one that was edited or rebuilt.
std::string readFilesText(const std::vector<std::string>& included);

/// The first line where two texts differ, as "there: 'A', now: 'B'" (resume's refusal message).
std::string firstDifference(const std::string& was, const std::string& now);

/// `crowdhealth sweep …` (argv[0] is "sweep"). Exit statuses as the program's (exit_codes.h).
int sweepCommand(int argc, char* argv[]);

}  // namespace chcli
