// crowdhealth — the progress bar on stderr. The wall clock is used here for display only (redraw
// rate, elapsed, ETA); the simulation itself never reads it.
#pragma once

#include <chrono>
#include <cstddef>
#include <iosfwd>
#include <string>

namespace ch { class Simulation; }

namespace chcli {

class ProgressBar {
public:
    /// `enabled` false makes every call a no-op. `endTime` (s) is the time the run stops at
    /// (< 0: unknown, progress is then the share of agents that are gone).
    ProgressBar(std::ostream& out, bool enabled, double endTime);

    /// Redraws if at least 0.1 s of wall time has passed since the last redraw.
    void update(const ch::Simulation& sim);
    /// Draws the final state and ends the line.
    void finish(const ch::Simulation& sim);

    /// True when stderr is a terminal (only then is a bar drawn).
    static bool stderrIsTerminal();

private:
    void draw(const ch::Simulation& sim);

    std::ostream& out_;
    bool enabled_;
    double endTime_;
    std::chrono::steady_clock::time_point start_, lastDraw_;
    bool drawn_ = false;
};

/// The one-line progress of a set of replications on stderr: runs done/total, runs going, the
/// simulated time of the slowest run going, elapsed wall time. The caller decides when to redraw.
class ReplicationProgress {
public:
    /// `enabled` false makes every call a no-op. `endTime` (s) is the time a run stops at at the
    /// latest (< 0: unknown); it is only shown.
    ReplicationProgress(std::ostream& out, bool enabled, std::size_t total, double endTime);

    /// Redraws the line. `slowest` (s) is the smallest simulated time among the runs going
    /// (ignored when `running` is 0; not shown when NaN, i.e. not known).
    void draw(std::size_t done, std::size_t running, double slowest);
    /// Erases the line, so that a message can be printed; the next draw() brings it back.
    void clear();
    /// Ends the line (after a last draw()).
    void finish();

private:
    std::ostream& out_;
    bool enabled_;
    std::size_t total_;
    double endTime_;
    std::chrono::steady_clock::time_point start_;
    bool drawn_ = false;
};

/// "1:05" / "1:02:03" for a number of seconds.
std::string formatDuration(double seconds);

}  // namespace chcli
