// CrowdHealth — global navigation beneath every policy (DESIGN §8, docs/navigation.md).
//
// A scenario with a venue (crowdhealth/navigation/venue.h: <Navigation>, targets, exits, journeys
// or sources) gets a Navigation. Per fine step, before preferred velocities are set:
//   1. exits open and close at their scheduled times; agents heading to a closed exit re-route;
//   2. (parallel, each agent its own slot) the direction and remaining distance of every agent to
//      its current target: along −∇T of the target's geodesic distance field with <Navigation>,
//      straight at the target's nearest point without it;
//   3. (serial, in agent order, on the state of 2) arrivals: an agent inside its waypoint starts
//      its dwell (admitted first at a checkpoint with a capacity), then goes on to the next stage;
//      a checkpoint admits its free places to the nearest waiting agents (ties by id); agents at
//      the exit stage choose an exit by their set's rule (quickest: re-evaluated every interval;
//      a social group's members take the exit its first member to choose picked, while it is open);
//   4. the preferred velocity: direction × preferred speed, zero while the agent waits (its
//      premovement time, a dwell, or a queue in front of a full checkpoint) or stands at its last
//      waypoint.
// Agents with a plain goal and no journey keep UMANS' semantics (goal radius, remove_at_goal); with
// <Navigation> only their direction follows the path. Without a venue the simulation has no
// Navigation and behaves exactly as before.
#pragma once

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/rank_index.h"
#include "crowdhealth/core/scenario.h"
#include "crowdhealth/core/world.h"
#include "crowdhealth/navigation/field.h"

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace ch {

/// The rectangle (lo, hi) the navigation grid covers: a planar world's bounds; otherwise every
/// obstacle, target, agent start, plain goal and source area, with <Navigation margin>. The loader
/// checks reachability on the same grid the simulation builds.
std::pair<Vec2, Vec2> navigationBounds(const ScenarioSpec& spec);

class Navigation {
public:
    /// Builds the walkable grid and one distance field per target (and per distinct agent goal)
    /// when the venue has <Navigation>. Throws std::runtime_error naming the target when a target
    /// touches no walkable floor.
    Navigation(const ScenarioSpec& spec, const World& world);
    ~Navigation();

    /// True when the scenario needs a Navigation (a <Navigation>, or any target, journey or source).
    static bool needed(const ScenarioSpec& spec);

    /// Sets up agent i (just added from `s`): journey, first target, premovement.
    void activated(AgentStore& agents, std::size_t i, const AgentSpec& s, double time);
    /// A free place for an agent of source `source` (its radius in `s`): a point inside the
    /// source's area clear of walls and of every agent in `agents` and `placed`; false when none
    /// was found in this step's attempts (the arrival waits for the next step).
    bool place(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed, AgentSpec& s,
               std::uint64_t seed, std::uint64_t step) const;
    /// The place of a source's arrival at fine step `step`, groups included (what the simulation
    /// calls, arrivals in order; a group's members come one after the other). An agent alone:
    /// place(). A group's first member: place(), then a place for every other member — a free
    /// point within kGroupPlacementRadius of the first member, in sight of it (placeNear), else
    /// place() — all or none: when one finds no room the first member waits too (false), and
    /// the group tries again next step. The other members then take the places kept for them
    /// (and wait, false, while the first member waits), so a group arrives in one step. A group
    /// that has waited more than kGroupPatience arrives as it fits: its first member alone, each
    /// other member beside it or anywhere in the area, else in a later step beside a member
    /// already walking.
    bool placeArrival(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed, AgentSpec& s,
                      std::uint64_t seed, std::uint64_t step);
    /// m: a group member is placed within this distance of its first member (centre to centre).
    static constexpr double kGroupPlacementRadius = 1.5;
    /// s a group waits for room for all its members before arriving as it fits.
    static constexpr double kGroupPatience = 10.0;

    /// Steps 1–3 above at time t (s).
    void update(AgentStore& agents, double t, std::uint64_t seed);
    /// Step 4: agent i's preferred velocity (m/s).
    Vec2 preferred(const AgentStore& agents, std::size_t i, double t) const;
    /// The exit agent i leaves by now (index into VenueSpec::targets: an open exit it may leave
    /// by and stands inside), -1 when it does not leave.
    int leaves(const AgentStore& agents, std::size_t i) const;

    /// The geodesic grid (nullptr without <Navigation>).
    const WalkableGrid* grid() const { return grid_.get(); }
    /// Number of targets with a field (venue targets and distinct agent goals).
    std::size_t fieldCount() const { return fields_.size(); }
    /// Remaining path length (m) from p to venue target `target` (index into VenueSpec::targets):
    /// geodesic with <Navigation>, straight otherwise.
    double distanceTo(int target, const Vec2& p) const;
    /// Clear width (m) of venue target `target` (an exit's `width`, else its longer side, 1 m for a point).
    double width(int target) const;
    /// Current state of exit `target` (true = open).
    bool open(int target) const { return open_[static_cast<std::size_t>(target)] != 0; }

    /// Wall-clock seconds spent preparing (grid and fields), for summaries and benchmarks.
    double preparationSeconds() const { return prepSeconds_; }

    /// Per-checkpoint log for tests and outputs: (agent id, waypoint, service start, service end).
    struct Service {
        AgentId id;
        int journey, waypoint;
        double start, end;
    };
    const std::vector<Service>& services() const { return services_; }

private:
    struct Target;  // a shape with its field
    const ScenarioSpec& spec_;
    const World& world_;
    std::unique_ptr<WalkableGrid> grid_;
    std::vector<Target> targets_;        ///< venue targets, then one point per distinct agent goal
    std::vector<DistanceField> fields_;  ///< per target (empty without <Navigation>)
    std::map<std::pair<double, double>, int> goalIndex_;  ///< distinct plain goal → its target
    std::vector<unsigned char> open_;    ///< per venue target: exits open/closed
    std::size_t nextEvent_ = 0;
    std::vector<int> eventOrder_;        ///< exit events by time (stable)
    std::vector<int> exitSetOf_;         ///< per journey: its exit set (-1 none)
    std::vector<int> leaveExitOf_;       ///< per journey: its single exit (-1 none)
    // The venue's names resolved once to target indices (the per-step code never looks a name up).
    std::vector<std::vector<int>> setExits_;     ///< per exit set: its exits' targets, in its order
    std::vector<std::vector<double>> setWeights_;  ///< per exit set: its exits' weights (default 1)
    std::vector<int> setFixed_;                  ///< per exit set: the target of its fixed exit (-1 none)
    std::vector<std::vector<int>> stageTarget_;  ///< per journey: each waypoint's target
    std::vector<int> eventTarget_;               ///< per exit event: the exit's target
    /// chooseExit's scratch: the open candidates and their weights (one per thread that chooses).
    struct ChoiceScratch {
        std::vector<int> openOnes;
        std::vector<double> openWeights;
    };
    ChoiceScratch scratch_;  ///< for the choices made on one thread (activation, advance, step 3's serial part)
    /// Per target: the remaining distances of those heading there. A cache line of its own, as
    /// each ThreadLists is: the threads append to their lists at once (a shared line would bounce).
    struct alignas(64) Queue {
        std::vector<double> values;
    };
    /// One thread's share of update()'s lists, from the runs of agents it sampled (in agent order).
    struct alignas(64) ThreadLists {
        std::vector<std::size_t> serial;    ///< agents before their last waypoint, and choosers in a social group
        std::vector<std::size_t> choosers;  ///< every agent choosing an exit in this update
        std::vector<Queue> queues;          ///< per target
        ChoiceScratch scratch;
    };
    std::vector<ThreadLists> lists_;
    std::vector<Service> services_;
    std::vector<RankIndex> ranks_;  ///< per target: the distances of the people heading there (who is nearer)
    std::vector<std::vector<std::span<const double>>> rankParts_;  ///< per target: its queues, thread by thread
    bool quickest_ = false;         ///< some exit set chooses by the quickest rule
    /// Step 3's serial part in agent order: agents before their last waypoint (their services
    /// are recorded in order) and choosers in a social group (the group's first choice binds the
    /// others). Choosers outside groups choose independently, on the team.
    std::vector<std::size_t> serial_;
    /// The agents who choose an exit in this update's step 3, in agent order, and the path lengths
    /// to their sets' exits, sampled before step 3: chooser m's row of choiceSlots_ holds the path
    /// to its set's k-th exit (NaN where not sampled: closed, no set, or its current target).
    std::vector<std::size_t> choosers_;
    std::vector<double> choicePaths_;
    std::size_t choiceSlots_ = 0;  ///< the most exits of one exit set
    std::vector<unsigned char> quickestJourney_;  ///< per journey: leaves by a quickest exit set
    /// Per social group (ScenarioSpec::groups), for groups drawn by sources: the id of its first
    /// member (-1: not a source's group), whether that member has been placed, where, and in which step.
    std::vector<AgentId> groupFirst_;
    std::vector<std::vector<std::size_t>> groupMembers_;  ///< per group: its members (indices into spec agents)
    std::vector<std::pair<AgentId, Vec2>> reserved_;      ///< places kept for the group placed last
    /// Per social group (every group, declared or drawn): the exit its first member to choose
    /// picked; the others take it while it is open (-1: none yet).
    std::vector<int> groupExit_;
    std::vector<unsigned char> groupPlaced_;
    std::vector<Vec2> groupAnchor_;
    std::vector<std::uint64_t> groupAnchorStep_;
    double prepSeconds_ = 0;

    int goalTarget(const Vec2& goal) const;
    /// True when a body of `radius` at p is inside the world, outside obstacles, on walkable floor,
    /// at least `radius` from every wall, and overlaps none of `near` (centre, radius).
    bool freeAt(const Vec2& p, double radius, const std::vector<std::pair<Vec2, double>>& near) const;
    /// A free point for `s` within kGroupPlacementRadius of `anchor` with no wall between them
    /// (the first half of the attempts also inside the source's area); false when none was found.
    bool placeNear(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed, AgentSpec& s,
                   const Vec2& anchor, std::uint64_t seed, std::uint64_t step) const;
    /// True when agent i has passed every waypoint of its journey (heading for an exit or done).
    bool leaving(const AgentStore& a, std::size_t i) const {
        const int j = a.journey[i];
        return j >= 0 && static_cast<std::size_t>(a.stage[i]) >= stageTarget_[static_cast<std::size_t>(j)].size();
    }
    /// Agent i goes on from its current waypoint to the next stage.
    void advance(AgentStore& a, std::size_t i, double t, std::uint64_t seed);
    /// Chooses agent i's exit by its journey's rule (a weighted choice stands while its exit is open).
    /// `sampled`: a.navDir[i] and a.navDistance[i] already hold directionTo(a.target[i], a.pos[i])
    /// (update's step 2), which the choice then reads instead of sampling the field again; `paths`:
    /// i's row of choicePaths_ (null: none), read the same way.
    /// `scratch`: the calling thread's own. Without a social group (sharesGroupExit false), a
    /// choice reads and writes agent i's slots only, so choices of different agents may run at once.
    void chooseExit(AgentStore& a, std::size_t i, double t, std::uint64_t seed, ChoiceScratch& scratch,
                    bool sampled = false, const double* paths = nullptr);
    /// True when agent i's exit choice follows, or sets, its social group's shared exit.
    bool sharesGroupExit(const AgentStore& a, std::size_t i) const {
        return a.group[i] >= 0 && static_cast<std::size_t>(a.group[i]) < groupExit_.size();
    }
    /// Step 3 for an agent before its last waypoint: dwell ends, arrival, admission to service.
    void serveWaypoint(AgentStore& a, std::size_t i, double t, std::uint64_t seed);
    /// True when update's step 3 has agent i choose its exit: i is leaving by an exit or an exit
    /// set, and an exit opened or closed in this update (`changed`) or its quickest choice is due.
    bool choosesNow(const AgentStore& a, std::size_t i, double t, bool changed) const;
    /// Direction of the path from p to `target` and its remaining length in `distance`: along
    /// the target's field, or straight at the target without one (or off the grid).
    Vec2 directionTo(int target, const Vec2& p, double& distance) const;
    /// The same with p already probed on the grid (q = grid_->probe(p)); only with fields.
    Vec2 directionTo(int target, const Vec2& p, const WalkableGrid::Probe& q, double& distance) const;
    /// Straight at the nearest point of the target (no field, or p off the grid).
    Vec2 straightTo(int target, const Vec2& p, double& distance) const;
    /// Asks for the field cells that directionsTo will read: lane l of q (positions probed with
    /// probe8) on target[l]'s field, for the lanes in `lanes`.
    void prefetchLanes(const WalkableGrid::Probe8& q, const int* target, unsigned lanes) const;
    /// directionTo(target[l], pos[l], …) into dir[l] and dist[l] for the lanes in `lanes` (q =
    /// grid_->probe8(pos)): eight at a time by DistanceField::sample8, the lanes it leaves one by
    /// one; the same results. Only with fields.
    void directionsTo(const WalkableGrid::Probe8& q, const Vec2* pos, const int* target, unsigned lanes, Vec2* dir,
                      double* dist) const;
};

}  // namespace ch
