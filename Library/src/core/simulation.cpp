// CrowdHealth — the simulation loop (see simulation.h for the order of phases).
#include "crowdhealth/core/simulation.h"

#include "crowdhealth/core/kernels.h"
#include "crowdhealth/core/near_filter.h"
#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/rng.h"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace ch {

namespace {
int finePerCoarseOf(const ScenarioSpec& s) {
    const double ratio = s.deltaTime / s.fineStep();
    return std::max(1, static_cast<int>(std::lround(ratio)));
}
}  // namespace

Simulation::Simulation(ScenarioSpec specIn)
    : spec_(std::move(specIn)),
      world_(spec_.world, spec_.obstacles),
      dtCoarse_(spec_.deltaTime),
      dtFine_(spec_.fineStep()),
      finePerCoarse_(finePerCoarseOf(spec_)),
      endTime_(spec_.endTime) {
    const ScenarioSpec& spec = spec_;
    if (!(dtCoarse_ > 0) || !(dtFine_ > 0)) throw std::runtime_error("delta_time must be positive");

    std::map<int, int> policyIndex;
    for (const PolicySpec& p : spec.policies) {
        if (policyIndex.count(p.id)) throw std::runtime_error("duplicate policy id " + std::to_string(p.id));
        policyIndex[p.id] = static_cast<int>(policies_.size());
        policies_.emplace_back(p);  // throws RegistryError for unknown components
    }
    double maxRadius = 0;
    for (const AgentSpec& a : spec.agents) {
        if (!policyIndex.count(a.policyId))
            throw std::runtime_error("agent " + std::to_string(a.id) + " names policy " +
                                     std::to_string(a.policyId) + ", which does not exist");
        maxRadius = std::max(maxRadius, a.radius);
    }
    agentPolicy_.reserve(spec.agents.size());
    for (const AgentSpec& a : spec.agents) agentPolicy_.push_back(policyIndex[a.policyId]);

    // A body on the floor (CrowdHealth falls) is larger than the person standing.
    maxRadius = std::max(maxRadius, HealthLayer::largestFallenRadius(spec));
    // Neighbourhood radius per policy: its largest component range, and at least the contact reach.
    maxRadius_ = maxRadius;
    for (const Policy& p : policies_) {
        double r = 2 * maxRadius;
        for (const PolicyStep& s : p.steps()) r = std::max(r, s.interactionRange());
        policyRange_.push_back(r);
        maxRange_ = std::max(maxRange_, r);
    }
    gridCell_ = stepGridCell(maxRange_);
    world_.prepareWallQueries(policyRange_);  // every agent's walls within its policy's range, every step
    // Lists are stored only when some component reads them through its StepContext.
    needStoredLists_ = false;
    for (const Policy& p : policies_)
        for (const PolicyStep& s : p.steps())
            for (const auto& e : s.components()) needStoredLists_ = needStoredLists_ || e.component->readsStepLists();
    storeLists_ = needStoredLists_;
    for (const Policy& p : policies_) {
        // Per-agent step buffers that only some policies need (none is kept at a million agents
        // when nobody uses it: 16 bytes each per agent).
        anyUmansContact_ = anyUmansContact_ || p.contactForceScale() > 0;
        // A policy whose components all read their neighbours elsewhere (SPH, ContactForces: the
        // stored lists by index) gets no AgentQuery::agents, unless UMANS' contact reads them.
        bool reads = p.contactForceScale() > 0;
        for (const PolicyStep& s : p.steps()) {
            anyCoarseStep_ = anyCoarseStep_ || s.timing() == StepTiming::Coarse;
            for (const auto& e : s.components()) reads = reads || e.component->readsQueryAgents();
        }
        queryAgents_.push_back(reads ? 1 : 0);
    }

    totalAgents_ = spec.agents.size();
    pending_.resize(spec.agents.size());
    for (std::size_t k = 0; k < pending_.size(); ++k) pending_[k] = k;
    std::stable_sort(pending_.begin(), pending_.end(), [&](std::size_t a, std::size_t b) {
        return spec.agents[a].startTime < spec.agents[b].startTime;
    });
    agents_.navigationColumns = Navigation::needed(spec_);
    agents_.reserve(spec.agents.size());
    if (agents_.navigationColumns) navigation_ = std::make_unique<Navigation>(spec_, world_);
    health_.init(spec_);
    resolveRamps();
    activatePending();
    applySchedule();
}

Simulation::~Simulation() = default;

bool Simulation::releaseAgentSpecs() {
    if (specsReleased_) return true;
    if (pending() > 0) return false;
    // Read only to activate agents (their spec, policy and record, a waiting group's members in
    // Navigation) and by ramps and setPrefSpeed for agents still to come: none is left.
    std::vector<AgentSpec>().swap(spec_.agents);
    std::vector<std::size_t>().swap(pending_);
    nextPending_ = 0;
    std::vector<int>().swap(agentPolicy_);
    health_.releaseSpecPositions();
    specsReleased_ = true;
    return true;
}

double Simulation::stepGridCell(double range) {
    return range < NeighbourLists::kFineGridFrom ? 0.5 * range : range;
}

void Simulation::setThreads(int n) { omp_set_num_threads(std::max(1, n)); }

bool Simulation::finished() const {
    // Nothing left to simulate once every agent has left (evacuation runs end there even when
    // the scenario names a later end_time).
    if (agents_.empty() && pending() == 0) return true;
    return endTime_ >= 0 && time() >= endTime_ - 0.5 * dtFine_;
}

void Simulation::activatePending() {
    // Half a fine step of tolerance so a start_time written as a multiple of delta_time is met
    // exactly despite rounding.
    const double now = time() + 0.5 * dtFine_;
    const std::size_t before = agents_.size();
    if (navigation_ == nullptr) {
        while (nextPending_ < pending_.size() && spec_.agents[pending_[nextPending_]].startTime <= now) {
            const std::size_t k = pending_[nextPending_++];
            const std::size_t i = agents_.add(spec_.agents[k], agentPolicy_[k], health_.recordFor(k));
            health_.activated(agents_, i);
        }
    } else {
        // Arrivals of sources take a free place in their area (a group's members beside its first
        // member); one that finds none waits (in order) and tries again next step, ahead of later
        // arrivals (a group's members wait with its first member).
        std::vector<std::size_t> due;
        due.swap(deferred_);
        while (nextPending_ < pending_.size() && spec_.agents[pending_[nextPending_]].startTime <= now)
            due.push_back(pending_[nextPending_++]);
        std::vector<std::pair<Vec2, double>> placed;
        for (std::size_t k : due) {
            AgentSpec& a = spec_.agents[k];
            if (a.source >= 0) {
                if (!navigation_->placeArrival(agents_, placed, a, spec_.seed, fineSteps_)) {
                    deferred_.push_back(k);
                    continue;
                }
                placed.push_back({a.position, a.radius});
            }
            const std::size_t i = agents_.add(a, agentPolicy_[k], health_.recordFor(k));
            health_.activated(agents_, i);
            navigation_->activated(agents_, i, a, time());
        }
    }
    if (agents_.size() != before) {
        std::vector<int> previous(agents_.size(), -1);
        for (std::size_t i = 0; i < before; ++i) previous[i] = static_cast<int>(i);
        followAgents(previous);
    }
}

void Simulation::followAgents(const std::vector<int>& previous) {
    // The held coarse accelerations (kept only when some policy has a coarse step), then every
    // component's per-agent state.
    if (anyCoarseStep_) {
        remapColumn(heldAccel_, previous, Vec2(0, 0));
    }
    for (Policy& p : policies_)
        for (PolicyStep& s : p.steps())
            for (auto& e : s.components()) e.component->remapAgents(previous);
}

void Simulation::stepCoarse() {
    for (int k = 0; k < finePerCoarse_; ++k) stepFine();
}

void Simulation::gatherQuery(std::size_t i, AgentQuery& q, NeighbourLists::Scratch& scratch, bool agents) const {
    setQueryAgent(q, agents_, i);
    if (lists_.streaming()) {
        lists_.gather(i, scratch, q.agents, q.segments);
        return;
    }
    q.agents = agents ? lists_.agents(i, scratch.agents) : std::span<const NeighbourAgent>{};
    q.segments = lists_.segments(i);
}

Vec2 Simulation::umansContactAcceleration(const AgentQuery& q, double scale, double maxRadius) const {
    // UMANS' contact model: a spring along the centre line for every overlap, applied after the
    // acceleration clamp. `scale` is a stiffness per unit mass (1/s²).
    // Only neighbours within q.radius + radius_j ≤ q.radius + maxRadius can touch: nearEntries
    // finds those candidates 64 entries at a time (eight per instruction with AVX-512; issue 20:
    // the SocialForces lists hold ~78 neighbours within 5 m, of which a handful touch), and each
    // candidate gets the exact test below, in list order, so the sum has the bits of the full scan.
    Vec2 acc(0, 0);
    const double bound = q.radius + maxRadius;
    const double bound2 = bound > 0 ? bound * bound : std::numeric_limits<double>::infinity();
    const std::size_t m = q.agents.size();
    for (std::size_t k0 = 0; k0 < m; k0 += 64) {
        const std::size_t count = std::min<std::size_t>(64, m - k0);
        for (std::uint64_t near = nearEntries(q.agents.data() + k0, count, bound2); near != 0; near &= near - 1) {
            const NeighbourAgent& n = q.agents[k0 + static_cast<std::size_t>(std::countr_zero(near))];
            const double reach = q.radius + agents_.radius[n.index];
            if (n.distanceSquared() >= reach * reach) continue;
            const double d = n.distance();
            const double overlap = reach - d;
            if (overlap > 0 && d > 1e-12) acc -= n.offset / d * (scale * overlap);
        }
    }
    // Walls: the query's are those within the policy's range (5 m for SocialForces), but only
    // those within q.radius touch. A wall whose bounds are farther than that along x or y is
    // passed over before its nearest point is computed (its distance is at least as far).
    const Vec2& p = q.position;
    for (int s : q.segments) {
        const Segment& seg = world_.segments()[s];
        if (std::max({std::min(seg.a.x(), seg.b.x()) - p.x(), p.x() - std::max(seg.a.x(), seg.b.x()),
                      std::min(seg.a.y(), seg.b.y()) - p.y(), p.y() - std::max(seg.a.y(), seg.b.y())}) > q.radius)
            continue;
        const Vec2 diff = q.position - closestPointOnSegment(q.position, seg.a, seg.b);
        const double d = diff.norm();
        const double overlap = q.radius - d;
        if (overlap > 0 && d > 1e-12) acc += diff / d * (scale * overlap);
    }
    return acc / q.mass;
}

const char* Simulation::phaseName(Phase p) {
    static constexpr const char* names[] = {"activation", "neighbours", "preferred", "prepare",
                                            "forces", "integration", "removal"};
    return p < Phase::Count ? names[static_cast<std::size_t>(p)] : "?";
}

template <class F>
void Simulation::timed(Phase p, F&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    phaseSeconds_[static_cast<std::size_t>(p)] +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void Simulation::stepFine() {
    timed(Phase::Activation, [&] { activatePending(); });
    const std::size_t n = agents_.size();
    const bool coarseBoundary = fineSteps_ % static_cast<std::uint64_t>(finePerCoarse_) == 0;

    timed(Phase::Neighbours, [&] {
        // One search per step: the grid, then every agent's neighbour list within its policy's
        // range, which SPH density, contact and the per-agent calls all read; or, when only the
        // per-agent calls read them, the lists are gathered in evaluateAgents, agent by agent.
        grid_.build(agents_.pos, gridCell_, world_.periodic(), spec_.world.width, spec_.world.height);
        if (reorderInterval_ > 0 && fineSteps_ % static_cast<std::uint64_t>(reorderInterval_) == 0) reorderAgents();
        if (storeLists_)
            lists_.build(agents_.pos, grid_, world_, agents_.policy, policyRange_);
        else
            lists_.bind(agents_.pos, grid_, world_, agents_.policy, policyRange_);
    });
    timed(Phase::Preferred, [&] {
        // CrowdHealth: panic update and the speeds in effect, then the preferred velocities, then
        // herding/erratic turns of the preferred direction (each agent writes only its own slot).
        health_.beginStep(agents_, grid_, time(), dtFine_);
        if (navigation_) navigation_->update(agents_, time(), spec_.seed);
        setPreferredVelocities();
        health_.steerPreferred(agents_, grid_, time(), spec_.seed);
        health_.care(agents_, grid_, time(), dtFine_, spec_.seed);
    });
    timed(Phase::Prepare, [&] {
        for (Policy& p : policies_)
            for (PolicyStep& s : p.steps())
                if (s.timing() == StepTiming::Fine || coarseBoundary) s.prepare(contextFor(s));
    });

    fineAccel_.resize(n);
    if (anyUmansContact_) umansContact_.resize(n);
    stopped_.resize(n);
    nextContact_.resize(n);
    timed(Phase::Forces, [&] { evaluateAgents(coarseBoundary); });
    // Every acceleration of the step is known: the state is advanced in place (each agent reads
    // and writes only its own slots from here on).
    timed(Phase::Integration, [&] { integrate(); });
    std::swap(agents_.contactAccel, nextContact_);
    ++fineSteps_;
    health_.endStep(agents_, time(), dtFine_);
    timed(Phase::Removal, [&] { removeFinished(); });
    applySchedule();
}

void Simulation::resolveRamps() {
    for (const RampSpec& r : spec_.ramps) {
        Ramp ramp;
        ramp.spec = r;
        if (r.target == RampSpec::Target::Component) {
            for (std::size_t p = 0; p < policies_.size(); ++p) {
                if (r.policyId && policies_[p].id() != *r.policyId) continue;
                if (r.component == "CrowdHealth") {
                    ramp.policies.push_back(static_cast<int>(p));
                    continue;
                }
                for (PolicyStep& s : policies_[p].steps())
                    for (auto& e : s.components())
                        if (e.name == r.component) ramp.components.push_back(e.component.get());
            }
            if (ramp.components.empty() && ramp.policies.empty())
                throw std::runtime_error(r.loc.file + ":" + std::to_string(r.loc.line) + ": the ramp of " + r.column() +
                                         " targets no component of any policy");
        }
        const std::string name = r.column();
        const auto it = std::find(scheduleColumns_.begin(), scheduleColumns_.end(), name);
        ramp.column = static_cast<int>(it - scheduleColumns_.begin());
        if (it == scheduleColumns_.end()) {
            ramp.first = true;
            scheduleColumns_.push_back(name);
            columnRamp_.push_back(static_cast<int>(ramps_.size()));
        }
        ramps_.push_back(std::move(ramp));
    }
    lastAgentValue_.assign(scheduleColumns_.size(), std::numeric_limits<double>::quiet_NaN());
}

void Simulation::applySchedule() {
    const double t = time();
    // Half a fine step of tolerance so a start written as a multiple of delta_time is met exactly.
    const double tol = 0.5 * dtFine_;
    for (Ramp& ramp : ramps_) {
        const RampSpec& r = ramp.spec;
        if (t < r.start - tol && !ramp.first) continue;  // a later ramp of the same target waits for its start
        const double v = t >= r.end - tol ? r.to : (t <= r.start + tol ? r.from : r.valueAt(t));
        // Held values are written once: outside its window a ramp costs nothing per step (agents
        // activated later read the value from their spec, updated below).
        if (v == ramp.applied) continue;
        ramp.applied = v;
        if (r.target == RampSpec::Target::Agents) {
            auto apply = [&](std::vector<double>& active, double AgentSpec::*member, std::vector<double>* base) {
                for (double& x : active) x = v;
                if (base != nullptr)
                    for (double& x : *base) x = v;
                for (std::size_t k = nextPending_; k < pending_.size(); ++k) spec_.agents[pending_[k]].*member = v;
            };
            if (r.parameter == "pref_speed") apply(agents_.basePrefSpeed, &AgentSpec::prefSpeed, &agents_.prefSpeed);
            else if (r.parameter == "max_speed") apply(agents_.baseMaxSpeed, &AgentSpec::maxSpeed, &agents_.maxSpeed);
            else if (r.parameter == "max_acceleration") apply(agents_.maxAcceleration, &AgentSpec::maxAcceleration, nullptr);
            lastAgentValue_[static_cast<std::size_t>(ramp.column)] = v;
        } else {
            for (Component* c : ramp.components) c->setParameter(r.parameter, v);
            for (int p : ramp.policies) health_.params(static_cast<std::size_t>(p)).set(r.parameter, v);
        }
    }
}

std::vector<double> Simulation::scheduleValues() const {
    std::vector<double> out;
    for (std::size_t c = 0; c < scheduleColumns_.size(); ++c) {
        const Ramp& ramp = ramps_[static_cast<std::size_t>(columnRamp_[c])];
        const RampSpec& r = ramp.spec;
        double v = std::numeric_limits<double>::quiet_NaN();
        if (r.target == RampSpec::Target::Agents) {
            const std::vector<double>* column = r.parameter == "pref_speed"   ? &agents_.basePrefSpeed
                                                : r.parameter == "max_speed" ? &agents_.baseMaxSpeed
                                                                             : &agents_.maxAcceleration;
            if (!column->empty()) {
                double sum = 0;
                for (double x : *column) sum += x;
                v = sum / static_cast<double>(column->size());
                lastAgentValue_[c] = v;
            } else {
                v = lastAgentValue_[c];
            }
        } else if (!ramp.components.empty()) {
            v = ramp.components.front()->parameter(r.parameter);
        } else if (!ramp.policies.empty()) {
            v = health_.params(static_cast<std::size_t>(ramp.policies.front())).get(r.parameter);
        }
        out.push_back(v);
    }
    return out;
}

StepContext Simulation::contextFor(const PolicyStep& s) const {
    const double dt = s.timing() == StepTiming::Coarse ? dtCoarse_ : dtFine_;
    return StepContext{agents_, world_, grid_, dt, time(), fineSteps_, spec_.seed, s.spec().relaxationTime, &lists_, maxRadius_};
}

void Simulation::setPreferredVelocities() {
    // Part of the frozen state of this step: towards the goal at preferred speed, 0 at the goal.
    const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(agents_.size());
    if (navigation_) {
        // Along the path to the current target (crowdhealth/navigation/navigation.h).
        const double t = time();
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(n)))
        for (std::ptrdiff_t ii = 0; ii < n; ++ii)
            agents_.prefVel[static_cast<std::size_t>(ii)] = navigation_->preferred(agents_, static_cast<std::size_t>(ii), t);
        return;
    }
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(n)))
    for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        agents_.prefVel[i] = agents_.atGoal(i) ? Vec2(0, 0)
                                               : Vec2(normalisedOrZero(agents_.goal[i] - agents_.pos[i]) *
                                                      agents_.prefSpeed[i]);
    }
}

Vec2 Simulation::symmetryJitter(std::size_t i) const {
    // Exactly symmetric scenarios (agents on a circle, mirror-image crossings) stay symmetric in
    // double precision, and some models then deadlock for ever; UMANS' single precision breaks the
    // tie with rounding noise (a float position a few metres from the origin is rounded by up to
    // ~5e-7 m every step). Here an agent that is held up — it wants to walk (has a preferred
    // velocity) but moves slower than half its preferred speed — has its new position moved by a
    // point uniform in a disc of radius ε, drawn from (seed, agent id, fine step): no shared state,
    // so the same bits with any thread count or agent order. Agents walking freely are left
    // exactly as they are, so a symmetric encounter that resolves by itself (a head-on pair that
    // both step aside) stays symmetric, as in UMANS, whose rounding is exact under negation.
    // Most of a dense crowd is held up, so the draw is cheap: one mix for the step's key (the
    // same for every agent: hoisted out of integrate's loop), one 64-bit draw per agent read as
    // a point of the square kept when inside the disc (uniformInUnitDisc, crowdhealth/core/rng.h).
    const double eps = spec_.symmetryBreaking;
    if (!(eps > 0) || agents_.prefVel[i].squaredNorm() == 0) return Vec2(0, 0);
    const double slow = kHeldUpFraction * agents_.prefSpeed[i];
    if (agents_.vel[i].squaredNorm() >= slow * slow) return Vec2(0, 0);
    const std::uint64_t key = drawKey(spec_.seed, kStreamSymmetry, fineSteps_);
    return eps * uniformInUnitDisc(key, static_cast<std::uint64_t>(agents_.id[i]));
}

void Simulation::evaluateAgents(bool coarseBoundary) {
    const std::size_t n = agents_.size();
    // The largest radius bounds the reach of UMANS' contact (umansContactAcceleration); NaN radii
    // never touch, and with none finite the bound is −inf (the filter then keeps every entry).
    // Only where some policy has that contact: the scan reads every agent's radius on one thread.
    double maxRadius = -std::numeric_limits<double>::infinity();
    if (anyUmansContact_)
        for (const double r : agents_.radius) maxRadius = r > maxRadius ? r : maxRadius;
    if (listScratch_.size() < static_cast<std::size_t>(omp_get_max_threads()))
        listScratch_.resize(static_cast<std::size_t>(omp_get_max_threads()));
#pragma omp parallel if (parallelNeighbourLoop(n))
    {
        AgentQuery q;  // per thread, on its own stack (no shared cache lines); its spans allocate nothing
        NeighbourLists::Scratch& scratch = listScratch_[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const Policy& policy = policies_[agents_.policy[i]];
            gatherQuery(i, q, scratch, queryAgents_[agents_.policy[i]] != 0);

            Vec2 fine(0, 0);
            Vec2 reported(0, 0);  // contact accelerations reported by components (contactField)
            bool stop = false;
            const bool atGoal = agents_.prefVel[i].squaredNorm() == 0;
            if (coarseBoundary && anyCoarseStep_) heldAccel_[i] = Vec2(0, 0);
            for (const PolicyStep& s : policy.steps()) {
                if (atGoal && s.spec().stopAtGoal) {
                    stop = true;
                    continue;
                }
                // A blended step (StepSpec::blend) counts with its per-agent weight; weight 0
                // skips it. A coarse step's weight is taken with its acceleration and held.
                const double w = s.weight(i);
                if (!(w > 0)) continue;
                if (s.timing() == StepTiming::Coarse) {
                    if (coarseBoundary) heldAccel_[i] += w * s.acceleration(q, contextFor(s));
                } else {
                    fine += w * s.acceleration(q, contextFor(s));
                }
                for (const auto& e : s.components())
                    if (const std::vector<Vec2>* f = e.component->contactField(); f != nullptr && i < f->size())
                        reported += w * e.coeff * (*f)[i];
            }
            Vec2 contact(0, 0);
            if (policy.contactForceScale() > 0) contact = umansContactAcceleration(q, policy.contactForceScale(), maxRadius);
            fineAccel_[i] = fine;
            stopped_[i] = stop ? 1 : 0;
            if (anyUmansContact_) umansContact_[i] = contact;
            nextContact_[i] = contact + reported;
        }
    }
}

void Simulation::integrate() {
    const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(agents_.size());
    const bool anyFallen = health_.anyFallen();
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(n)))
    for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        if (anyFallen && health_.isFallen(agents_, i)) {
            // A body on the floor (CrowdHealth falls) lies still: an obstacle the others avoid.
            agents_.vel[i] = Vec2(0, 0);
            continue;
        }
        // Zeros stand for the buffers no policy needs, so the sums are those of the full formula.
        const Vec2 held = anyCoarseStep_ ? heldAccel_[i] : Vec2(0, 0);
        const Vec2 umans = anyUmansContact_ ? umansContact_[i] : Vec2(0, 0);
        Vec2 v(0, 0);
        if (!stopped_[i]) {
            const Vec2 a = clampLength(held + fineAccel_[i], agents_.maxAcceleration[i]);
            v = clampLength(agents_.vel[i] + a * dtFine_, agents_.maxSpeed[i]);
        }
        v += umans * dtFine_;
        // The jitter reads the velocity of the step's start: drawn before it is overwritten.
        const Vec2 jitter = symmetryJitter(i);
        agents_.vel[i] = v;
        agents_.pos[i] = world_.wrap(agents_.pos[i] + v * dtFine_ + jitter);
        // UMANS' viewing direction: mostly the velocity, partly the preferred velocity.
        const Vec2 look = (2.0 * v + agents_.prefVel[i]) / 3.0;
        if (look.squaredNorm() > 0.01) agents_.viewDir[i] = look.normalized();
    }
}

void Simulation::reorderAgents() {
    // Cell order keeps neighbours close in memory: the per-pair reads of a step (positions,
    // masses, densities of neighbours) then hit cache lines already loaded. Agents that join
    // later are appended; the next re-ordering places them.
    const std::vector<int>& order = grid_.order();
    const std::size_t n = agents_.size();
    if (order.size() != n) return;
    bool sorted = true;
    for (std::size_t k = 0; k < n && sorted; ++k) sorted = order[k] == static_cast<int>(k);
    if (sorted) return;
    // The grid's own order (no copy, 4 MB at a million agents): nothing below builds the grid
    // again until every column has moved.
    const std::vector<int>& previous = order;
    agents_.permute(previous);
    followAgents(previous);
    health_.follow(agents_);
    grid_.build(agents_.pos, gridCell_, world_.periodic(), spec_.world.width, spec_.world.height);
}

void Simulation::removeFinished() {
    const std::size_t n = agents_.size();
    std::vector<unsigned char>& remove = remove_;
    remove.resize(n);
    exitOf_.resize(n);
    const double t = time();
    const std::size_t firstNew = evacuations_.size();
    const bool anyFallen = health_.anyFallen();
    // Who leaves, in parallel (reads only): 1 through an exit or at the goal, 2 out of the world.
    // The events are then written in agent order, as a single loop would (issue 20: the scan was
    // a serial 3 % of the dense 10k step on two threads).
    bool any = false;
    const std::ptrdiff_t count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static) reduction(|| : any) if (parallelCheapLoop(n))
    for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        remove[i] = 0;
        // Someone on the floor (CrowdHealth falls) leaves only once up again.
        if (anyFallen && health_.isFallen(agents_, i)) continue;
        // A journey ends in an exit (crowdhealth/navigation/navigation.h); a plain goal as in UMANS.
        const int exit = navigation_ && agents_.journey[i] >= 0 ? navigation_->leaves(agents_, i) : -1;
        const bool leaves = navigation_ && agents_.journey[i] >= 0
                                ? exit >= 0
                                : agents_.removeAtGoal[i] && agents_.hasGoal[i] && agents_.atGoal(i);
        exitOf_[i] = exit;
        if (leaves) remove[i] = 1;
        else if (!world_.inside(agents_.pos[i])) remove[i] = 2;
        any = any || remove[i] != 0;
    }
    if (any) {
        for (std::size_t i = 0; i < n; ++i) {
            if (remove[i] == 1) {
                evacuations_.push_back(Evacuation{agents_.id[i], t, exitOf_[i]});
                removed_.push_back(Removal{agents_.id[i], t, agents_.pos[i]});
                health_.markExit(agents_, i, t);
            } else if (remove[i] == 2) {
                ++leftWorld_;
                removed_.push_back(Removal{agents_.id[i], t, agents_.pos[i]});
            }
        }
    }
    // Agents leaving at the same step are listed by id, whatever their order in the store.
    std::sort(evacuations_.begin() + static_cast<std::ptrdiff_t>(firstNew), evacuations_.end(),
              [](const Evacuation& a, const Evacuation& b) { return a.id < b.id; });
    if (any) {
        agents_.removeMarked(remove);
        std::vector<int> previous;
        previous.reserve(n);
        for (std::size_t r = 0; r < n; ++r)
            if (!remove[r]) previous.push_back(static_cast<int>(r));
        followAgents(previous);
    }
}

std::vector<double> measureDensity(const std::vector<Vec2>& positions, const std::vector<double>& masses,
                                   const World& world, double h) {
    std::vector<double> density;
    measureDensity(positions, masses, world, h, density);
    return density;
}

void measureDensity(const std::vector<Vec2>& positions, const std::vector<double>& masses, const World& world,
                    double h, std::vector<double>& density) {
    const std::size_t n = positions.size();
    density.assign(n, 0.0);
    // A grid of its own, for the metrics' every record (the step's has other cells, and a sum in
    // another order would differ in the last bits), without a copy of the positions: 8 bytes
    // per agent instead of 24, besides the cells (at a million agents the metrics row's grid was
    // the largest block of the heap, issue 20).
    PointGrid grid;
    grid.keepPositions(false);
    grid.build(positions, h, world.periodic(), world.spec().width, world.spec().height);
    const PointGrid& walls = world.particleGrid();
    const bool hasWalls = !world.boundaryParticles().empty();
#pragma omp parallel for schedule(static) if (parallelNeighbourLoop(n))
    for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        double rho = 0;  // includes the agent itself (j = i, r = 0)
        grid.forEachWithin(positions[i], h, [&](int j, const Vec2&, double d2) {
            rho += masses[static_cast<std::size_t>(j)] * kernels::poly6(d2, h);
        });
        if (hasWalls)
            walls.forEachWithin(positions[i], h, [&](int, const Vec2&, double d2) { rho += kernels::poly6(d2, h); });
        density[i] = rho;
    }
}

void Simulation::measureDensity(double h) {
    ch::measureDensity(agents_.pos, agents_.mass, world_, h, agents_.density);
}

void Simulation::setPrefSpeed(double speed) {
    for (double& v : agents_.prefSpeed) v = speed;
    for (double& v : agents_.basePrefSpeed) v = speed;  // the CrowdHealth layer derives prefSpeed from it
    for (AgentSpec& a : spec_.agents) a.prefSpeed = speed;
}

double Simulation::maxWallPenetration() const {
    // Depth by which an agent's disc reaches into a wall: r − d for a centre outside at distance d
    // from the nearest wall, r + d for a centre inside an obstacle (d = distance to that
    // obstacle's nearest edge, i.e. the shortest way out).
    // (Inside overlapping obstacles, the lowest-numbered one counts.)
    double worst = 0;
    std::vector<int> near;
    const auto& segments = world_.segments();
    for (std::size_t i = 0; i < agents_.size(); ++i) {
        const Vec2& p = agents_.pos[i];
        const double r = agents_.radius[i];
        if (const int o = world_.obstacleAt(p); o >= 0) {
            double dmin = kInf;
            for (const Segment& seg : world_.segmentsOf(o)) dmin = std::min(dmin, std::sqrt(distanceToSegmentSquared(p, seg.a, seg.b)));
            worst = std::max(worst, r + dmin);
            continue;
        }
        world_.segmentsNear(p, r, near);
        for (int s : near) {
            const Segment& seg = segments[s];
            worst = std::max(worst, r - std::sqrt(distanceToSegmentSquared(p, seg.a, seg.b)));
        }
    }
    return worst;
}

}  // namespace ch
