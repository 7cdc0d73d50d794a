// CrowdHealth — the simulation loop (see simulation.h for the order of phases).
#include "crowdhealth/simulation.h"

#include "crowdhealth/kernels.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace ch {

namespace {
int finePerCoarseOf(const ScenarioSpec& s) {
    const double ratio = s.deltaTime / s.fineStep();
    return std::max(1, static_cast<int>(std::lround(ratio)));
}
}  // namespace

Simulation::Simulation(const ScenarioSpec& spec)
    : spec_(spec),
      world_(spec.world, spec.obstacles),
      dtCoarse_(spec.deltaTime),
      dtFine_(spec.fineStep()),
      finePerCoarse_(finePerCoarseOf(spec)),
      endTime_(spec.endTime) {
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

    // Neighbourhood radius per policy: its largest component range, and at least the contact reach.
    maxRadius_ = maxRadius;
    for (const Policy& p : policies_) {
        double r = 2 * maxRadius;
        for (const PolicyStep& s : p.steps()) r = std::max(r, s.interactionRange());
        policyRange_.push_back(r);
        maxRange_ = std::max(maxRange_, r);
    }

    pending_.resize(spec.agents.size());
    for (std::size_t k = 0; k < pending_.size(); ++k) pending_[k] = k;
    std::stable_sort(pending_.begin(), pending_.end(), [&](std::size_t a, std::size_t b) {
        return spec.agents[a].startTime < spec.agents[b].startTime;
    });
    activatePending();
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
    while (nextPending_ < pending_.size() && spec_.agents[pending_[nextPending_]].startTime <= now) {
        const std::size_t k = pending_[nextPending_++];
        agents_.add(spec_.agents[k], agentPolicy_[k]);
    }
    if (agents_.size() != before) {
        std::vector<int> previous(agents_.size(), -1);
        for (std::size_t i = 0; i < before; ++i) previous[i] = static_cast<int>(i);
        heldAccel_.resize(agents_.size(), Vec2(0, 0));
        remapComponents(previous);
    }
}

void Simulation::remapComponents(const std::vector<int>& previous) {
    for (Policy& p : policies_)
        for (PolicyStep& s : p.steps())
            for (auto& e : s.components()) e.component->remapAgents(previous);
}

void Simulation::stepCoarse() {
    for (int k = 0; k < finePerCoarse_; ++k) stepFine();
}

void Simulation::gatherQuery(std::size_t i, double range, AgentQuery& q) const {
    q.i = static_cast<int>(i);
    q.position = agents_.pos[i];
    q.velocity = agents_.vel[i];
    q.prefVelocity = agents_.prefVel[i];
    q.radius = agents_.radius[i];
    q.prefSpeed = agents_.prefSpeed[i];
    q.maxSpeed = agents_.maxSpeed[i];
    q.maxAcceleration = agents_.maxAcceleration[i];
    q.mass = agents_.mass[i];
    q.agents.clear();
    grid_.forEachWithin(q.position, range, [&](int j, const Vec2& d, double d2) {
        if (j != q.i) q.agents.push_back(NeighbourAgent{j, d, std::sqrt(d2)});
    });
    world_.segmentsNear(q.position, range, q.segments);
}

Vec2 Simulation::umansContactAcceleration(const AgentQuery& q, double scale) const {
    // UMANS' contact model: a spring along the centre line for every overlap, applied after the
    // acceleration clamp. `scale` is a stiffness per unit mass (1/s²).
    Vec2 acc(0, 0);
    for (const NeighbourAgent& n : q.agents) {
        const double overlap = q.radius + agents_.radius[n.index] - n.distance;
        if (overlap > 0 && n.distance > 1e-12) acc -= n.offset / n.distance * (scale * overlap);
    }
    for (int s : q.segments) {
        const Segment& seg = world_.segments()[s];
        const Vec2 diff = q.position - closestPointOnSegment(q.position, seg.a, seg.b);
        const double d = diff.norm();
        const double overlap = q.radius - d;
        if (overlap > 0 && d > 1e-12) acc += diff / d * (scale * overlap);
    }
    return acc / q.mass;
}

void Simulation::stepFine() {
    activatePending();
    const std::size_t n = agents_.size();
    const bool coarseBoundary = fineSteps_ % static_cast<std::uint64_t>(finePerCoarse_) == 0;

    grid_.build(agents_.pos, maxRange_, world_.periodic(), spec_.world.width, spec_.world.height);

    // Preferred velocities (part of the frozen state of this step).
    for (std::size_t i = 0; i < n; ++i)
        agents_.prefVel[i] = agents_.atGoal(i) ? Vec2(0, 0)
                                               : Vec2(normalisedOrZero(agents_.goal[i] - agents_.pos[i]) *
                                                      agents_.prefSpeed[i]);

    const double t = time();
    auto contextFor = [&](const PolicyStep& s) {
        const double dt = s.timing() == StepTiming::Coarse ? dtCoarse_ : dtFine_;
        return StepContext{agents_, world_, grid_, dt, t, fineSteps_, spec_.seed, s.spec().relaxationTime};
    };
    for (Policy& p : policies_)
        for (PolicyStep& s : p.steps())
            if (s.timing() == StepTiming::Fine || coarseBoundary) s.prepare(contextFor(s));

    heldAccel_.resize(n, Vec2(0, 0));
    nextPos_.resize(n);
    nextVel_.resize(n);
    nextView_.resize(n);
    nextContact_.resize(n);

#pragma omp parallel
    {
        AgentQuery q;  // per thread, reused
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const Policy& policy = policies_[agents_.policy[i]];
            gatherQuery(i, policyRange_[agents_.policy[i]], q);

            Vec2 fine(0, 0);
            Vec2 reported(0, 0);  // contact accelerations reported by components (contactField)
            bool stop = false;
            const bool atGoal = agents_.prefVel[i].squaredNorm() == 0;
            if (coarseBoundary) heldAccel_[i] = Vec2(0, 0);
            for (const PolicyStep& s : policy.steps()) {
                if (atGoal && s.spec().stopAtGoal) {
                    stop = true;
                    continue;
                }
                if (s.timing() == StepTiming::Coarse) {
                    if (coarseBoundary) heldAccel_[i] += s.acceleration(q, contextFor(s));
                } else {
                    fine += s.acceleration(q, contextFor(s));
                }
                for (const auto& e : s.components())
                    if (const std::vector<Vec2>* f = e.component->contactField(); f != nullptr && i < f->size())
                        reported += e.coeff * (*f)[i];
            }

            Vec2 v(0, 0);
            if (!stop) {
                const Vec2 a = clampLength(heldAccel_[i] + fine, agents_.maxAcceleration[i]);
                v = clampLength(agents_.vel[i] + a * dtFine_, agents_.maxSpeed[i]);
            }
            Vec2 contact(0, 0);
            if (policy.contactForceScale() > 0) contact = umansContactAcceleration(q, policy.contactForceScale());
            v += contact * dtFine_;

            nextVel_[i] = v;
            nextPos_[i] = world_.wrap(agents_.pos[i] + v * dtFine_);
            nextContact_[i] = contact + reported;
            // UMANS' viewing direction: mostly the velocity, partly the preferred velocity.
            const Vec2 look = (2.0 * v + agents_.prefVel[i]) / 3.0;
            nextView_[i] = look.squaredNorm() > 0.01 ? Vec2(look.normalized()) : agents_.viewDir[i];
        }
    }

    std::swap(agents_.pos, nextPos_);
    std::swap(agents_.vel, nextVel_);
    std::swap(agents_.viewDir, nextView_);
    std::swap(agents_.contactAccel, nextContact_);
    ++fineSteps_;
    removeFinished();
}

void Simulation::removeFinished() {
    const std::size_t n = agents_.size();
    std::vector<unsigned char> remove(n, 0);
    bool any = false;
    const double t = time();
    for (std::size_t i = 0; i < n; ++i) {
        if (agents_.removeAtGoal[i] && agents_.hasGoal[i] && agents_.atGoal(i)) {
            remove[i] = 1;
            evacuations_.push_back(Evacuation{agents_.id[i], t});
            any = true;
        } else if (!world_.inside(agents_.pos[i])) {
            remove[i] = 1;
            ++leftWorld_;
            any = true;
        }
    }
    if (any) {
        agents_.removeMarked(remove);
        // Keep the held coarse accelerations aligned with the surviving agents.
        std::size_t w = 0;
        std::vector<int> previous;
        previous.reserve(n);
        for (std::size_t r = 0; r < n; ++r)
            if (!remove[r]) {
                heldAccel_[w++] = heldAccel_[r];
                previous.push_back(static_cast<int>(r));
            }
        heldAccel_.resize(w);
        remapComponents(previous);
    }
}

void Simulation::measureDensity(double h) {
    const std::size_t n = agents_.size();
    PointGrid grid;
    grid.build(agents_.pos, h, world_.periodic(), spec_.world.width, spec_.world.height);
    const PointGrid& walls = world_.particleGrid();
    const bool hasWalls = !world_.boundaryParticles().empty();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        double rho = 0;  // includes the agent itself (j = i, r = 0)
        grid.forEachWithin(agents_.pos[i], h, [&](int j, const Vec2&, double d2) {
            rho += agents_.mass[j] * kernels::poly6(d2, h);
        });
        if (hasWalls)
            walls.forEachWithin(agents_.pos[i], h, [&](int, const Vec2&, double d2) { rho += kernels::poly6(d2, h); });
        agents_.density[i] = rho;
    }
}

double Simulation::maxWallPenetration() const {
    // Depth by which an agent's disc reaches into a wall: r − d for a centre outside at distance d
    // from the nearest wall, r + d for a centre inside an obstacle (d = distance to that
    // obstacle's nearest edge, i.e. the shortest way out).
    double worst = 0;
    std::vector<int> near;
    const auto& obstacles = world_.obstacles();
    const auto& segments = world_.segments();
    for (std::size_t i = 0; i < agents_.size(); ++i) {
        const Vec2& p = agents_.pos[i];
        const double r = agents_.radius[i];
        world_.segmentsNear(p, r, near);
        bool inside = false;
        for (std::size_t o = 0; o < obstacles.size() && !inside; ++o) {
            if (obstacles[o].points.size() < 3 || !pointInPolygon(p, obstacles[o].points)) continue;
            inside = true;
            double dmin = kInf;
            for (const Segment& seg : segments)
                if (seg.obstacle == static_cast<int>(o))
                    dmin = std::min(dmin, std::sqrt(distanceToSegmentSquared(p, seg.a, seg.b)));
            worst = std::max(worst, r + dmin);
        }
        if (inside) continue;
        for (int s : near) {
            const Segment& seg = segments[s];
            worst = std::max(worst, r - std::sqrt(distanceToSegmentSquared(p, seg.a, seg.b)));
        }
    }
    return worst;
}

}  // namespace ch
