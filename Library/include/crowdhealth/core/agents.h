// CrowdHealth — the active agents as a structure of arrays (hot data in contiguous columns).
#pragma once

#include "crowdhealth/core/big_alloc.h"
#include "crowdhealth/core/types.h"

#include <type_traits>
#include <vector>

namespace ch {

struct AgentSpec;

/// Columns of the agents that are currently in the world. Index i is the same in every column.
/// The order is the order in which agents were activated; removal keeps the order of the rest,
/// so every run with the same input visits agents in the same order.
struct AgentStore {
    // identity and attributes (cold-ish)
    std::vector<AgentId> id;
    std::vector<int> record;              ///< index of the agent's HealthLayer record; -1: added by hand
    std::vector<int> policy;              ///< index into Simulation::policies()
    std::vector<double> radius;           ///< m
    std::vector<double> prefSpeed;        ///< m/s, in effect this step (base, raised by panic, lowered by injury)
    std::vector<double> maxSpeed;         ///< m/s, in effect this step (base, lowered by injury)
    std::vector<double> basePrefSpeed;    ///< m/s, the agent's attribute (file or schedule)
    std::vector<double> baseMaxSpeed;     ///< m/s, the agent's attribute (file or schedule)
    std::vector<double> maxAcceleration;  ///< m/s²
    std::vector<double> mass;             ///< dimensionless mass factor
    std::vector<double> goalRadius;       ///< m
    std::vector<unsigned char> removeAtGoal;
    std::vector<unsigned char> hasGoal;
    std::vector<Vec2> goal;               ///< m

    // state (hot)
    std::vector<Vec2> pos;      ///< m
    std::vector<Vec2> vel;      ///< m/s
    std::vector<Vec2> prefVel;  ///< m/s, towards the goal at preferred speed (0 at the goal)
    std::vector<Vec2> viewDir;  ///< unit vector (UMANS' viewing direction)

    // measurements of the last step (written by the simulation, read by recorders)
    std::vector<double> density;      ///< SPH density with h = 1 m, walls included (1/m² × mass)
    std::vector<Vec2> contactAccel;   ///< sum of contact accelerations of the last step (m/s²)

    // navigation state (crowdhealth/navigation/navigation.h): kept only with navigationColumns
    std::vector<int> journey;         ///< index into VenueSpec::journeys, -1: none
    std::vector<int> stage;           ///< journey stage: waypoint index, = waypoints: leaving
    std::vector<int> target;          ///< Navigation target index, -1: none (straight to `goal`)
    std::vector<double> navDistance;  ///< m, remaining distance to the current target (-1: unknown)
    std::vector<Vec2> navDir;         ///< unit direction of the path to the current target
    std::vector<double> holdUntil;    ///< s, the agent waits until then (premovement, dwell)
    std::vector<unsigned char> navFlags;  ///< Navigation's per-agent flags (admitted, in service …)
    std::vector<double> nextChoice;   ///< s, next re-evaluation of a quickest exit choice

    // social groups (ScenarioSpec::groups)
    std::vector<int> group;           ///< index into ScenarioSpec::groups, -1: walks alone

    /// Whether the navigation columns (journey … nextChoice) are kept. True for a store built by
    /// hand; a Simulation without Navigation (no venue, journey, source or premovement time)
    /// clears it before its first agent, and they then stay empty (53 bytes per agent: 50 MiB for
    /// a million). Readers outside Navigation test it first.
    bool navigationColumns = true;

    std::size_t size() const { return id.size(); }
    bool empty() const { return id.empty(); }

    /// Appends one agent from its spec; `record` is its HealthLayer record (HealthLayer::recordFor).
    /// Returns its index.
    std::size_t add(const AgentSpec& spec, int policyIndex, int record = -1);
    /// Removes every agent i with remove[i] != 0, keeping the order of the others.
    void removeMarked(const std::vector<unsigned char>& remove);
    /// True when agent i is within its goal radius of its goal.
    bool atGoal(std::size_t i) const {
        if (!hasGoal[i]) return true;
        return (goal[i] - pos[i]).squaredNorm() <= goalRadius[i] * goalRadius[i];
    }
    /// Re-orders every column: agent k of the result is agent order[k] of now (a permutation).
    void permute(const std::vector<int>& order);
    /// Room for n agents in every column (one allocation each instead of repeated doubling).
    void reserve(std::size_t n);

    /// Calls f(column) for every column above that is kept (a new column must be added here too).
    template <class F>
    void forEachColumn(F&& f) {
        f(id), f(record), f(policy), f(radius), f(prefSpeed), f(maxSpeed), f(basePrefSpeed), f(baseMaxSpeed);
        f(maxAcceleration), f(mass), f(goalRadius), f(removeAtGoal), f(hasGoal), f(goal);
        f(pos), f(vel), f(prefVel), f(viewDir), f(density), f(contactAccel);
        if (navigationColumns)
            f(journey), f(stage), f(target), f(navDistance), f(navDir), f(holdUntil), f(navFlags), f(nextChoice);
        f(group);
    }
};

namespace detail {

/// The parts of a column's value that remapColumn moves one at a time: x, then y of a Vec2; the
/// value itself otherwise.
template <class V>
inline constexpr int kRemapLanes = std::is_same_v<V, Vec2> ? 2 : 1;
template <class V>
auto& remapLane(V& v, int lane) {
    if constexpr (std::is_same_v<V, Vec2>)
        return lane == 0 ? v.x() : v.y();
    else
        return v;
}

}  // namespace detail

/// Moves a per-agent column along with its agents (AgentStore::permute, Component::remapAgents):
/// entry i becomes the old entry previous[i], or `fresh` where previous[i] is negative or past
/// the old end (an agent new to the world).
///
/// The column keeps its buffer (re-sized in place when it has room) and is written in place, one
/// part of its values at a time (x, then y, of a Vec2), from a copy of that part alone, freed
/// before returning and a mapping of its own when large (bigAllocate). A re-ordering of a million
/// agents then needs 8 MB more at most, not a second column (issue 20: new columns grew the
/// resident memory at each re-ordering, and a whole copy of a 16-byte column was its peak).
///
/// With `keepEmpty`, a column that is still empty stays empty: its owner sizes it when it first
/// uses it, so a component that has not run yet allocates nothing while the crowd is set up.
template <class Column, class T>
void remapColumn(Column& column, const std::vector<int>& previous, const T& fresh, bool keepEmpty = false) {
    using V = typename Column::value_type;
    if (keepEmpty && column.empty()) return;
    const std::size_t n = column.size(), m = previous.size();
    V freshValue(fresh);
    if (m > n) column.resize(m, freshValue);  // the first n entries stay as they were
    for (int lane = 0; lane < detail::kRemapLanes<V>; ++lane) {
        using Lane = std::remove_reference_t<decltype(detail::remapLane(freshValue, lane))>;
        std::vector<Lane, BigAllocator<Lane>> before(n);
        for (std::size_t i = 0; i < n; ++i) before[i] = detail::remapLane(column[i], lane);
        const Lane freshLane = detail::remapLane(freshValue, lane);
        for (std::size_t i = 0; i < m; ++i) {
            const int p = previous[i];
            detail::remapLane(column[i], lane) =
                p >= 0 && static_cast<std::size_t>(p) < n ? before[static_cast<std::size_t>(p)] : freshLane;
        }
    }
    if (m < n) column.resize(m, freshValue);
}

}  // namespace ch
