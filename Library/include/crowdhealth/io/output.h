// CrowdHealth — recorders and writers for a run's outputs (DESIGN §6): metrics.csv,
// evacuations.csv, summary.json and trajectories (UMANS per-agent CSV, PedPy text, compact binary).
//
// Reusable by any program that embeds a Simulation:
//
//     ch::MetricsRecorder metrics(spec.output.metricsInterval);
//     ch::TrajectoryOutput traj(dir, formats, spec.output.trajectoryInterval, sim.deltaTime());
//     metrics.sample(sim); traj.record(sim);            // t = 0
//     while (!sim.finished()) { sim.stepCoarse(); metrics.maybeSample(sim); traj.maybeRecord(sim); }
//     metrics.finish(sim); traj.finish(sim);
//     metrics.write(dir / "metrics.csv"); traj.commit(); ...
//
// Every file is written whole or not at all: the text goes to `<name>.tmp` in the same folder,
// which is renamed over `<name>` only once it is complete and flushed (rename is atomic within a
// file system), so a crash or Ctrl-C never leaves a half-written file under the final name. The
// streamed trajectory files grow in their `.tmp` during the run and are renamed at its end.
//
// Numbers are written with std::to_chars (locale-independent, general format, a fixed number of
// significant digits) and every sum runs in agent order, so the files are byte-identical for the
// same seed whatever the thread count.
#pragma once

#include "crowdhealth/core/simulation.h"

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

struct Verdict;  // crowdhealth/health/safety.h
class SafetyRecorder;  // crowdhealth/health/safety.h

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
// JSON: crowdhealth/io/json.h (every JSON file goes through nlohmann/json).

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

// ---- sampling times ------------------------------------------------------------------------

/// When an output taken every `interval` seconds of simulated time is due: at the first coarse
/// step at or after each multiple of the interval (times are compared with a relative tolerance
/// of 1e-9, since 3·0.1 is 0.30000000000000004). Shared by metrics.csv and the trajectories.
class SampleClock {
public:
    /// `interval` in s; ≤ 0 or NaN: every time is due.
    explicit SampleClock(double interval) : interval_(interval) {}
    /// True when a sample is due at simulated time t (s).
    bool due(double t) const;
    /// Notes a sample taken at t: the next is due at the first multiple of the interval after t.
    void taken(double t);
    double interval() const { return interval_; }

private:
    double interval_;
    std::uint64_t nextIndex_ = 0;  ///< the next sample is due at nextIndex_·interval_
};

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
    /// Helbing, Johansson & Al-Abideen 2007 "crowd pressure" ρ·Var_t(V) (1/s²): the largest value
    /// over the cells of the SafetyRecorder given to MetricsRecorder::setCrowdPressure
    /// (crowdhealth/health/safety.h); NaN (an empty cell) without one, since it is a time average.
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
    /// Takes the crowd_pressure column from `recorder` (its value at its last record(), so record
    /// there before sampling here). Without one the column is empty.
    void setCrowdPressure(const SafetyRecorder* recorder) { pressure_ = recorder; }

    const std::vector<MetricsRow>& rows() const { return rows_; }
    MetricsPeaks peaks() const;
    /// The whole file: header + one line per row.
    std::string csv() const;
    /// Writes csv() atomically.
    void write(const std::filesystem::path& file) const { writeFileAtomic(file, csv()); }

private:
    SampleClock clock_;
    double h_;
    const SafetyRecorder* pressure_ = nullptr;
    MetricsRow measure(Simulation& sim) const;
    std::vector<std::string> scheduleColumns_;  ///< taken from the simulation at the first sample
    std::vector<MetricsRow> rows_;
};

// ---- evacuations ---------------------------------------------------------------------------

/// evacuations.csv: header `id,time`, one row per sim.evacuations() entry (already in time order).
std::string evacuationsCsv(const Simulation& sim);

// ---- trajectories --------------------------------------------------------------------------

/// The file layout of trajectories.bin (all numbers little-endian, no padding):
///
///     header, 32 bytes:
///       0  char[6]  magic "CHTRJ1"
///       6  uint16   version (1)
///       8  uint32   flags: bit 0 = the records carry vx, vy
///      12  uint32   record size in bytes: 12, or 20 with velocities
///      16  float64  delta_time (s): the coarse step; time = step · delta_time
///      24  float64  nominal time between frames (s): the trajectory interval, at least delta_time
///     then frames until the end of the file, each:
///       float64  time (s)
///       uint32   step: coarse steps since t = 0 (the PedPy frame number)
///       uint32   n: agents in the world
///       n records, by increasing id: uint32 id, float32 x, float32 y (m) [, float32 vx, vy (m/s)]
///
/// The frame count is not stored (frames are written while the run goes on): read frames until
/// the end of the file. The file is complete when it has its final name (AtomicFile).
namespace trajbin {
inline constexpr char kMagic[6] = {'C', 'H', 'T', 'R', 'J', '1'};
inline constexpr std::uint16_t kVersion = 1;
inline constexpr std::uint32_t kFlagVelocities = 1;
inline constexpr std::size_t kHeaderBytes = 32;
inline constexpr std::size_t kFrameHeaderBytes = 16;
/// The largest agent id (and coarse step) the file can hold.
inline constexpr std::uint64_t kMaxId = 0xffffffffu;
/// Bytes of one record with or without velocities.
inline constexpr std::size_t recordBytes(bool velocities) { return velocities ? 20 : 12; }
}  // namespace trajbin

/// One frame of a trajectory file read back (readBinaryTrajectories).
struct TrajectoryFrame {
    double time = 0;          ///< s
    std::uint64_t step = 0;   ///< coarse steps since t = 0
    std::vector<std::uint32_t> id;
    std::vector<float> x, y;  ///< m
    std::vector<float> vx, vy;  ///< m/s; empty unless the file carries velocities
};

/// The content of a trajectories.bin.
struct BinaryTrajectories {
    std::uint32_t flags = 0;
    double deltaTime = 0, interval = 0;  ///< s
    std::vector<TrajectoryFrame> frames;
};

/// Reads a whole trajectories.bin. Throws OutputError (naming the file and the byte offset) when
/// it cannot be read, is not such a file, or ends inside a frame.
BinaryTrajectories readBinaryTrajectories(const std::filesystem::path& file);

/// Streams trajectories.bin frame by frame while the run goes on (memory: one frame), into
/// `<file>.tmp`, renamed by commit(); see trajbin for the layout.
class BinaryTrajectoryWriter {
public:
    /// Opens the temporary file and writes the header. Throws OutputError.
    BinaryTrajectoryWriter(std::filesystem::path file, double deltaTime, double interval, bool velocities);
    /// Appends the current state as one frame (every agent in the world, by increasing id).
    /// Throws OutputError when an id or the step does not fit in a uint32 (kMaxId).
    void writeFrame(const Simulation& sim);
    void commit() { file_.commit(); }

private:
    AtomicFile file_;
    bool velocities_;
    std::string buffer_;  ///< one frame, reused
    std::vector<std::size_t> order_;  ///< agent indices by id, reused
};

/// Streams a PedPy-readable trajectories.txt frame by frame (`# framerate: <1/delta_time>`,
/// `# x/m`, `# y/m`, `# z/m`, then rows `id frame x y z` with z = 0 and frame = coarse step
/// index, frame 0 = t = 0, in frame order then id order, positions with 4 decimals) into
/// `<file>.tmp`, renamed by commit().
class PedPyTrajectoryWriter {
public:
    /// Opens the temporary file and writes the comment lines. Throws OutputError.
    PedPyTrajectoryWriter(std::filesystem::path file, double deltaTime);
    /// Appends the rows of the current coarse step.
    void writeFrame(const Simulation& sim);
    void commit() { file_.commit(); }

private:
    AtomicFile file_;
    std::string buffer_;
    std::vector<std::size_t> order_;
};

/// Buffers every agent's state at each recorded frame for UMANS' per-agent files, written at the
/// end (one file per agent must not mean one open file per agent). Meant for small runs.
///
/// Memory: 32 bytes per agent per recorded frame (x, y, dir_x, dir_y as doubles; time is shared
/// per frame), e.g. 400 agents × 1200 frames ≈ 15 MB.
class TrajectoryRecorder {
public:
    /// Records every active agent at the current coarse step (sim.coarseSteps()). Calling it twice
    /// at the same step records nothing new.
    void record(const Simulation& sim);

    /// Agents seen so far.
    std::size_t agentCount() const { return tracks_.size(); }
    /// Frames recorded so far (including step 0 if recorded).
    std::size_t frameCount() const { return frameTime_.size(); }

    /// UMANS' format: one `output_<id>.csv` per agent in `dir`, rows `time,x,y,dir_x,dir_y`, no
    /// header, one row per recorded frame while the agent is in the world, without the t = 0 row
    /// (UMANS records after each step). Each file is written atomically.
    void writeUmans(const std::filesystem::path& dir) const;
    /// The names writeUmans writes: output_<id>.csv of every agent recorded, by id.
    std::vector<std::string> umansFileNames() const;

private:
    struct Run {
        std::size_t firstFrame;  ///< index into frameTime_ of the run's first row
        std::size_t firstRow;    ///< index into rows
        std::size_t count;
    };
    struct Track {
        AgentId id;
        std::vector<Run> runs;  ///< usually one: agents are in the world for one contiguous span
        std::vector<double> rows;  ///< x, y, dir_x, dir_y per recorded frame
    };
    std::vector<Track> tracks_;
    std::unordered_map<AgentId, std::size_t> trackOf_;
    std::vector<double> frameTime_;   ///< simulated time (s) of each recorded frame
    std::vector<std::uint64_t> frameStep_;  ///< coarse step of each recorded frame
};

/// The trajectory files of a run: a frame at t = 0 (record()), one at the first coarse step at or
/// after each multiple of the interval (maybeRecord()), and the final state (finish()). The text
/// and binary files are streamed to their temporary files as frames come; the UMANS files are
/// buffered (TrajectoryRecorder). commit() completes them all; destroying it before leaves no
/// file behind (only a previous run's files, untouched).
///
///     ch::TrajectoryOutput traj(dir, *ch::parseTrajectoryFormats("txt,bin"), interval, sim.deltaTime());
///     traj.record(sim);
///     while (!sim.finished()) { sim.stepCoarse(); traj.maybeRecord(sim); }
///     traj.finish(sim);
///     traj.commit();
class TrajectoryOutput {
public:
    /// Opens the files of `formats` in `dir` (output_<id>.csv, trajectories.txt, trajectories.bin).
    /// `interval` in s (≤ 0: every coarse step); `velocities`: trajectories.bin carries vx, vy.
    /// Throws OutputError when a file cannot be created.
    TrajectoryOutput(const std::filesystem::path& dir, const TrajectoryFormats& formats, double interval,
                     double deltaTime, bool velocities = false);
    TrajectoryOutput(const TrajectoryOutput&) = delete;
    TrajectoryOutput& operator=(const TrajectoryOutput&) = delete;

    /// Records a frame now (unless this coarse step already has one).
    void record(const Simulation& sim);
    /// Records a frame when one is due. Returns true if it did.
    bool maybeRecord(const Simulation& sim);
    /// Records the final state if it is not already a frame.
    void finish(const Simulation& sim) { record(sim); }
    /// Writes the UMANS files and renames the streamed files to their final names.
    void commit();
    /// The names of the files commit() writes into the folder (trajectories.txt, …).
    std::vector<std::string> fileNames() const;

    /// Frames recorded so far.
    std::size_t frameCount() const { return frames_; }

private:
    std::filesystem::path dir_;
    SampleClock clock_;
    std::optional<TrajectoryRecorder> umans_;
    std::optional<PedPyTrajectoryWriter> txt_;
    std::optional<BinaryTrajectoryWriter> bin_;
    std::uint64_t lastStep_ = 0;  ///< coarse step of the last frame
    std::size_t frames_ = 0;
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
    /// Of wallTimeSeconds: inside Simulation::stepCoarse, and in the recorders of the run (metrics,
    /// safety, measurement, trajectories). Display only, not in summary.json.
    double stepSeconds = 0, recordSeconds = 0;
    /// Of recordSeconds: each recorder's share (display only). Safety: the crowd field, the
    /// safety grid's cells and the verdict's timelines; metrics: its rows; measurement: lines,
    /// areas and exits; trajectories: the frames written.
    double safetySeconds = 0, metricsSeconds = 0, measurementSeconds = 0, trajectorySeconds = 0;
    int threads = 0;
};

/// Flow between the `first`-th and `last`-th evacuee (1-based): (last − first)/(t_last − t_first)
/// persons per second, nullopt when there are fewer than `last` evacuees or no time elapsed.
std::optional<double> evacuationFlow(const std::vector<Evacuation>& evacuations, int first, int last);

/// summary.json: scenario, seed, time steps, end/simulated time, interrupted, agent counts,
/// evacuation time, flow {first, last, persons_per_second}, peaks, wall time.
/// With `verdict`, a "verdict" member {"level", "reasons": [...]} is added (crowdhealth/health/safety.h).
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
