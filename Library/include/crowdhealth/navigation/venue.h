// CrowdHealth — the venue part of a ScenarioSpec (DESIGN §8, docs/navigation.md): global
// navigation settings, targets, exits and exit sets, journeys with checkpoints, sources of agents
// over time, and the times exits close and reopen. Plain structs filled by the XML loader (or by
// hand); crowdhealth/navigation/navigation.h runs them.
#pragma once

#include "crowdhealth/core/types.h"
#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/navigation/field.h"

#include <optional>
#include <string>
#include <vector>

namespace ch {

/// <Navigation> in <World>: present = every agent's preferred velocity follows the shortest
/// walkable path to its current target (a geodesic distance field per target).
struct NavigationSpec {
    WalkableGridSettings grid;  ///< cell_size, clearance, min_speed
    double margin = 5.0;        ///< m, Infinite worlds: the grid spans everything plus this margin
    SourceLoc loc;
};

/// <Target> or <Exit> in <World>: a named place. An exit is a target where agents leave the
/// simulation (counted as evacuated).
struct TargetSpec {
    std::string name;
    TargetShape shape;
    bool exit = false;
    /// m, the exit's clear width (quickest rule: its capacity). Absent: the shape's longer side
    /// (a rectangle drawn across a door), 1 m for a point exit.
    double width = 0;
    SourceLoc loc;
};

/// How an agent picks one exit of an exit set (DESIGN §8; docs/navigation.md gives the rules).
enum class ExitChoice { Nearest, Quickest, Fixed, Weighted };

/// <ExitSet> in <World>: the exits an agent may leave by and the rule that chooses among them.
struct ExitSetSpec {
    std::string name;
    std::vector<std::string> exits;  ///< names of <Exit> elements
    std::vector<double> weights;     ///< Weighted: one per exit (relative), else empty
    ExitChoice choice = ExitChoice::Nearest;
    std::string fixed;               ///< Fixed: the exit taken while it is open
    double interval = 2.0;           ///< s, Quickest: time between re-evaluations per agent
    double hysteresis = 0.2;         ///< Quickest: switch only when the new estimate is this fraction shorter
    double flowCapacity = 1.33;      ///< P/(m·s), Quickest: specific flow assumed through an exit
    SourceLoc loc;
};

/// One stage of a journey: walk to a target, optionally wait there (a checkpoint).
struct WaypointSpec {
    std::string target;   ///< a <Target> (or an <Exit> used as a waypoint, left open)
    double dwell = 0;     ///< s spent inside the target before going on
    int capacity = 0;     ///< people inside at once (0 = unlimited); the others wait in front
    SourceLoc loc;
};

/// <Journey> in <World>: waypoints in order, then either leave by an exit (set) or stay at the
/// last waypoint.
struct JourneySpec {
    std::string name;
    std::vector<WaypointSpec> waypoints;
    std::string leaveBy;  ///< an <Exit> or <ExitSet> name; empty = stay at the last waypoint
    SourceLoc loc;
};

/// An attribute of the agents a source creates, drawn per agent from the run's seed.
struct DrawSpec {
    enum class Kind { Constant, Uniform, Normal, Lognormal } kind = Kind::Constant;
    double value = 0;             ///< Constant
    double min = 0, max = 0;      ///< Uniform bounds; Normal and Lognormal: truncation bounds
    double mean = 0, sd = 0;      ///< Normal
    /// Lognormal: the mean and standard deviation of the natural log of the value (the value is
    /// exp(mu + sigma·z), z standard normal: median e^mu, mean e^(mu + sigma²/2)).
    double mu = 0, sigma = 0;
    double draw(class Rng& rng) const;
};

/// <Source> in <Agents>: agents appear in an area at a rate.
struct SourceSpec {
    std::string name;               ///< for messages (default "source N")
    std::vector<Vec2> area;         ///< polygon (a rectangle: four vertices)
    double start = 0;               ///< s, first arrival
    double end = kInf;              ///< s, no arrival after it
    int count = -1;                 ///< agents in all; < 0 = until `end`
    double rate = 1;                ///< persons/s when `table` is empty
    /// Piecewise-constant rate: (time s, persons/s) sorted by time; the rate of an entry holds
    /// until the next one.
    std::vector<std::pair<double, double>> table;
    std::string journey;            ///< journey name; empty: `goal` or stand still
    std::optional<Vec2> goal;       ///< a plain goal point (as <Agent><goal>)
    int policyId = 0;
    DrawSpec radius, prefSpeed, maxSpeed, premovement;
    double maxAcceleration = 5.0;
    bool removeAtGoal = true;
    /// Social groups (docs/navigation.md, "Sources"): 0 = everyone arrives alone; otherwise
    /// arrivals come in groups whose size is drawn uniformly in [groupSizeMin, groupSizeMax]
    /// (2..20). A group is consecutive arrivals, all arriving at the first one's time, named
    /// "<name>/g<k>" (AgentSpec::group); `count` and `end` cut the last group short.
    int groupSizeMin = 0, groupSizeMax = 0;
    /// Fraction of the arrivals (people, in expectation) that come in groups (0..1); the rest
    /// arrive alone. Used only with group sizes.
    double groupShare = 1;
    SourceLoc loc;
};

/// <CloseExit>/<OpenExit> in <Schedule>.
struct ExitEventSpec {
    std::string exit;
    double time = 0;
    bool open = false;
    SourceLoc loc;
};

/// Everything of a venue in one place (ScenarioSpec::venue).
struct VenueSpec {
    std::optional<NavigationSpec> navigation;
    std::vector<TargetSpec> targets;    ///< targets and exits, in file order
    std::vector<ExitSetSpec> exitSets;
    std::vector<JourneySpec> journeys;
    std::vector<SourceSpec> sources;
    std::vector<ExitEventSpec> exitEvents;
    /// Index of the target/exit named `name`, -1 if none.
    int targetIndex(const std::string& name) const;
    int exitSetIndex(const std::string& name) const;
    int journeyIndex(const std::string& name) const;
    /// True when nothing of a venue is written (the scenario runs exactly as UMANS').
    bool empty() const {
        return !navigation && targets.empty() && exitSets.empty() && journeys.empty() && sources.empty() &&
               exitEvents.empty();
    }
};

struct ScenarioSpec;
/// Arrival times of source `s`'s agents (s), in order: the k-th arrival (k = 0, 1, …) comes when
/// the integral of the rate from `start` reaches k (a constant rate r: start + k/r), up to `count`
/// agents or until `end`. Capped at `limit` arrivals.
std::vector<double> sourceArrivals(const SourceSpec& s, std::size_t limit);
/// Appends one AgentSpec per arrival of every source to spec.agents (start_time = arrival, the
/// drawn attributes, `source` set; the position is chosen when the agent arrives). Attributes are
/// drawn from streams keyed by (seed, source, arrival), so they depend only on the file and seed.
/// A source with group sizes partitions its arrivals into groups (sizes from streams keyed by
/// (seed, source, first arrival of the group)): the members get the group's name in
/// AgentSpec::group and the first member's start_time. Groups of one are not named (the agent
/// walks alone). AgentSpec::groupIndex and ScenarioSpec::groups are left to the loader (it indexes
/// every group of the file, these included).
void expandSources(ScenarioSpec& spec);
/// Probability that a unit of arrivals (a group or one person) of `s` is a group, so that the
/// expected share of people arriving in groups is s.groupShare: q = share / (share + (1 − share)·E),
/// E = (min + max)/2 the mean group size. 0 without group sizes.
double sourceGroupProbability(const SourceSpec& s);

}  // namespace ch
