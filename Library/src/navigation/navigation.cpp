// CrowdHealth — global navigation: targets, exits, journeys, checkpoints (navigation.h).
#include "crowdhealth/navigation/navigation.h"

#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/rng.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <tuple>

namespace ch {

namespace {
// AgentStore::navFlags bits.
constexpr unsigned char kAdmitted = 1;   ///< may walk into its checkpoint (a place is kept for it)
constexpr unsigned char kInService = 2;  ///< dwelling inside its waypoint
constexpr unsigned char kDone = 4;       ///< reached the last waypoint of a journey without an exit
/// m: an agent not yet admitted to a full checkpoint stops this far (path length) from it.
constexpr double kQueueDistance = 1.0;
/// Slowest speed (m/s) used to turn a path length into a walking time (quickest rule).
constexpr double kMinChoiceSpeed = 0.1;
}  // namespace

struct Navigation::Target {
    TargetShape shape;
    bool exit = false;
    double width = 1.0;
    int capacity = 0;  ///< checkpoint places (0 = unlimited), from the journeys' waypoints
    Box box;  ///< a polygon's bounds (shape.bounds())

    /// shape.contains(p), with the polygon test skipped for a point outside the polygon's bounds
    /// (the even-odd test gives false there too: no edge crosses its row to the point's left an
    /// odd number of times). Per agent and step, for every exit of its set (Navigation::leaves).
    bool contains(const Vec2& p) const {
        if (shape.kind == TargetShape::Kind::Polygon && !box.contains(p)) return false;
        return shape.contains(p);
    }
};

bool Navigation::needed(const ScenarioSpec& spec) {
    if (!spec.venue.empty()) return true;
    for (const AgentSpec& a : spec.agents)
        if (a.premovement > 0 || !a.journey.empty() || a.source >= 0) return true;
    return false;
}

Navigation::Navigation(const ScenarioSpec& spec, const World& world) : spec_(spec), world_(world) {
    const auto t0 = std::chrono::steady_clock::now();
    const VenueSpec& venue = spec.venue;
    for (const TargetSpec& t : venue.targets) {
        Target target;
        target.shape = t.shape;
        target.exit = t.exit;
        if (t.width > 0) {
            target.width = t.width;
        } else if (t.shape.kind == TargetShape::Kind::Polygon) {
            // The longest side: a rectangle drawn across a door spans its width.
            double w = 0;
            const std::vector<Vec2>& p = t.shape.polygon;
            for (std::size_t k = 0; k < p.size(); ++k) w = std::max(w, (p[(k + 1) % p.size()] - p[k]).norm());
            target.width = w;
        }
        if (t.shape.kind == TargetShape::Kind::Polygon && !t.shape.polygon.empty())
            target.box = t.shape.bounds();
        targets_.push_back(std::move(target));
    }
    open_.assign(targets_.size(), 1);
    for (const ExitSetSpec& e : venue.exitSets) {
        std::vector<int> exits;
        std::vector<double> weights;
        for (std::size_t k = 0; k < e.exits.size(); ++k) {
            exits.push_back(venue.targetIndex(e.exits[k]));
            weights.push_back(k < e.weights.size() ? e.weights[k] : 1.0);
        }
        setExits_.push_back(std::move(exits));
        setWeights_.push_back(std::move(weights));
        setFixed_.push_back(venue.targetIndex(e.fixed));
    }
    for (const JourneySpec& j : venue.journeys) {
        std::vector<int> stages;
        for (const WaypointSpec& w : j.waypoints) stages.push_back(venue.targetIndex(w.target));
        stageTarget_.push_back(std::move(stages));
    }
    for (const ExitEventSpec& e : venue.exitEvents) eventTarget_.push_back(venue.targetIndex(e.exit));
    for (const ExitSetSpec& e : venue.exitSets) quickest_ = quickest_ || e.choice == ExitChoice::Quickest;
    for (const std::vector<int>& exits : setExits_) choiceSlots_ = std::max(choiceSlots_, exits.size());
    for (const JourneySpec& j : venue.journeys) {
        exitSetOf_.push_back(j.leaveBy.empty() ? -1 : venue.exitSetIndex(j.leaveBy));
        const int set = exitSetOf_.back();
        quickestJourney_.push_back(set >= 0 && venue.exitSets[static_cast<std::size_t>(set)].choice == ExitChoice::Quickest);
        leaveExitOf_.push_back(j.leaveBy.empty() || exitSetOf_.back() >= 0 ? -1 : venue.targetIndex(j.leaveBy));
        for (const WaypointSpec& w : j.waypoints) {
            const int t = venue.targetIndex(w.target);
            if (t >= 0 && w.capacity > 0) {
                int& c = targets_[static_cast<std::size_t>(t)].capacity;
                c = c == 0 ? w.capacity : std::min(c, w.capacity);
            }
        }
    }
    eventOrder_.resize(venue.exitEvents.size());
    for (std::size_t k = 0; k < eventOrder_.size(); ++k) eventOrder_[k] = static_cast<int>(k);
    std::stable_sort(eventOrder_.begin(), eventOrder_.end(), [&](int a, int b) {
        return venue.exitEvents[static_cast<std::size_t>(a)].time < venue.exitEvents[static_cast<std::size_t>(b)].time;
    });

    // Groups drawn by sources: each one's first member (the members are consecutive arrivals).
    groupFirst_.assign(spec.groups.size(), -1);
    groupMembers_.assign(spec.groups.size(), {});
    for (std::size_t k = 0; k < spec.agents.size(); ++k) {
        const AgentSpec& a = spec.agents[k];
        if (a.source < 0 || a.groupIndex < 0 || static_cast<std::size_t>(a.groupIndex) >= groupFirst_.size()) continue;
        const std::size_t g = static_cast<std::size_t>(a.groupIndex);
        if (groupFirst_[g] < 0) groupFirst_[g] = a.id;
        groupMembers_[g].push_back(k);
    }
    groupExit_.assign(spec.groups.size(), -1);
    groupPlaced_.assign(spec.groups.size(), 0);
    groupAnchor_.assign(spec.groups.size(), Vec2(0, 0));
    groupAnchorStep_.assign(spec.groups.size(), std::numeric_limits<std::uint64_t>::max());

    if (!venue.navigation) {
        prepSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return;
    }
    if (world.type() == WorldType::Toric)
        throw std::runtime_error("<Navigation> needs a Planar or Infinite world, not a Toric one");
    // Plain goals navigate too: one point target per distinct goal.
    for (const AgentSpec& a : spec.agents)
        if (a.journey.empty() && a.goal && goalTarget(*a.goal) < 0) {
            goalIndex_.emplace(std::make_pair(a.goal->x(), a.goal->y()), static_cast<int>(targets_.size()));
            Target target;
            target.shape.kind = TargetShape::Kind::Point;
            target.shape.point = *a.goal;
            targets_.push_back(std::move(target));
        }

    const auto [lo, hi] = navigationBounds(spec);
    grid_ = std::make_unique<WalkableGrid>(world, venue.navigation->grid, lo, hi);
    fields_.resize(targets_.size());
    const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(targets_.size());
    // Fields are independent: built in parallel, each a pure function of grid and target.
#pragma omp parallel for schedule(dynamic, 1) if (n > 1)
    for (std::ptrdiff_t k = 0; k < n; ++k)
        fields_[static_cast<std::size_t>(k)] = DistanceField(*grid_, targets_[static_cast<std::size_t>(k)].shape);
    for (std::size_t k = 0; k < fields_.size(); ++k)
        if (!fields_[k].seeded()) {
            const std::string what = k < venue.targets.size() ? "target '" + venue.targets[k].name + "'"
                                                               : "a goal at (" + std::to_string(targets_[k].shape.point.x()) +
                                                                     ", " + std::to_string(targets_[k].shape.point.y()) + ")";
            throw std::runtime_error(what + " touches no walkable floor (inside a wall or off the navigation grid)");
        }
    prepSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Navigation::~Navigation() = default;

int Navigation::goalTarget(const Vec2& goal) const {
    const auto it = goalIndex_.find({goal.x(), goal.y()});
    return it == goalIndex_.end() ? -1 : it->second;
}

std::pair<Vec2, Vec2> navigationBounds(const ScenarioSpec& spec) {
    if (spec.world.type == WorldType::Planar)
        return {Vec2(spec.world.xmin, spec.world.ymin), Vec2(spec.world.xmax, spec.world.ymax)};
    Box box;
    auto grow = [&](const Vec2& p) { box.add(p); };
    for (const ObstacleSpec& o : spec.obstacles)
        for (const Vec2& p : o.points) grow(p);
    for (const TargetSpec& t : spec.venue.targets) {
        const Box b = t.shape.bounds();
        grow(b.lo);
        grow(b.hi);
    }
    for (const AgentSpec& a : spec.agents) {
        if (a.source < 0) grow(a.position);  // a source's agents: its area, below
        if (a.journey.empty() && a.goal) grow(*a.goal);
    }
    for (const SourceSpec& s : spec.venue.sources) {
        for (const Vec2& p : s.area) grow(p);
        if (s.goal) grow(*s.goal);
    }
    if (!std::isfinite(box.lo.x())) box = Box(Vec2(0, 0), Vec2(0, 0));
    const Box grid = box.grown(spec.venue.navigation ? spec.venue.navigation->margin : NavigationSpec{}.margin);
    return {grid.lo, grid.hi};
}

Vec2 Navigation::directionTo(int target, const Vec2& p, double& distance) const {
    if (!fields_.empty()) return directionTo(target, p, grid_->probe(p), distance);
    return straightTo(target, p, distance);
}

Vec2 Navigation::directionTo(int target, const Vec2& p, const WalkableGrid::Probe& q, double& distance) const {
    const Vec2 dir = fields_[static_cast<std::size_t>(target)].sample(q, p, distance);
    if (std::isfinite(distance)) return dir;
    return straightTo(target, p, distance);
}

Vec2 Navigation::straightTo(int target, const Vec2& p, double& distance) const {
    // No field (or p off the grid): straight at the nearest point of the target.
    const Target& t = targets_[static_cast<std::size_t>(target)];
    const Vec2 c = t.shape.closest(p);
    distance = (c - p).norm();
    return normalisedOrZero(c - p);
}

void Navigation::prefetchLanes(const WalkableGrid::Probe8& q, const int* target, unsigned lanes) const {
    for (unsigned m = lanes & q.inGrid; m != 0; m &= m - 1) {
        const int l = __builtin_ctz(m);
        fields_[static_cast<std::size_t>(target[l])].prefetch(static_cast<std::size_t>(q.first[l]));
    }
}

void Navigation::directionsTo(const WalkableGrid::Probe8& q, const Vec2* pos, const int* target, unsigned lanes,
                              Vec2* dir, double* dist) const {
    const DistanceField* fields[8] = {};  // (only the lanes in `lanes` are read)
    for (unsigned m = lanes; m != 0; m &= m - 1) {
        const int l = __builtin_ctz(m);
        fields[l] = &fields_[static_cast<std::size_t>(target[l])];
    }
    const unsigned done = DistanceField::sample8(fields, q, lanes, dir, dist);
    for (unsigned m = lanes & ~done; m != 0; m &= m - 1) {
        const int l = __builtin_ctz(m);
        dir[l] = directionTo(target[l], pos[l], grid_->probe(pos[l]), dist[l]);
    }
}

double Navigation::width(int target) const { return targets_[static_cast<std::size_t>(target)].width; }

double Navigation::distanceTo(int target, const Vec2& p) const {
    double d = 0;
    directionTo(target, p, d);
    return d;
}

void Navigation::activated(AgentStore& a, std::size_t i, const AgentSpec& s, double time) {
    a.holdUntil[i] = time + s.premovement;
    // Quickest choices are re-evaluated at staggered times (a fixed fraction of the interval per
    // id), so a crowd does not switch all in one step on the same snapshot.
    {
        const double phase = std::fmod(static_cast<double>(s.id < 0 ? 0 : s.id) * 0.6180339887498949, 1.0);
        double interval = 0;
        for (const ExitSetSpec& e : spec_.venue.exitSets) interval = std::max(interval, e.interval);
        a.nextChoice[i] = time + phase * interval;
    }
    if (!s.journey.empty()) {
        const int j = spec_.venue.journeyIndex(s.journey);
        if (j < 0) throw std::runtime_error("agent " + std::to_string(s.id) + " names journey '" + s.journey + "', which does not exist");
        a.journey[i] = j;
        a.stage[i] = 0;
        const JourneySpec& js = spec_.venue.journeys[static_cast<std::size_t>(j)];
        if (js.waypoints.empty()) {
            chooseExit(a, i, time, spec_.seed, scratch_);
        } else {
            a.target[i] = stageTarget_[static_cast<std::size_t>(j)][0];
        }
    } else if (s.goal && !fields_.empty()) {
        a.target[i] = goalTarget(*s.goal);
    }
    if (a.target[i] >= 0) a.navDir[i] = directionTo(a.target[i], a.pos[i], a.navDistance[i]);
}

bool Navigation::freeAt(const Vec2& p, double radius, const std::vector<std::pair<Vec2, double>>& near) const {
    if (!world_.inside(p) || world_.insideObstacle(p)) return false;
    if (grid_ && !grid_->walkable(p)) return false;
    std::vector<int> segs;
    world_.segmentsNear(p, radius, segs);
    for (int g : segs) {
        const Segment& seg = world_.segments()[static_cast<std::size_t>(g)];
        if (distanceToSegmentSquared(p, seg.a, seg.b) < radius * radius) return false;
    }
    for (const auto& [q, r] : near) {
        const double reach = radius + r;
        if ((q - p).squaredNorm() < reach * reach) return false;
    }
    return true;
}

bool Navigation::place(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed, AgentSpec& s,
                       std::uint64_t seed, std::uint64_t step) const {
    const SourceSpec& src = spec_.venue.sources[static_cast<std::size_t>(s.source)];
    const Box area = Box::around(src.area);
    // The people already near the area: one pass over the crowd, then the attempts test only them.
    const Box reach = area.grown(s.radius + 1.0);
    std::vector<std::pair<Vec2, double>> near;
    for (std::size_t j = 0; j < agents.size(); ++j)
        if (reach.contains(agents.pos[j])) near.push_back({agents.pos[j], agents.radius[j]});
    for (const auto& p : placed) near.push_back(p);
    Rng rng(seed, static_cast<std::uint64_t>(s.id), kStreamSource, step + 1);
    constexpr int kAttempts = 40;
    for (int k = 0; k < kAttempts; ++k) {
        const Vec2 p(rng.uniform(area.lo.x(), area.hi.x()), rng.uniform(area.lo.y(), area.hi.y()));
        if (!pointInPolygon(p, src.area)) continue;
        if (!freeAt(p, s.radius, near)) continue;
        s.position = p;
        return true;
    }
    return false;
}

namespace {
/// True when the segments [a, b] and [c, d] cross or touch.
bool segmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
    const auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
    const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
    const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
    // Collinear or touching: an end point on the other segment.
    const auto on = [&](const Vec2& p, const Vec2& q, const Vec2& r) {  // r on [p, q], given collinear
        return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) && std::min(p.y(), q.y()) <= r.y() &&
               r.y() <= std::max(p.y(), q.y());
    };
    return (d1 == 0 && on(a, b, c)) || (d2 == 0 && on(a, b, d)) || (d3 == 0 && on(c, d, a)) || (d4 == 0 && on(c, d, b));
}
}  // namespace

bool Navigation::placeNear(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed, AgentSpec& s,
                           const Vec2& anchor, std::uint64_t seed, std::uint64_t step) const {
    const SourceSpec& src = spec_.venue.sources[static_cast<std::size_t>(s.source)];
    const double R = kGroupPlacementRadius;
    const double reach = R + s.radius + 1.0;
    std::vector<std::pair<Vec2, double>> near;
    for (std::size_t j = 0; j < agents.size(); ++j)
        if ((agents.pos[j] - anchor).squaredNorm() <= reach * reach) near.push_back({agents.pos[j], agents.radius[j]});
    for (const auto& p : placed) near.push_back(p);
    std::vector<int> segs;
    world_.segmentsNear(anchor, R, segs);
    Rng rng(seed, static_cast<std::uint64_t>(s.id), kStreamSourceGroup, step + 1);
    constexpr int kAttempts = 40;
    for (int k = 0; k < kAttempts; ++k) {
        // Uniform in the disc of radius R round the anchor.
        const double r = R * std::sqrt(rng.uniform()), phi = 2 * kPi * rng.uniform();
        const Vec2 p = anchor + r * Vec2(std::cos(phi), std::sin(phi));
        // The first half of the attempts keep to the source's area; the rest may step out of it
        // (a narrow area), still on free floor in sight of the anchor.
        if (k < kAttempts / 2 && !pointInPolygon(p, src.area)) continue;
        if (!freeAt(p, s.radius, near)) continue;
        bool seen = true;
        for (std::size_t m = 0; seen && m < segs.size(); ++m) {
            const Segment& seg = world_.segments()[static_cast<std::size_t>(segs[m])];
            seen = !segmentsMeet(anchor, p, seg.a, seg.b);
        }
        if (!seen) continue;
        s.position = p;
        return true;
    }
    return false;
}

bool Navigation::placeArrival(const AgentStore& agents, const std::vector<std::pair<Vec2, double>>& placed,
                              AgentSpec& s, std::uint64_t seed, std::uint64_t step) {
    const std::size_t g = static_cast<std::size_t>(s.groupIndex);
    if (s.source < 0 || s.groupIndex < 0 || g >= groupFirst_.size() || groupFirst_[g] < 0)
        return place(agents, placed, s, seed, step);
    const std::vector<std::size_t>& members = groupMembers_[g];
    if (s.id == groupFirst_[g]) {
        if (!place(agents, placed, s, seed, step)) return false;
        // Places for the others beside it, all or none: the group arrives together or waits. After
        // kGroupPatience s of waiting it arrives as it fits (the others near it, else anywhere in
        // the area, else in a later step).
        const double now = static_cast<double>(step) * spec_.fineStep();
        const bool patient = now <= s.startTime + kGroupPatience;
        reserved_.clear();
        if (patient) {
            std::vector<std::pair<Vec2, double>> taken = placed;
            taken.push_back({s.position, s.radius});
            for (std::size_t m = 1; m < members.size(); ++m) {
                AgentSpec other = spec_.agents[members[m]];
                if (!placeNear(agents, taken, other, s.position, seed, step) && !place(agents, taken, other, seed, step)) {
                    reserved_.clear();
                    return false;
                }
                taken.push_back({other.position, other.radius});
                reserved_.push_back({other.id, other.position});
            }
        }
        groupPlaced_[g] = 1;
        groupAnchor_[g] = s.position;
        groupAnchorStep_[g] = step;
        return true;
    }
    if (!groupPlaced_[g]) return false;  // waits for the first member: the group arrives in one step
    if (groupAnchorStep_[g] == step)
        for (const auto& [id, at] : reserved_)
            if (id == s.id) {
                s.position = at;
                return true;
            }
    // Arriving as it fits (an impatient group, or a member deferred to a later step): beside the
    // first member when it came this step, else beside a member already walking (the first in the store).
    std::optional<Vec2> anchor;
    if (groupAnchorStep_[g] == step) {
        anchor = groupAnchor_[g];
    } else {
        for (std::size_t j = 0; j < agents.size() && !anchor; ++j)
            if (agents.group[j] == s.groupIndex) anchor = agents.pos[j];
    }
    if (anchor && placeNear(agents, placed, s, *anchor, seed, step)) return true;
    return place(agents, placed, s, seed, step);
}

bool Navigation::choosesNow(const AgentStore& a, std::size_t i, double t, bool changed) const {
    // Most agents fail on the first two tests, which read per-agent arrays in order. A leaving
    // agent's journey has leave_by: a journey needs waypoints or leave_by (the loader's rule), and
    // only with leave_by does an agent go past its last waypoint (advance()).
    const int j = a.journey[i];
    if (j < 0 || (!changed && t + 1e-9 < a.nextChoice[i]) || !leaving(a, i)) return false;
    return changed || quickestJourney_[static_cast<std::size_t>(j)] != 0;
}

void Navigation::chooseExit(AgentStore& a, std::size_t i, double t, std::uint64_t seed, ChoiceScratch& scratch,
                            bool sampled, const double* paths) {
    const VenueSpec& venue = spec_.venue;
    const int j = a.journey[i];
    const int setIndex = exitSetOf_[static_cast<std::size_t>(j)];
    const ExitSetSpec* set = setIndex >= 0 ? &venue.exitSets[static_cast<std::size_t>(setIndex)] : nullptr;
    // The candidates: the set's exits (resolved once, in the constructor), or the journey's one exit.
    const int single[1] = {leaveExitOf_[static_cast<std::size_t>(j)]};
    const double one[1] = {1.0};
    const std::span<const int> candidates =
        set ? std::span<const int>(setExits_[static_cast<std::size_t>(setIndex)]) : std::span<const int>(single);
    const std::span<const double> weights =
        set ? std::span<const double>(setWeights_[static_cast<std::size_t>(setIndex)]) : std::span<const double>(one);
    std::vector<int>& openOnes = scratch.openOnes;
    std::vector<double>& openWeights = scratch.openWeights;
    openOnes.clear();
    openWeights.clear();
    for (std::size_t k = 0; k < candidates.size(); ++k)
        if (open_[static_cast<std::size_t>(candidates[k])]) {
            openOnes.push_back(candidates[k]);
            openWeights.push_back(weights[k]);
        }
    if (openOnes.empty() && !set) {
        // A journey's only exit is closed: any open exit of the venue will do.
        for (std::size_t k = 0; k < targets_.size() && k < venue.targets.size(); ++k)
            if (targets_[k].exit && open_[k]) {
                openOnes.push_back(static_cast<int>(k));
                openWeights.push_back(1.0);
            }
    }
    int& current = a.target[i];
    // The path length to exit e from here: the agent's own, already sampled, for its current target.
    const int known = sampled ? current : -1;
    // Every exit's field is read at the same place: the grid is probed there once.
    WalkableGrid::Probe probe;
    bool probed = false;
    auto pathTo = [&](int e) {
        if (e >= 0 && e == known) return a.navDistance[i];
        if (paths && set)
            for (std::size_t k = 0; k < candidates.size(); ++k)
                if (candidates[k] == e && !std::isnan(paths[k])) return paths[k];
        if (fields_.empty()) return distanceTo(e, a.pos[i]);
        if (!probed) {
            probe = grid_->probe(a.pos[i]);
            probed = true;
        }
        double d = 0;
        directionTo(e, a.pos[i], probe, d);
        return d;
    };
    if (openOnes.empty()) {
        // Nowhere to go yet: keep heading for the exit chosen (or the first), wait for a reopening.
        if (current < 0) current = candidates.front();
        if (current != known) a.navDir[i] = directionTo(current, a.pos[i], a.navDistance[i]);
        return;
    }
    const bool currentOpen = current >= 0 && open_[static_cast<std::size_t>(current)] &&
                             std::find(openOnes.begin(), openOnes.end(), current) != openOnes.end();
    auto nearest = [&] {
        int best = openOnes.front();
        double bestD = kInf;
        for (int e : openOnes) {
            const double d = pathTo(e);
            if (d < bestD) {
                bestD = d;
                best = e;
            }
        }
        return best;
    };
    const ExitChoice rule = set ? set->choice : ExitChoice::Nearest;
    int chosen = current;
    switch (rule) {
        case ExitChoice::Nearest: chosen = nearest(); break;
        case ExitChoice::Fixed: {
            const int f = setFixed_[static_cast<std::size_t>(setIndex)];
            chosen = open_[static_cast<std::size_t>(f)] ? f : nearest();
            break;
        }
        case ExitChoice::Weighted: {
            // Drawn once; drawn again (among the open exits) only when the chosen exit closes.
            if (currentOpen) break;
            double sum = 0;
            for (double w : openWeights) sum += w;
            Rng rng(seed, static_cast<std::uint64_t>(a.id[i]), kStreamExitChoice, nextEvent_);
            double u = rng.uniform() * sum;
            chosen = openOnes.back();
            for (std::size_t k = 0; k < openOnes.size(); ++k) {
                if (u < openWeights[k]) {
                    chosen = openOnes[k];
                    break;
                }
                u -= openWeights[k];
            }
            break;
        }
        case ExitChoice::Quickest: {
            // Walking time plus the wait behind the people heading there and nearer to it:
            //   cost_e = d_e / v + n_e / (q_s · w_e).
            const double v = std::max(kMinChoiceSpeed, a.prefSpeed[i]);
            auto cost = [&](int e) {
                const double d = pathTo(e);
                // Strictly nearer people only: the agent itself (at distance d) is not counted.
                // (Before the first update, at activation, nobody is counted yet.)
                double ahead = 0;
                if (static_cast<std::size_t>(e) < ranks_.size())
                    ahead = static_cast<double>(ranks_[static_cast<std::size_t>(e)].countBelow(d));
                const double w = std::max(0.1, targets_[static_cast<std::size_t>(e)].width);
                return d / v + ahead / (set->flowCapacity * w);
            };
            int best = openOnes.front();
            double bestC = kInf, currentC = kInf;  // an open current exit is among openOnes
            for (int e : openOnes) {
                const double c = cost(e);
                if (e == current) currentC = c;
                if (c < bestC) {
                    bestC = c;
                    best = e;
                }
            }
            if (!currentOpen || bestC < (1.0 - set->hysteresis) * currentC) chosen = best;
            if (t + 1e-9 >= a.nextChoice[i]) a.nextChoice[i] = t + set->interval;
            break;
        }
    }
    if (chosen < 0) chosen = nearest();
    // A social group leaves by one exit: members heading for different exits would pull each
    // other back (the SocialGroups force) and stall between them. The first member to choose picks
    // by the rule; the others take its exit while it is open (they do not re-evaluate it one by one).
    const int g = a.group[i];
    if (g >= 0 && static_cast<std::size_t>(g) < groupExit_.size()) {
        const int shared = groupExit_[static_cast<std::size_t>(g)];
        if (shared >= 0 && std::find(openOnes.begin(), openOnes.end(), shared) != openOnes.end()) chosen = shared;
        else if (shared < 0 || !open_[static_cast<std::size_t>(shared)]) groupExit_[static_cast<std::size_t>(g)] = chosen;
        // (a member whose journey does not lead to the group's open exit goes its own way)
    }
    if (chosen == known) return;  // direction and distance already sampled
    current = chosen;
    a.navDir[i] = directionTo(current, a.pos[i], a.navDistance[i]);
}

void Navigation::update(AgentStore& a, double t, std::uint64_t seed) {
    const VenueSpec& venue = spec_.venue;
    const std::size_t n = a.size();
    // 1. Exits open and close; everyone leaving re-evaluates (a weighted choice only if its exit closed).
    bool changed = false;
    while (nextEvent_ < eventOrder_.size() &&
           venue.exitEvents[static_cast<std::size_t>(eventOrder_[nextEvent_])].time <= t + 1e-9) {
        const ExitEventSpec& e = venue.exitEvents[static_cast<std::size_t>(eventOrder_[nextEvent_])];
        open_[static_cast<std::size_t>(eventTarget_[static_cast<std::size_t>(eventOrder_[nextEvent_])])] = e.open ? 1 : 0;
        ++nextEvent_;
        changed = true;
    }

    // 2. Directions and remaining distances (each agent its own slot), in runs of kRun agents:
    // every position of a run is probed on the grid (once for every field: they share it) and
    // the field cells it needs are requested, then the run is sampled. Agents sit in many
    // different rows of a field, and the memory latency of one agent's rows is then hidden behind
    // the work of the others. Probes and samples go eight agents at a time (probe8, sample8: in
    // AVX-512 lanes where the CPU runs it); the agents near walls, targets and the grid's edges,
    // which sample8 leaves, are sampled one by one.
    // The same pass lists, per thread, what step 3 and the quickest rule need (issue 20: these
    // were serial passes over everyone, about half of the quickest rule's navigation time on
    // two threads):
    //  * per exit, the remaining distances of the people heading there, indexed below for "how
    //    many are nearer" (the quickest rule's only input; not gathered in venues without it);
    //  * who chooses an exit in step 3 (a quickest choice due, or an exit opened or closed);
    //  * who has step 3's serial work: agents before their last waypoint, and choosers in a group.
    // Each thread's runs are one contiguous block (schedule(static)), so the lists joined in
    // thread order are in agent order, whatever the number of threads.
    constexpr std::size_t kRun = 16;
    const std::size_t runs = (n + kRun - 1) / kRun;
    const bool team = parallelCheapLoop(n);
    const std::size_t threads = team ? static_cast<std::size_t>(std::max(1, omp_get_max_threads())) : 1;
    if (lists_.size() < threads) lists_.resize(threads);
    for (ThreadLists& l : lists_) {
        l.serial.clear();
        l.choosers.clear();
        l.queues.resize(quickest_ ? targets_.size() : 0);
        for (Queue& q : l.queues) q.values.clear();
    }
    if (quickest_) ranks_.resize(targets_.size());
    serial_.clear();
    choosers_.clear();
    const bool listChoosers = !fields_.empty() && choiceSlots_ > 0;
    // The m-th chooser's row of paths to its set's exits (none when they are not sampled).
    const auto pathsOf = [&](std::size_t m) -> const double* {
        return listChoosers ? &choicePaths_[m * choiceSlots_] : nullptr;
    };
    static const std::vector<int> kNoExits;
#pragma omp parallel if (team)
    {
        ThreadLists& mine = lists_[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(static)
        for (std::ptrdiff_t rr = 0; rr < static_cast<std::ptrdiff_t>(runs); ++rr) {
            const std::size_t begin = static_cast<std::size_t>(rr) * kRun, end = std::min(n, begin + kRun);
            if (fields_.empty()) {
                for (std::size_t i = begin; i < end; ++i)
                    if (a.target[i] >= 0) a.navDir[i] = directionTo(a.target[i], a.pos[i], a.navDistance[i]);
            } else {
                WalkableGrid::Probe8 probes[kRun / 8];
                unsigned lanes[kRun / 8] = {};
                for (std::size_t g = 0; g < kRun / 8 && begin + 8 * g < end; ++g) {
                    const std::size_t lo = begin + 8 * g, count = std::min<std::size_t>(8, end - lo);
                    grid_->probe8(&a.pos[lo], static_cast<int>(count), probes[g]);
                    for (std::size_t l = 0; l < count; ++l)
                        if (a.target[lo + l] >= 0) lanes[g] |= 1u << l;
                    prefetchLanes(probes[g], &a.target[lo], lanes[g]);
                }
                for (std::size_t g = 0; g < kRun / 8 && begin + 8 * g < end; ++g) {
                    const std::size_t lo = begin + 8 * g;
                    Vec2 dirs[8];
                    double dists[8];
                    directionsTo(probes[g], &a.pos[lo], &a.target[lo], lanes[g], dirs, dists);
                    for (unsigned m = lanes[g]; m != 0; m &= m - 1) {
                        const int l = __builtin_ctz(m);
                        a.navDir[lo + static_cast<std::size_t>(l)] = dirs[l];
                        a.navDistance[lo + static_cast<std::size_t>(l)] = dists[l];
                    }
                }
            }
            for (std::size_t i = begin; i < end; ++i) {
                if (a.journey[i] < 0) continue;
                if (!leaving(a, i)) {
                    mine.serial.push_back(i);
                    continue;
                }
                if (quickest_ && a.target[i] >= 0) mine.queues[static_cast<std::size_t>(a.target[i])].values.push_back(a.navDistance[i]);
                if (choosesNow(a, i, t, changed)) {
                    mine.choosers.push_back(i);
                    if (sharesGroupExit(a, i)) mine.serial.push_back(i);
                }
            }
        }
        // (the implicit barrier: every list is complete, and every thread sees the same lists)
        // Nobody listed and no queues to index (no journeys, or no choice due, as in a venue
        // without the quickest rule most of the time): nothing more to do on the team.
        std::size_t listed = 0;
        for (std::size_t k = 0; k < threads; ++k) listed += lists_[k].serial.size() + lists_[k].choosers.size();
        const bool more = quickest_ || listed > 0;  // (the quickest rule indexes its queues every update, empty or not)
        if (more) {
#pragma omp single
            {
                for (std::size_t k = 0; k < threads; ++k) {
                    serial_.insert(serial_.end(), lists_[k].serial.begin(), lists_[k].serial.end());
                    choosers_.insert(choosers_.end(), lists_[k].choosers.begin(), lists_[k].choosers.end());
                }
                // (OpenMP leaves the blocks' order to the runtime; every known one keeps it.)
                if (!std::is_sorted(serial_.begin(), serial_.end())) std::sort(serial_.begin(), serial_.end());
                if (!std::is_sorted(choosers_.begin(), choosers_.end())) std::sort(choosers_.begin(), choosers_.end());
                choicePaths_.assign(listChoosers ? choosers_.size() * choiceSlots_ : 0,
                                    std::numeric_limits<double>::quiet_NaN());  // not sampled: unknown
                if (quickest_) {
                    rankParts_.resize(targets_.size());
                    for (std::size_t e = 0; e < targets_.size(); ++e) {
                        rankParts_[e].clear();
                        for (std::size_t k = 0; k < threads; ++k) rankParts_[e].emplace_back(lists_[k].queues[e].values);
                    }
                }
            }
        }
        // Each exit's index of distances, exits shared among the threads.
        if (quickest_) {
#pragma omp for schedule(dynamic, 1)
            for (std::ptrdiff_t e = 0; e < static_cast<std::ptrdiff_t>(targets_.size()); ++e)
                ranks_[static_cast<std::size_t>(e)].assign(rankParts_[static_cast<std::size_t>(e)]);
        }
        // The paths to the choosers' other exits, eight choosers at a time (probe8 and
        // directionsTo, as in 2): slot k of a chooser's row is its set's k-th exit, sampled when
        // open and not its target already.
        if (listChoosers && more) {
#pragma omp for schedule(static)
            for (std::ptrdiff_t gg = 0; gg < static_cast<std::ptrdiff_t>((choosers_.size() + 7) / 8); ++gg) {
                const std::size_t lo = static_cast<std::size_t>(gg) * 8;
                const int count = static_cast<int>(std::min<std::size_t>(8, choosers_.size() - lo));
                Vec2 pos[8];
                const std::vector<int>* exits[8];
                for (int l = 0; l < count; ++l) {
                    const std::size_t i = choosers_[lo + static_cast<std::size_t>(l)];
                    const int set = exitSetOf_[static_cast<std::size_t>(a.journey[i])];
                    pos[l] = a.pos[i];
                    exits[l] = set >= 0 ? &setExits_[static_cast<std::size_t>(set)] : &kNoExits;
                }
                WalkableGrid::Probe8 q;
                grid_->probe8(pos, count, q);
                for (std::size_t k = 0; k < choiceSlots_; ++k) {
                    int exit[8];
                    unsigned lanes = 0;
                    for (int l = 0; l < count; ++l) {
                        if (k >= exits[l]->size()) continue;
                        exit[l] = (*exits[l])[k];
                        if (exit[l] != a.target[choosers_[lo + static_cast<std::size_t>(l)]] && open_[static_cast<std::size_t>(exit[l])])
                            lanes |= 1u << l;
                    }
                    if (lanes == 0) continue;
                    prefetchLanes(q, exit, lanes);
                    Vec2 dirs[8];
                    double dists[8];
                    directionsTo(q, pos, exit, lanes, dirs, dists);
                    for (unsigned m = lanes; m != 0; m &= m - 1) {
                        const int l = __builtin_ctz(m);
                        choicePaths_[(lo + static_cast<std::size_t>(l)) * choiceSlots_ + k] = dists[l];
                    }
                }
            }
        }
        // 3a. Exit choices outside social groups: each reads the indexes and its own row and
        // writes its own slots only, so they run on the team (those in groups are in serial_).
        if (more) {
#pragma omp for schedule(static)
            for (std::ptrdiff_t mm = 0; mm < static_cast<std::ptrdiff_t>(choosers_.size()); ++mm) {
                const std::size_t m = static_cast<std::size_t>(mm), i = choosers_[m];
                if (!sharesGroupExit(a, i)) chooseExit(a, i, t, seed, mine.scratch, true, pathsOf(m));
            }
        }
    }

    // 3b. Dwell ends, arrivals and exit choices in social groups: serial, in agent order (services
    // are recorded in that order, and a group's first choice binds the others). Agent i's step
    // changes its own slots only, so it is still listed as in 2.
    for (const std::size_t i : serial_) {
        if (!leaving(a, i)) {
            serveWaypoint(a, i, t, seed);
            continue;
        }
        // Step 2 sampled its current target (-1: none), and the pass after it the other exits
        // of its set.
        const std::size_t m = static_cast<std::size_t>(std::lower_bound(choosers_.begin(), choosers_.end(), i) - choosers_.begin());
        chooseExit(a, i, t, seed, scratch_, true, pathsOf(m));
    }

    // Checkpoints with a capacity admit their free places to the nearest waiting people.
    for (std::size_t k = 0; k < venue.targets.size(); ++k) {
        const int cap = targets_[k].capacity;
        if (cap <= 0) continue;
        int used = 0;
        std::vector<std::size_t> waiting;
        for (std::size_t i = 0; i < n; ++i) {
            if (a.target[i] != static_cast<int>(k) || a.journey[i] < 0 || leaving(a, i)) continue;
            if (a.navFlags[i] & (kAdmitted | kInService)) ++used;
            else waiting.push_back(i);
        }
        std::sort(waiting.begin(), waiting.end(), [&](std::size_t x, std::size_t y) {
            return a.navDistance[x] != a.navDistance[y] ? a.navDistance[x] < a.navDistance[y] : a.id[x] < a.id[y];
        });
        for (std::size_t m = 0; m < waiting.size() && used < cap; ++m, ++used)
            a.navFlags[waiting[m]] = static_cast<unsigned char>(a.navFlags[waiting[m]] | kAdmitted);
    }
}

void Navigation::serveWaypoint(AgentStore& a, std::size_t i, double t, std::uint64_t seed) {
    const int j = a.journey[i];
    const JourneySpec& js = spec_.venue.journeys[static_cast<std::size_t>(j)];
    const std::size_t s = static_cast<std::size_t>(a.stage[i]);
    const WaypointSpec& w = js.waypoints[s];
    Target& target = targets_[static_cast<std::size_t>(a.target[i])];
    if (a.navFlags[i] & kInService) {
        if (t + 1e-9 >= a.holdUntil[i]) {
            for (auto it = services_.rbegin(); it != services_.rend(); ++it)
                if (it->id == a.id[i] && it->end < 0) {
                    it->end = t;
                    break;
                }
            a.navFlags[i] = 0;
            advance(a, i, t, seed);
        }
        return;
    }
    const bool inside = target.shape.kind == TargetShape::Kind::Point
                            ? (a.pos[i] - target.shape.point).norm() <= std::max(target.shape.radius, a.goalRadius[i])
                            : target.contains(a.pos[i]);
    if (!inside) return;
    if (target.capacity > 0 && !(a.navFlags[i] & kAdmitted)) return;  // waits to be admitted
    if (w.dwell > 0 || target.capacity > 0) {
        a.navFlags[i] = static_cast<unsigned char>(a.navFlags[i] | kInService);
        a.holdUntil[i] = std::max(a.holdUntil[i], t + w.dwell);
        services_.push_back(Service{a.id[i], j, static_cast<int>(s), t, -1.0});
        if (w.dwell <= 0) {  // a capacity without dwell: through one at a time, no stop
            services_.back().end = t;
            a.navFlags[i] = 0;
            advance(a, i, t, seed);
        }
    } else {
        advance(a, i, t, seed);
    }
}

void Navigation::advance(AgentStore& a, std::size_t i, double t, std::uint64_t seed) {
    const JourneySpec& js = spec_.venue.journeys[static_cast<std::size_t>(a.journey[i])];
    const std::size_t next = static_cast<std::size_t>(a.stage[i]) + 1;
    if (next < js.waypoints.size()) {
        a.stage[i] = static_cast<int>(next);
        a.target[i] = stageTarget_[static_cast<std::size_t>(a.journey[i])][next];
        a.navDir[i] = directionTo(a.target[i], a.pos[i], a.navDistance[i]);
    } else if (!js.leaveBy.empty()) {
        a.stage[i] = static_cast<int>(next);
        a.target[i] = -1;
        chooseExit(a, i, t, seed, scratch_);
    } else {
        // No exit: the agent stays at its last waypoint (stage stays there, in place, done).
        a.navFlags[i] = static_cast<unsigned char>(a.navFlags[i] | kDone);
    }
}

Vec2 Navigation::preferred(const AgentStore& a, std::size_t i, double t) const {
    if (t + 1e-9 < a.holdUntil[i] || (a.navFlags[i] & (kInService | kDone))) return Vec2(0, 0);
    if (a.target[i] < 0) {
        // UMANS: straight at the goal, zero inside the goal radius.
        return a.atGoal(i) ? Vec2(0, 0) : Vec2(normalisedOrZero(a.goal[i] - a.pos[i]) * a.prefSpeed[i]);
    }
    if (a.journey[i] < 0) {
        // A plain goal along its path: UMANS' arrival rule.
        if (a.atGoal(i)) return Vec2(0, 0);
        if (a.navDistance[i] <= a.goalRadius[i] + 2 * (grid_ ? grid_->cellSize() : 0))
            return normalisedOrZero(a.goal[i] - a.pos[i]) * a.prefSpeed[i];
        return a.navDir[i] * a.prefSpeed[i];
    }
    const Target& target = targets_[static_cast<std::size_t>(a.target[i])];
    if (!leaving(a, i) && target.capacity > 0 && !(a.navFlags[i] & kAdmitted) && a.navDistance[i] <= kQueueDistance)
        return Vec2(0, 0);  // waits in front of a full checkpoint
    return a.navDir[i] * a.prefSpeed[i];
}

int Navigation::leaves(const AgentStore& a, std::size_t i) const {
    if (a.journey[i] < 0 || !leaving(a, i)) return -1;
    const JourneySpec& js = spec_.venue.journeys[static_cast<std::size_t>(a.journey[i])];
    if (js.leaveBy.empty()) return -1;
    // Any open exit the agent may leave by, not only the one it aimed for.
    auto through = [&](int e) {
        return e >= 0 && open_[static_cast<std::size_t>(e)] && targets_[static_cast<std::size_t>(e)].contains(a.pos[i]);
    };
    if (through(a.target[i])) return a.target[i];
    const int setIndex = exitSetOf_[static_cast<std::size_t>(a.journey[i])];
    if (setIndex >= 0)
        for (const int e : setExits_[static_cast<std::size_t>(setIndex)])
            if (through(e)) return e;
    return -1;
}

}  // namespace ch
