// CrowdHealth — recorders and writers for a run's outputs (DESIGN §6): metrics.csv,
// evacuations.csv, summary.json and trajectories (UMANS per-agent CSV, PedPy text).
//
// Reusable by any program that embeds a Simulation:
//
//     ch::MetricsRecorder metrics(spec.output.metricsInterval);
//     ch::TrajectoryRecorder traj;
//     metrics.sample(sim); traj.record(sim);            // t = 0
//     while (!sim.finished()) { sim.stepCoarse(); metrics.maybeSample(sim); traj.record(sim); }
//     metrics.finish(sim);
//     metrics.write(dir / "metrics.csv"); traj.writeUmans(dir); ...
//
// Every file is written whole or not at all: the text goes to `<name>.tmp` in the same folder,
// which is renamed over `<name>` only once it is complete and flushed (rename is atomic within a
// file system), so a crash or Ctrl-C never leaves a half-written file under the final name.
//
// Numbers are written with std::to_chars (locale-independent, general format, a fixed number of
// significant digits) and every sum runs in agent order, so the files are byte-identical for the
// same seed whatever the thread count.
#pragma once

#include "crowdhealth/simulation.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace ch {

struct Verdict;  // crowdhealth/safety.h

/// A file could not be created, written or renamed.
class OutputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// ---- number formatting ---------------------------------------------------------------------

/// Appends v in general format with `digits` significant digits ("%.6g"-like, never a comma as
/// decimal separator). NaN is written as "nan", infinities as "inf"/"-inf"; -0 as "0".
void appendNumber(std::string& out, double v, int digits = 6);
/// appendNumber into a new string.
std::string formatNumber(double v, int digits = 6);
/// JSON value of v with `digits` significant digits, or `null` if not finite. Ten digits keep
/// times such as 92·0.1 = 9.200000000000001 readable as 9.2 while losing nothing measurable.
std::string jsonNumber(double v, int digits = 10);
/// JSON string literal with quotes and escapes.
std::string jsonString(std::string_view s);

// ---- atomic files --------------------------------------------------------------------------

/// Writes `target` via `target.tmp` + rename. Destroying it without commit() removes the
/// temporary file and leaves any previous `target` untouched.
class AtomicFile {
public:
    /// Opens `<target>.tmp` for writing (truncating it). Throws OutputError if it cannot.
    explicit AtomicFile(std::filesystem::path target);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    std::ostream& stream() { return out_; }
    void write(std::string_view text) { out_.write(text.data(), static_cast<std::streamsize>(text.size())); }
    /// Flushes, closes and renames the temporary file to the target. Throws OutputError on any
    /// write or rename failure (the temporary file is removed).
    void commit();

    const std::filesystem::path& target() const { return target_; }
    const std::filesystem::path& temporary() const { return temp_; }

private:
    std::filesystem::path target_, temp_;
    std::ofstream out_;
    bool committed_ = false;
};

/// Writes `content` to `target` atomically (AtomicFile in one call).
void writeFileAtomic(const std::filesystem::path& target, std::string_view content);

// ---- metrics -------------------------------------------------------------------------------

/// The header of metrics.csv (no trailing newline).
inline constexpr const char* kMetricsHeader =
    "time,agents,evacuated,mean_density,max_density,mean_rest_density,mean_speed,max_speed,"
    "mean_contact_accel,max_contact_accel,max_wall_penetration,mean_panic,injured,crowd_pressure";

/// One row of metrics.csv: the crowd at one instant.
struct MetricsRow {
    double time = 0;              ///< s
    std::size_t agents = 0;       ///< active agents
    std::size_t evacuated = 0;    ///< agents removed at their goal so far
    double meanDensity = 0;       ///< SPH density (Poly6, h = 1 m, walls included), 1/m²
    double maxDensity = 0;        ///< 1/m²
    /// Mean of the component field "rest_density" over the agents whose policy provides it
    /// (1/m²); NaN (an empty cell) when no component provides it or none has a value yet.
    double meanRestDensity = 0;
    double meanSpeed = 0, maxSpeed = 0;                 ///< m/s
    double meanContactAccel = 0, maxContactAccel = 0;   ///< m/s²
    double maxWallPenetration = 0;                      ///< m
    double meanPanic = 0;        ///< 0..1, mean over the active agents (CrowdHealth layer)
    std::size_t injured = 0;     ///< agents injured so far, in the world or not (CrowdHealth layer)
    /// Helbing, Johansson & Al-Abideen 2007 "crowd pressure" ρ·Var(v) (1/s²): the largest value
    /// over the cells of crowdField() (crowdhealth/safety.h: Gaussian R = 0.7 m, 1 m cells).
    double crowdPressure = 0;
    /// Current values of the ramped parameters (Simulation::scheduleColumns()), after the fixed columns.
    std::vector<double> schedule;
};

/// Measures the crowd now. Calls sim.measureDensity(h) (which only fills agents().density) and
/// reads the frozen state; `h` (m) is the smoothing length of the density and pressure kernels.
MetricsRow measureMetrics(Simulation& sim, double h = 1.0);


/// The largest values over the rows of metrics.csv (so sampled every metrics interval, not every
/// step: a peak between two rows is not seen).
struct MetricsPeaks {
    double maxDensity = 0;          ///< 1/m²
    double maxMeanDensity = 0;      ///< 1/m²
    double maxContactAccel = 0;     ///< m/s²
    double maxWallPenetration = 0;  ///< m
};

/// Samples the metrics every `interval` seconds of simulated time (t = 0 included) and writes
/// metrics.csv. When the interval is not a whole number of coarse steps, a row is taken at the
/// first coarse step at or after each multiple of the interval (its time column is the actual
/// simulated time).
class MetricsRecorder {
public:
    /// `interval` in s (≤ 0 or NaN: every call to maybeSample() samples).
    explicit MetricsRecorder(double interval = 1.0, double smoothingLength = 1.0);

    /// Takes a row now (unless one was already taken at this exact time).
    void sample(Simulation& sim);
    /// Takes a row when the next multiple of the interval has been reached. Returns true if it did.
    bool maybeSample(Simulation& sim);
    /// Adds the row of the final time if the last row is not at sim.time().
    void finish(Simulation& sim);

    const std::vector<MetricsRow>& rows() const { return rows_; }
    MetricsPeaks peaks() const;
    /// The whole file: header + one line per row.
    std::string csv() const;
    /// Writes csv() atomically.
    void write(const std::filesystem::path& file) const { writeFileAtomic(file, csv()); }

private:
    double interval_, h_;
    std::vector<std::string> scheduleColumns_;  ///< taken from the simulation at the first sample
    std::uint64_t nextIndex_ = 0;  ///< the next sample is due at nextIndex_·interval_
    std::vector<MetricsRow> rows_;
};

// ---- evacuations ---------------------------------------------------------------------------

/// evacuations.csv: header `id,time`, one row per sim.evacuations() entry (already in time order).
std::string evacuationsCsv(const Simulation& sim);

// ---- trajectories --------------------------------------------------------------------------

/// Buffers every agent's state once per coarse step, then writes the trajectories at the end
/// (one file per agent must not mean one open file per agent).
///
/// Memory: 32 bytes per agent per coarse step (x, y, dir_x, dir_y as doubles; time is shared per
/// step), e.g. 400 agents × 1200 steps ≈ 15 MB.
class TrajectoryRecorder {
public:
    /// Records every active agent at the current coarse step (sim.coarseSteps()). Calling it twice
    /// at the same step records nothing new.
    void record(const Simulation& sim);

    /// Agents seen so far.
    std::size_t agentCount() const { return tracks_.size(); }
    /// Coarse steps recorded so far (including step 0 if recorded).
    std::size_t stepCount() const { return stepsRecorded_; }

    /// UMANS' format: one `output_<id>.csv` per agent in `dir`, rows `time,x,y,dir_x,dir_y`, no
    /// header, one row per coarse step while the agent is in the world, without the t = 0 row
    /// (UMANS records after each step). Each file is written atomically.
    void writeUmans(const std::filesystem::path& dir) const;
    /// PedPy-readable text (`# framerate: <1/delta_time>`, `# x/m`, `# y/m`, `# z/m`, then rows
    /// `id frame x y z` with z = 0 and frame = coarse step index, frame 0 = t = 0), in frame order
    /// then id order. Written atomically.
    void writePedPy(const std::filesystem::path& file, double deltaTime) const;

private:
    struct Run {
        std::uint64_t firstStep;  ///< coarse step of the run's first row
        std::size_t firstRow;     ///< index into rows
        std::size_t count;
    };
    struct Track {
        AgentId id;
        std::vector<Run> runs;  ///< usually one: agents are in the world for one contiguous span
        std::vector<double> rows;  ///< x, y, dir_x, dir_y per recorded step
    };
    std::vector<Track> tracks_;
    std::unordered_map<AgentId, std::size_t> trackOf_;
    std::vector<double> stepTime_;  ///< simulated time (s) of each recorded coarse step (NaN: none)
    std::size_t stepsRecorded_ = 0;
    bool any_ = false;
    std::uint64_t lastStep_ = 0;

    std::vector<std::size_t> tracksById() const;
};

// ---- summary -------------------------------------------------------------------------------

/// What the program knows about a run beyond the simulation state.
struct RunInfo {
    std::string scenario;            ///< path of the scenario file as given ("" = spec.sourceFile)
    double endTime = -1;             ///< s, the end time used (< 0: none, ran until empty/cap)
    std::string endTimeSource;       ///< "scenario", "command line" or "none" (then a safety cap applies)
    bool interrupted = false;        ///< stopped by SIGINT/SIGTERM
    bool stoppedAtSafetyCap = false; ///< stopped because the safety cap on simulated time hit
    double wallTimeSeconds = 0;      ///< wall-clock duration of the simulation loop (display only)
    int threads = 0;
};

/// Flow between the `first`-th and `last`-th evacuee (1-based): (last − first)/(t_last − t_first)
/// persons per second, nullopt when there are fewer than `last` evacuees or no time elapsed.
std::optional<double> evacuationFlow(const std::vector<Evacuation>& evacuations, int first, int last);

/// summary.json: scenario, seed, time steps, end/simulated time, interrupted, agent counts,
/// evacuation time, flow {first, last, persons_per_second}, peaks, wall time.
/// With `verdict`, a "verdict" member {"level", "reasons": [...]} is added (crowdhealth/safety.h).
std::string summaryJson(const Simulation& sim, const RunInfo& info, const MetricsPeaks& peaks,
                        const Verdict* verdict = nullptr);

/// The evacuation time of summary.json: when the last agent was removed at its goal, once nobody
/// is left (nullopt while agents remain or when nobody was evacuated).
std::optional<double> runEvacuationTime(const Simulation& sim);
/// The flow of summary.json: evacuationFlow() from spec().output.flowFirst to
/// min(flowLast, total agents).
std::optional<double> runFlow(const Simulation& sim);

// ---- replications (summary.csv) -------------------------------------------------------------

/// The header of a replications summary.csv (no trailing newline).
inline constexpr const char* kReplicationsHeader =
    "run,seed,evacuated,evacuation_time,flow,peak_mean_density,mean_density_at_15s,"
    "peak_max_contact_accel,peak_wall_penetration,interrupted";

/// The columns of a replication row that have a mean and a standard deviation, in file order.
inline constexpr std::array<const char*, 7> kReplicationStatColumns = {
    "evacuated", "evacuation_time", "flow", "peak_mean_density", "mean_density_at_15s",
    "peak_max_contact_accel", "peak_wall_penetration"};

/// One run of a set of replications: one row of summary.csv. An empty optional is an empty cell.
struct ReplicationRow {
    std::string run;                         ///< the run's folder name, e.g. "run_003"
    std::uint64_t seed = 0;
    std::size_t evacuated = 0;               ///< agents removed at their goal
    std::optional<double> evacuationTime;    ///< s (runEvacuationTime)
    std::optional<double> flow;              ///< persons/s (runFlow)
    double peakMeanDensity = 0;              ///< 1/m², largest mean_density of metrics.csv
    /// 1/m², mean_density at the first coarse step at or after t = 15 s (the metrics row at
    /// t = 15 s when the metrics interval lands on it); empty if the run ended earlier.
    std::optional<double> meanDensityAt15s;
    double peakMaxContactAccel = 0;          ///< m/s², largest max_contact_accel of metrics.csv
    double peakWallPenetration = 0;          ///< m, largest max_wall_penetration of metrics.csv
    bool interrupted = false;                ///< stopped by SIGINT/SIGTERM before its end

    /// The kReplicationStatColumns values of this row, in that order.
    std::array<std::optional<double>, kReplicationStatColumns.size()> statValues() const;
};

/// Count, mean and sample standard deviation (divisor count − 1) of some values. mean is NaN when
/// count is 0, sd is NaN when count < 2.
struct SampleStats {
    std::size_t count = 0;
    double mean = std::numeric_limits<double>::quiet_NaN();
    double sd = std::numeric_limits<double>::quiet_NaN();
};

/// Statistics of the values that are present and finite (others are ignored), summed in order.
SampleStats sampleStats(const std::vector<std::optional<double>>& values);

/// SampleStats per kReplicationStatColumns column over the rows that were not interrupted (an
/// interrupted run's values cover only part of the run).
std::array<SampleStats, kReplicationStatColumns.size()> replicationStats(const std::vector<ReplicationRow>& rows);

/// summary.csv of a set of replications: kReplicationsHeader, one line per row (in the given
/// order), then the lines `mean`, `sd` and `n` (the number of values each statistic uses) with
/// the seed and interrupted cells empty; a statistic without enough values is an empty cell.
/// Numbers have 10 significant digits; interrupted is `true` or `false`.
std::string replicationsCsv(const std::vector<ReplicationRow>& rows);

}  // namespace ch
