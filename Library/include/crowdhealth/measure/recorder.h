// CrowdHealth — measurement recorders (docs/measurement.md): crossings of measurement lines and
// of exits, and the density, speed, specific flow and level of service of measurement areas, over
// time, into flows.csv and areas.csv; and the verdict reasons they give (an exit or line above its
// capacity, an area at level of service F).
//
// Call record() at t = 0 and after every coarse step, as the SafetyRecorder. Crossings are found
// on each agent's straight move between two records (its last position, for an agent removed
// between them, is Simulation::removed()'s): exactly the crossings of the trajectories written at
// every coarse step.
#pragma once

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/scenario.h"
#include "crowdhealth/health/safety.h"
#include "crowdhealth/measure/measurement.h"

#include <deque>
#include <string>
#include <unordered_map>
#include <vector>

namespace ch {

class Simulation;
struct AgentStore;

/// Which side of the line a → b the point p lies on: +1 left (cross product > 0), −1 right or on it.
int lineSide(const Vec2& a, const Vec2& b, const Vec2& p);
/// +1 when the move p → q crosses the segment a → b forwards (left to right, towards the normal
/// (b − a) rotated by −90°), −1 backwards, 0 when it does not cross. A point exactly on the line
/// counts as on its right side, so a stop on the line counts once: forwards, the move onto it
/// crosses and the move on to the right does not; backwards, the move onto it does not cross and
/// the move on to the left does.
int crossing(const Vec2& a, const Vec2& b, const Vec2& p, const Vec2& q);

class MeasurementRecorder {
public:
    /// From the scenario's measurement lines and areas, its exits (with `exitWidths`, m, one per
    /// VenueSpec::targets entry; ignored for targets that are not exits) and its <Safety>.
    MeasurementRecorder(const ScenarioSpec& spec, std::vector<double> exitWidths = {});

    /// Nothing to measure (no line, no area, no exit): record() returns at once and no file is due.
    bool empty() const { return lines_.empty() && areas_.empty() && exits_.empty(); }
    bool hasAreas() const { return !areas_.empty(); }
    bool hasFlows() const { return !lines_.empty() || !exits_.empty(); }

    void record(const Simulation& sim);
    /// The same from explicit states (tests, replayed trajectories): agents at time t, and those
    /// removed since the last call with their last positions.
    void record(const AgentStore& agents, double t, const std::vector<std::pair<AgentId, Vec2>>& removed,
                const std::vector<std::pair<int, double>>& exitLeaves = {});
    /// Closes the interval in progress (the last rows end at the final time).
    void finish();

    /// flows.csv: `time,line,kind,forward,backward,flow,specific_flow` — one row per line and exit
    /// per interval; time = the interval's end (s); kind line or exit; forward/backward = crossings
    /// (an exit: people who left by it, forward); flow = (forward + backward)/interval (P/s);
    /// specific_flow = flow / length or exit width (P/(m·s)).
    std::string flowsCsv() const;
    /// areas.csv: `time,area,density,speed,specific_flow,los,people` — one row per area per
    /// interval, averages over the records (coarse steps) in the interval: density = people inside
    /// / area (PedPy's classic method, persons/m²), speed = mean speed of those inside over the
    /// records with someone inside (m/s; 0 when empty throughout), specific_flow = mean of
    /// density × speed (P/(m·s)), los = Fruin's level of the mean density, people = mean count.
    std::string areasCsv() const;

    /// The verdict reasons: an exit or line whose specific flow over the last flow_window seconds
    /// stayed above flow_capacity for min_duration; an area at level of service F for min_duration.
    std::vector<VerdictReason> reasons() const;

    struct FlowRow {
        double start, time;  ///< s, the interval [start, time]
        int forward, backward;
    };
    struct AreaRow {
        double time, density, speed, specificFlow, people;
        char los;
    };
    /// Per line, then per exit (in venue order), their rows.
    const std::vector<std::vector<FlowRow>>& flowRows() const { return flowRows_; }
    /// Per area, its rows.
    const std::vector<std::vector<AreaRow>>& areaRows() const { return areaRows_; }
    /// Crossings of line k so far: forward, backward.
    std::pair<int, int> lineTotals(std::size_t k) const;

private:
    struct Line {
        std::string name;
        Vec2 a, b;
        double length;
        bool exit = false;
        int target = -1;  ///< exits: index into VenueSpec::targets
        int forward = 0, backward = 0;  ///< in the interval in progress
        int totalForward = 0, totalBackward = 0;
        std::deque<double> recent;  ///< crossing times within the flow window
        std::size_t peakCount = 0;  ///< most crossings within one window
        double heldSince = -1, longest = 0, first = -1;  ///< above capacity
        double peak = 0;            ///< highest windowed specific flow (P/(m·s))
        Box bounds;                 ///< of a → b, widened by kCrossingMargin
    };
    struct Area {
        std::string name;
        std::vector<Vec2> polygon;
        double area;
        Box bounds;
        double sumDensity = 0, sumSpeed = 0, sumFlow = 0, sumPeople = 0;
        int samples = 0, occupied = 0;  ///< records in the interval; those with someone inside
        double heldSince = -1, longest = 0, first = -1, peak = 0;
        double peakPeople = 0;
    };
    std::vector<Line> lines_;   ///< measurement lines, then exits
    std::vector<Line> exits_;   ///< exits (crossings = people leaving by them)
    std::vector<Area> areas_;
    double interval_;
    SafetyThresholds t_;
    double intervalStart_ = 0, lastTime_ = -1;
    bool started_ = false;
    /// Each agent's position at the last record: by id in a flat array for the ids of the
    /// scenario's agents when they are dense enough (the usual case: ids 0 … N − 1), else (and for
    /// agents added by hand with other ids) in the map.
    std::vector<Vec2> lastById_;
    std::vector<unsigned char> hasLastById_;
    std::unordered_map<AgentId, Vec2> last_;
    std::size_t removedSeen_ = 0, evacuationsSeen_ = 0;
    std::vector<std::vector<FlowRow>> flowRows_;
    std::vector<std::vector<AreaRow>> areaRows_;

    void closeInterval(double t);
    void countCrossing(Line& l, int direction, double t);
    void updateCapacity(Line& l, double t);
};

}  // namespace ch
