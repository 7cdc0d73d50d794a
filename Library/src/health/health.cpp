// CrowdHealth — the CrowdHealth layer (see health.h and docs/crowd-health.md).
#include "crowdhealth/health/health.h"

#include "crowdhealth/io/output.h"
#include "crowdhealth/core/cpu_features.h"
#include "crowdhealth/core/parallel.h"
#include "crowdhealth/core/rng.h"
#include "crowdhealth/core/simd.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <unordered_map>

// simd::DV (four doubles) passes by value between inlined helpers only: no call crosses an ABI.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace ch {

namespace {
/// Below this speed (m/s) an agent's heading is not defined (standing, jitter).
constexpr double kHeadingSpeed = 0.1;

ParamSpec positive(ParamSpec p) {
    p.minExclusive = true;
    return p;
}
}  // namespace

const ParamTable& crowdHealthTable() {
    static const ParamTable t = [] {
        const HealthParams d;
        return ParamTable{
            positive(ParamSpec::real("bodyMass", "kg", d.bodyMass, 0, 500,
                                     "body mass of an agent of mass factor 1; force = bodyMass * mass * |a_contact|")),
            ParamSpec::real("crushThreshold", "N", d.crushThreshold, 0, 1e6,
                            "contact force above which time and dose accumulate (Fruin 1993: 4500 N on bent railings)"),
            positive(ParamSpec::real("injuryDose", "N s", d.injuryDose, 0, 1e12,
                                     "dose (integral of the force while above the threshold) at which an agent is injured")),
            ParamSpec::boolean("injuryEffect", d.injuryEffect, "injured agents slow down (the factors below)"),
            ParamSpec::real("injuredSpeedFactor", "-", d.injuredSpeedFactor, 0, 1,
                            "preferred speed of an injured agent, as a fraction of its own"),
            ParamSpec::real("injuredMaxSpeedFactor", "-", d.injuredMaxSpeedFactor, 0, 1,
                            "maximum speed of an injured agent, as a fraction of its own"),
            ParamSpec::real("panic", "-", d.panic, 0, 1,
                            "scheduled panic: every agent of the policy has at least this level (ramp it)"),
            ParamSpec::real("panicDecay", "1/s", d.panicDecay, 0, 1e3, "panic decays as dP/dt = -panicDecay * P"),
            ParamSpec::real("contagionRate", "1/s", d.contagionRate, 0, 1e3,
                            "dP/dt = contagionRate * (P_max - P) from the most panicked neighbour"),
            ParamSpec::real("contagionRadius", "m", d.contagionRadius, 0, 10,
                            "distance between centres within which panic spreads"),
            ParamSpec::real("contagionThreshold", "-", d.contagionThreshold, 0, 1,
                            "a neighbour spreads panic only from this level on"),
            ParamSpec::boolean("panicSpeedEffect", d.panicSpeedEffect,
                               "panic raises the preferred speed towards panicSpeed (the paper's panic encoding)"),
            ParamSpec::real("panicSpeed", "m/s", d.panicSpeed, 0, 20,
                            "preferred speed at panic 1: v_pref = v + P * max(0, panicSpeed - v)"),
            ParamSpec::boolean("erratic", d.erratic, "panic adds noise to the preferred direction"),
            ParamSpec::real("erraticAngle", "deg", d.erraticAngle, 0, 180,
                            "standard deviation of the direction noise at panic 1 (scales with P)"),
            positive(ParamSpec::real("erraticInterval", "s", d.erraticInterval, 0, 60,
                                     "a noise angle is held for this long")),
            ParamSpec::boolean("herding", d.herding, "panic turns the preferred direction towards the neighbours' headings"),
            ParamSpec::real("herdingWeight", "-", d.herdingWeight, 0, 1,
                            "Helbing et al. 2000's herding p at panic 1: e = norm((1 - p P) e_goal + p P <e_j>)"),
            positive(ParamSpec::real("herdingRadius", "m", d.herdingRadius, 0, 10,
                                     "neighbours within this distance count for herding")),
            ParamSpec::boolean("falls", d.falls,
                               "agents fall under a crush dose of fallDose: they lie still as an obstacle until they get up"),
            positive(ParamSpec::real("fallDose", "N s", d.fallDose, 0, 1e12,
                                     "dose at which an agent falls (and again at each further multiple of it); falling injures")),
            ParamSpec::real("getUpTime", "s", d.getUpTime, 0, 1e9,
                            "time a fallen agent lies on the floor when nobody helps it"),
            ParamSpec::real("fallenRadius", "m", d.fallenRadius, 0.1, 1.5,
                            "radius of the body on the floor (grows from the standing radius over 1 s; not rampable)"),
            ParamSpec::boolean("helping", d.helping,
                               "agents of this policy help injured and fallen people (of their group, or strangers nearby)"),
            ParamSpec::real("helpGroup", "-", d.helpGroup, 0, 1,
                            "probability that an agent helps an injured or fallen member of its own group"),
            ParamSpec::real("helpStranger", "-", d.helpStranger, 0, 1,
                            "probability that an agent within helpRadius helps an injured or fallen stranger (one at a time)"),
            ParamSpec::real("helpRadius", "m", d.helpRadius, 0, 20,
                            "distance within which a stranger notices an injured or fallen person"),
            ParamSpec::real("helpTime", "s", d.helpTime, 0, 1e6,
                            "a helper stands this long beside a fallen person, who then gets up, and both leave"),
            positive(ParamSpec::real("escortDistance", "m", d.escortDistance, 0, 10,
                                     "a helper walks with the person it helps, catching up beyond this distance")),
        };
    }();
    return t;
}

HealthParams HealthParams::from(const ParamSet& v, bool effects) {
    HealthParams p;
    for (const ParamSpec& s : crowdHealthTable())
        if (s.type == ParamType::Real && v.has(s.name)) p.set(s.name, v.get(s.name));
    // Bool switches are not rampable (set() refuses them): read them here.
    auto flag = [&](const char* name, bool def) { return v.has(name) ? v.flag(name) : def; };
    p.injuryEffect = effects && flag("injuryEffect", p.injuryEffect);
    p.panicSpeedEffect = effects && flag("panicSpeedEffect", p.panicSpeedEffect);
    p.erratic = effects && flag("erratic", p.erratic);
    p.herding = effects && flag("herding", p.herding);
    p.falls = effects && flag("falls", p.falls);
    p.helping = effects && flag("helping", p.helping);
    if (v.has("fallenRadius")) p.fallenRadius = v.get("fallenRadius");  // not rampable: not in set()
    return p;
}

namespace {
template <class F>
bool visitReal(HealthParams& p, const std::string& name, F&& f) {
    struct Entry { const char* name; double HealthParams::*member; };
    static const Entry entries[] = {
        {"bodyMass", &HealthParams::bodyMass},
        {"crushThreshold", &HealthParams::crushThreshold},
        {"injuryDose", &HealthParams::injuryDose},
        {"injuredSpeedFactor", &HealthParams::injuredSpeedFactor},
        {"injuredMaxSpeedFactor", &HealthParams::injuredMaxSpeedFactor},
        {"panic", &HealthParams::panic},
        {"panicDecay", &HealthParams::panicDecay},
        {"contagionRate", &HealthParams::contagionRate},
        {"contagionRadius", &HealthParams::contagionRadius},
        {"contagionThreshold", &HealthParams::contagionThreshold},
        {"panicSpeed", &HealthParams::panicSpeed},
        {"erraticAngle", &HealthParams::erraticAngle},
        {"erraticInterval", &HealthParams::erraticInterval},
        {"herdingWeight", &HealthParams::herdingWeight},
        {"herdingRadius", &HealthParams::herdingRadius},
        {"fallDose", &HealthParams::fallDose},
        {"getUpTime", &HealthParams::getUpTime},
        {"helpGroup", &HealthParams::helpGroup},
        {"helpStranger", &HealthParams::helpStranger},
        {"helpRadius", &HealthParams::helpRadius},
        {"helpTime", &HealthParams::helpTime},
        {"escortDistance", &HealthParams::escortDistance},
    };
    for (const Entry& e : entries)
        if (name == e.name) {
            f(p.*(e.member));
            return true;
        }
    return false;
}
}  // namespace

bool HealthParams::set(const std::string& name, double value) {
    return visitReal(*this, name, [&](double& m) { m = value; });
}

double HealthParams::get(const std::string& name) const {
    double out = std::numeric_limits<double>::quiet_NaN();
    visitReal(const_cast<HealthParams&>(*this), name, [&](double& m) { out = m; });
    if (name == "injuryEffect") return injuryEffect;
    if (name == "panicSpeedEffect") return panicSpeedEffect;
    if (name == "erratic") return erratic;
    if (name == "herding") return herding;
    if (name == "falls") return falls;
    if (name == "helping") return helping;
    if (name == "fallenRadius") return fallenRadius;
    return out;
}

void HealthLayer::init(const ScenarioSpec& spec) {
    records_.assign(spec.agents.size(), HealthRecord{});
    care_.clear();
    recordOfSpec_.resize(spec.agents.size());
    for (std::size_t k = 0; k < recordOfSpec_.size(); ++k) recordOfSpec_[k] = static_cast<int>(k);
    std::unordered_map<int, std::size_t> policyIndex;
    for (std::size_t p = 0; p < spec.policies.size(); ++p) policyIndex.emplace(spec.policies[p].id, p);
    for (std::size_t k = 0; k < spec.agents.size(); ++k) {
        records_[k].id = spec.agents[k].id;
        if (const auto it = policyIndex.find(spec.agents[k].policyId); it != policyIndex.end())
            records_[k].policy = static_cast<std::uint32_t>(it->second);
    }
    params_.clear();
    hasElement_.clear();
    for (const PolicySpec& p : spec.policies) {
        if (p.health) {
            params_.push_back(HealthParams::from(p.health->params, true));
            hasElement_.push_back(1);
        } else {
            params_.push_back(HealthParams::from(ParamSet(crowdHealthTable()), false));
            hasElement_.push_back(0);
        }
    }
    events_ = spec.panicEvents;
    eventFired_.assign(events_.size(), 0);
    crush_ = CrushSummary{};
    aboveByRecord_.assign(records_.size(), 0);
    thresholdAtEnd_.clear();
    ended_ = false;
    maxPanic_ = 0;
    falls_.clear();
    fallenNow_ = 0;
    anyCasualty_ = false;
    anyInjured_ = false;
    anyCare_ = false;
    for (const HealthParams& hp : params_) anyCare_ = anyCare_ || hp.falls || hp.helping;
}

double HealthLayer::largestFallenRadius(const ScenarioSpec& spec) {
    double r = 0;
    for (const PolicySpec& p : spec.policies)
        if (p.health) {
            const HealthParams hp = HealthParams::from(p.health->params, true);
            if (hp.falls) r = std::max(r, hp.fallenRadius);
        }
    return r;
}

void HealthLayer::activated(const AgentStore& agents, std::size_t i) { record(agents, i).seen = true; }

void HealthLayer::follow(AgentStore& agents) {
    const std::size_t total = records_.size(), n = agents.size();
    // newOf: old record index → new; the agents' records first, in agent order, the others after
    // them in their order.
    std::vector<int>& newOf = newOf_;
    newOf.assign(total, -1);
    int next = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const int old = agents.record[i];
        if (old < 0 || newOf[static_cast<std::size_t>(old)] >= 0) return;  // not one record per agent: leave as is
        newOf[static_cast<std::size_t>(old)] = next++;
    }
    for (std::size_t k = 0; k < total; ++k)
        if (newOf[k] < 0) newOf[k] = next++;
    for (int& r : recordOfSpec_) r = newOf[static_cast<std::size_t>(r)];
    // Moved in place, one cycle of the permutation at a time (each swap puts one record where it
    // belongs): no second copy of the records (128 bytes per agent), whose fresh pages the
    // kernel would have to fault in at every re-ordering.
    for (std::size_t k = 0; k < total; ++k)
        while (newOf[k] != static_cast<int>(k)) {
            const std::size_t to = static_cast<std::size_t>(newOf[k]);
            std::swap(records_[k], records_[to]);
            std::swap(newOf[k], newOf[to]);
        }
    for (std::size_t i = 0; i < n; ++i) agents.record[i] = static_cast<int>(i);
}

const HealthRecord& HealthLayer::recordOf(const AgentStore& agents, std::size_t i) const {
    return records_[static_cast<std::size_t>(agents.record[i])];
}

const unsigned char* HealthLayer::crushFlags() const {
    if (!ended_ || aboveByRecord_.size() != records_.size() || thresholdAtEnd_.size() != params_.size()) return nullptr;
    for (std::size_t p = 0; p < params_.size(); ++p)
        if (!(thresholdAtEnd_[p] == params_[p].crushThreshold)) return nullptr;
    return aboveByRecord_.data();
}

namespace {

/// The speeds in effect of agent i at this panic level: panic raises the preferred speed towards
/// panicSpeed, an injury lowers both (beginStep's quiet path calls it at panic 0, uninjured, and
/// so gets the same bits as the full path would).
void setSpeedsInEffect(AgentStore& agents, std::size_t i, const HealthParams& hp, double panic, bool injured) {
    double v = agents.basePrefSpeed[i];
    double vmax = agents.baseMaxSpeed[i];
    if (hp.panicSpeedEffect && hp.panicSpeed > v) v += panic * (hp.panicSpeed - v);
    if (hp.injuryEffect && injured) {
        v *= hp.injuredSpeedFactor;
        vmax *= hp.injuredMaxSpeedFactor;
    }
    agents.prefSpeed[i] = v;
    agents.maxSpeed[i] = vmax;
}

}  // namespace

void HealthLayer::beginStep(AgentStore& agents, const PointGrid& grid, double time, double dt) {
    const std::size_t n = agents.size();
    const std::ptrdiff_t count = static_cast<std::ptrdiff_t>(n);
    // The quiet step (the usual one): nobody panics (maxPanic_, the largest level of the last
    // step, is 0, and agents that joined since start at 0), no policy has a panic floor, no panic
    // event is due, and no injury slows anyone down. Every level then stays exactly +0 and the
    // peaks do not change, so the records need not be read: only the speeds in effect are set,
    // by the same function as below at panic 0 (the same bits).
    bool quiet = maxPanic_ == 0;
    for (const HealthParams& hp : params_) quiet = quiet && !(hp.panic > 0) && !(anyInjured_ && hp.injuryEffect);
    for (std::size_t e = 0; e < events_.size() && quiet; ++e)
        quiet = eventFired_[e] || events_[e].time > time + 0.5 * dt;
    if (quiet) {
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(count)))
        for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            setSpeedsInEffect(agents, i, params_[static_cast<std::size_t>(agents.policy[i])], 0.0, false);
        }
        maxPanic_ = 0;
        return;
    }
    nextPanic_.resize(n);
    // Contagion can only raise an agent towards a more panicked neighbour: while nobody panics
    // (the usual case) the neighbour search per agent is skipped. maxPanic_ is the largest level
    // of the previous step; agents that left since can only make it too high, which costs a
    // search but changes no result (a neighbour that raises p also passes the true maximum's test).
    const double maxPanic = maxPanic_;
    // Panic: each agent reads the frozen levels of the previous step, writes only its own.
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(count)))
    for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[i])];
        double p = record(agents, i).panic;
        if (hp.contagionRate > 0 && hp.contagionRadius > 0 && maxPanic > p && maxPanic >= hp.contagionThreshold) {
            double pmax = 0;
            grid.forEachWithin(agents.pos[i], hp.contagionRadius, [&](int j, const Vec2&, double) {
                if (static_cast<std::size_t>(j) == i) return;
                const double pj = record(agents, static_cast<std::size_t>(j)).panic;
                if (pj >= hp.contagionThreshold && pj > pmax) pmax = pj;
            });
            if (pmax > p) p += std::min(1.0, hp.contagionRate * dt) * (pmax - p);
        }
        p -= std::min(1.0, hp.panicDecay * dt) * p;
        p = std::max(p, hp.panic);
        nextPanic_[i] = std::clamp(p, 0.0, 1.0);
    }
    // Panic events due now (half a step of tolerance, as agents' start times).
    for (std::size_t e = 0; e < events_.size(); ++e) {
        if (eventFired_[e] || events_[e].time > time + 0.5 * dt) continue;
        eventFired_[e] = 1;
        const PanicEventSpec& ev = events_[e];
        for (std::size_t i = 0; i < n; ++i)
            if ((agents.pos[i] - ev.position).squaredNorm() <= ev.radius * ev.radius)
                nextPanic_[i] = std::max(nextPanic_[i], std::clamp(ev.strength, 0.0, 1.0));
    }
    double newMax = 0;
#pragma omp parallel for schedule(static) reduction(max : newMax) if (parallelCheapLoop(static_cast<std::size_t>(count)))
    for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        HealthRecord& r = record(agents, i);
        r.panic = nextPanic_[i];
        newMax = std::max(newMax, r.panic);
        r.peakPanic = std::max(r.peakPanic, r.panic);
        setSpeedsInEffect(agents, i, params_[static_cast<std::size_t>(agents.policy[i])], r.panic, r.injured());
    }
    maxPanic_ = newMax;
}

void HealthLayer::steerPreferred(AgentStore& agents, const PointGrid& grid, double time, std::uint64_t seed) const {
    const std::ptrdiff_t count = static_cast<std::ptrdiff_t>(agents.size());
    bool any = false;
    for (const HealthParams& hp : params_) any = any || hp.erratic || hp.herding;
    // Nobody panics (the largest level of this step's beginStep is 0): nothing turns.
    if (!any || !(maxPanic_ > 0)) return;
#pragma omp parallel for schedule(static) if (parallelCheapLoop(static_cast<std::size_t>(count)))
    for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
        const std::size_t i = static_cast<std::size_t>(ii);
        const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[i])];
        const double panic = record(agents, i).panic;
        const Vec2 pref = agents.prefVel[i];
        const double speed = pref.norm();
        if (!(panic > 0) || !(speed > 0)) continue;
        Vec2 dir = pref / speed;
        if (hp.herding) {
            // Helbing, Farkas & Vicsek 2000: e_i = norm((1 - p) e_i0 + p <e_j>), neighbours' headings.
            Vec2 sum(0, 0);
            grid.forEachWithin(agents.pos[i], hp.herdingRadius, [&](int j, const Vec2&, double) {
                if (static_cast<std::size_t>(j) == i) return;
                const Vec2& vj = agents.vel[static_cast<std::size_t>(j)];
                const double sj = vj.norm();
                if (sj > kHeadingSpeed) sum += vj / sj;
            });
            const double sn = sum.norm();
            if (sn > 0) {
                const double p = hp.herdingWeight * panic;
                const Vec2 mixed = (1 - p) * dir + p * (sum / sn);
                if (mixed.squaredNorm() > 1e-12) dir = mixed.normalized();
            }
        }
        if (hp.erratic && hp.erraticAngle > 0) {
            const auto interval = static_cast<std::uint64_t>(std::floor(time / hp.erraticInterval + 1e-9));
            Rng rng(seed, static_cast<std::uint64_t>(agents.id[i]), interval, kStreamPanic);
            dir = rotated(dir, rng.normal() * panic * hp.erraticAngle * kPi / 180.0);
        }
        agents.prefVel[i] = dir * speed;
    }
}

// Blocks [b0, b1) of simd::kLanes agents of endStep. Per block, the turns of its agents,
// atan2(|h₀ × h₁|, h₀ · h₁), in one call of simd::angleOf (glibc's atan2 one agent at a time was
// ~2 % of a 10k-agent social-forces run and of a dense SPH step; issue 20). Compiled twice, like
// the safety grid's scatter: with AVX2 where the CPU has it (angleOf's comparisons and selects
// are then whole-vector operations; in the SSE2 build GCC 12 compares lane by lane) and for any
// x86-64 otherwise, chosen when the program starts (endStepPath; crowdhealth-bench --isa);
// neither build fuses a multiply and an add, so both give the same bits.
[[gnu::always_inline]] inline bool HealthLayer::endStepBlocksBody(AgentStore& agents, double time, double dt,
                                                                  std::ptrdiff_t b0, std::ptrdiff_t b1) {
    constexpr int L = simd::kLanes;
    const std::size_t n = agents.size();
    bool anyAbove = false;
    for (std::ptrdiff_t bb = b0; bb < b1; ++bb) {
        // Lanes without a turn this step keep (|cross|, dot) = (0, 1): angle 0, not added.
        simd::DV turnY = simd::splat(0.0), turnX = simd::splat(1.0);
        HealthRecord* turning[L] = {};
        const std::size_t iEnd = std::min(n, static_cast<std::size_t>(bb + 1) * L);
        for (std::size_t i = static_cast<std::size_t>(bb) * L; i < iEnd; ++i) {
            HealthRecord& r = record(agents, i);
            const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[i])];
            const double a = agents.contactAccel[i].norm();
            const double force = hp.bodyMass * agents.mass[i] * a;
            r.lastForce = force;
            r.peakContactAccel = std::max(r.peakContactAccel, a);
            r.peakForce = std::max(r.peakForce, force);
            above_[i] = force > hp.crushThreshold ? 1 : 0;
            // The test of crushFlags(), with the record's policy as its readers write it. Every
            // active agent's byte is written here, after any follow() of this step: the bytes need
            // no moving.
            aboveByRecord_[static_cast<std::size_t>(agents.record[i])] = force > params_[r.policy].crushThreshold ? 1 : 0;
            if (above_[i]) {
                anyAbove = true;
                r.timeAboveThreshold += dt;
                r.dose += force * dt;
                if (!r.injured() && r.dose >= hp.injuryDose) r.injuredAt = time;
                // Cornes et al. 2017: under a high enough load a pedestrian falls and lies still;
                // here at each multiple of fallDose (after getting up, the next multiple fells it
                // again).
                // (Its CareRecord is filled in after this loop: making one may grow care_.)
                if (hp.falls && !r.fallen && r.dose >= hp.fallDose * static_cast<double>(r.falls + 1)) {
                    r.fallen = true;
                    ++r.falls;
                    if (!r.injured()) r.injuredAt = time;  // a fall injures
                    fellNow_[i] = 1;
                }
            }
            if (r.care >= 0) {  // a helper's own exposure while it helps
                CareRecord& c = care_[static_cast<std::size_t>(r.care)];
                if (c.helping >= 0) {
                    c.helpTime += dt;
                    if (above_[i]) c.helpDose += force * dt;
                }
            }
            const Vec2& v = agents.vel[i];
            const double s = v.norm();
            if (s > kHeadingSpeed) {
                const Vec2 h = v / s;
                if (r.lastHeading.squaredNorm() > 0) {
                    const double cross = r.lastHeading.x() * h.y() - r.lastHeading.y() * h.x();
                    const double dot = r.lastHeading.dot(h);
                    const std::size_t l = i % L;
                    turnY[l] = std::abs(cross);  // |atan2(cross, dot)| = atan2(|cross|, dot)
                    turnX[l] = dot;
                    turning[l] = &r;
                    r.movingTime += dt;
                }
                r.lastHeading = h;
            } else {
                r.lastHeading = Vec2(0, 0);
            }
        }
        const simd::DV turn = simd::angleOf(turnY, turnX);
        for (int l = 0; l < L; ++l)
            if (turning[l] != nullptr) turning[l]->headingChange += turn[l];
    }
    return anyAbove;
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define CH_HEALTH_X86 1
#endif

namespace {
/// endStepBlocks' build in use: 0 generic, 1 AVX2 (the best this CPU runs unless set).
std::atomic<int> gEndStepPath{cpu::runsBuild(1) ? 1 : 0};
}  // namespace

bool HealthLayer::endStepBlocksGeneric(AgentStore& agents, double time, double dt, std::ptrdiff_t b0,
                                       std::ptrdiff_t b1) {
    return endStepBlocksBody(agents, time, dt, b0, b1);
}

#ifdef CH_HEALTH_X86
__attribute__((target("avx2"))) bool HealthLayer::endStepBlocksAvx2(AgentStore& agents, double time, double dt,
                                                                    std::ptrdiff_t b0, std::ptrdiff_t b1) {
    return endStepBlocksBody(agents, time, dt, b0, b1);
}
#endif

bool HealthLayer::endStepBlocks(AgentStore& agents, double time, double dt, std::ptrdiff_t b0, std::ptrdiff_t b1) {
#ifdef CH_HEALTH_X86
    if (gEndStepPath.load(std::memory_order_relaxed) == 1) return endStepBlocksAvx2(agents, time, dt, b0, b1);
#endif
    return endStepBlocksGeneric(agents, time, dt, b0, b1);
}

int HealthLayer::endStepPath() { return gEndStepPath.load(); }

bool HealthLayer::setEndStepPath(int path) {
    if (path < 0 || path > 1 || !cpu::runsBuild(path)) return false;
    gEndStepPath.store(path);
    return true;
}

void HealthLayer::endStep(AgentStore& agents, double time, double dt) {
    const std::size_t n = agents.size();
    const std::ptrdiff_t count = static_cast<std::ptrdiff_t>(n);
    above_.resize(n);
    aboveByRecord_.resize(records_.size(), 0);
    thresholdAtEnd_.resize(params_.size());
    for (std::size_t p = 0; p < params_.size(); ++p) thresholdAtEnd_[p] = params_[p].crushThreshold;
    ended_ = true;
    if (anyCare_) fellNow_.assign(n, 0);
    // Per agent, in parallel: each iteration writes only its own record, flag and radius. The
    // blocks are shared out as schedule(static) would, each thread's share in one call of
    // endStepBlocks (compiled twice: see there).
    constexpr int L = simd::kLanes;
    const std::ptrdiff_t blocks = (count + L - 1) / L;
    bool someAbove = false;
#pragma omp parallel reduction(|| : someAbove) if (parallelCheapLoop(static_cast<std::size_t>(count)))
    {
        const std::ptrdiff_t t = omp_get_thread_num(), threads = omp_get_num_threads();
        someAbove = endStepBlocks(agents, time, dt, blocks * t / threads, blocks * (t + 1) / threads);
    }
    // The crowd-level crush summary in agent order (sums in a fixed order: thread-count independent).
    // Injuries happen only above the threshold: anyInjured_ is kept here. Only when someone is
    // above it: the flags of the other thread's agents, read here, would otherwise cross the
    // cores at every step only to be written there again at the next (issue 20).
    bool anyAbove = false;
    for (std::size_t i = 0; someAbove && i < n; ++i) {
        if (!above_[i]) continue;
        if (!anyInjured_ && record(agents, i).injured()) anyInjured_ = true;
        const Vec2& x = agents.pos[i];
        if (crush_.samples == 0) {
            crush_.xmin = crush_.xmax = x.x();
            crush_.ymin = crush_.ymax = x.y();
        }
        crush_.xmin = std::min(crush_.xmin, x.x());
        crush_.xmax = std::max(crush_.xmax, x.x());
        crush_.ymin = std::min(crush_.ymin, x.y());
        crush_.ymax = std::max(crush_.ymax, x.y());
        crush_.positionSum += x;
        ++crush_.samples;
        anyAbove = true;
    }
    if (anyAbove) {
        if (!(crush_.firstTime == crush_.firstTime)) crush_.firstTime = time - dt;
        crush_.seconds += dt;
    }
    if (!anyCare_) return;
    // Falls of this step, by id; and whether care() has anyone to look after.
    const std::size_t before = falls_.size();
    for (std::size_t i = 0; i < n; ++i) {
        HealthRecord& r = record(agents, i);
        if (fellNow_[i]) {
            CareRecord& c = careFor(r);
            if (r.falls == 1) {
                c.fellAt = time;
                c.fallPosition = agents.pos[i];
            }
            c.lastFellAt = time;
            c.getUpAt = time + params_[static_cast<std::size_t>(agents.policy[i])].getUpTime;
            c.standingRadius = agents.radius[i];
            falls_.push_back(FallEvent{r.id, time, agents.pos[i]});
            ++fallenNow_;
        }
        if (!anyCasualty_ && (r.injured() || r.fallen)) anyCasualty_ = true;
    }
    std::sort(falls_.begin() + static_cast<std::ptrdiff_t>(before), falls_.end(),
              [](const FallEvent& a, const FallEvent& b) { return a.id < b.id; });
}

void HealthLayer::care(AgentStore& agents, const PointGrid& grid, double time, double dt, std::uint64_t seed) {
    if (!anyCare_ || !anyCasualty_) return;
    const std::size_t n = agents.size();
    constexpr double kFallSeconds = 1.0;  // the body takes its room on the floor over this time
    // 1. The people on the floor: get up when their time has come, else lie still.
    if (fallenNow_ > 0)
        for (std::size_t i = 0; i < n; ++i) {
            HealthRecord& r = record(agents, i);
            if (!r.fallen) continue;
            CareRecord& c = care_[static_cast<std::size_t>(r.care)];  // made when it fell
            if (time >= c.getUpAt - 0.5 * dt) {
                r.fallen = false;
                c.gotUpAt = time;
                c.getUpAt = CareRecord::kNever;
                agents.radius[i] = c.standingRadius;
                --fallenNow_;
                continue;
            }
            const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[i])];
            const double grown = std::min(1.0, (time - c.lastFellAt) / kFallSeconds);
            agents.radius[i] = c.standingRadius + grown * (hp.fallenRadius - c.standingRadius);
            agents.prefVel[i] = Vec2(0, 0);
        }
    // 2. The casualties in the world (injured or on the floor), by id.
    std::vector<std::size_t> casualties;
    std::vector<std::size_t> helpers;
    bool anyGroup = false;
    double farthest = 0;  // the largest helpRadius of a policy that helps
    for (const HealthParams& hp : params_)
        if (hp.helping) farthest = std::max(farthest, hp.helpRadius);
    for (std::size_t i = 0; i < n; ++i) {
        HealthRecord& r = record(agents, i);
        if (r.injured() || r.fallen) {
            casualties.push_back(i);
            anyGroup = anyGroup || agents.group[i] >= 0;
            if (careOf(r).helping >= 0) {  // a helper who was hurt itself stops helping
                CareRecord& c = care_[static_cast<std::size_t>(r.care)];
                c.helping = -1;
                c.helpPhase = 0;
            }
        } else if (careOf(r).helping >= 0) {
            helpers.push_back(i);
        }
    }
    std::sort(casualties.begin(), casualties.end(),
              [&](std::size_t a, std::size_t b) { return agents.id[a] < agents.id[b]; });
    std::unordered_map<AgentId, std::size_t> casualtyAt;
    for (std::size_t c : casualties) casualtyAt.emplace(agents.id[c], c);
    // 3. New helpers. Each (helper, casualty) pair has a draw of its own.
    if (farthest > 0 || anyGroup) {
        std::unordered_map<int, std::vector<std::size_t>> members;
        if (anyGroup)
            for (std::size_t i = 0; i < n; ++i)
                if (agents.group[i] >= 0) members[agents.group[i]].push_back(i);
        auto tryHelp = [&](std::size_t j, std::size_t c, bool stranger) {
            HealthRecord& rj = record(agents, j);
            const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[j])];
            if (!hp.helping || rj.injured() || rj.fallen || careOf(rj).helping >= 0) return false;
            const AgentId cid = agents.id[c];
            // The draw is keyed by the pair: asked again later, an agent answers the same.
            Rng rng(seed, static_cast<std::uint64_t>(agents.id[j]), static_cast<std::uint64_t>(cid), kStreamHelp);
            if (!(rng.uniform() < (stranger ? hp.helpStranger : hp.helpGroup))) return false;
            CareRecord& cj = careFor(rj);
            cj.helping = cid;
            cj.helpPhase = 1;
            cj.besideSince = CareRecord::kNever;
            if (cj.firstHelped < 0) cj.firstHelped = cid;
            ++careFor(record(agents, c)).helpers;
            helpers.push_back(j);
            return true;
        };
        std::vector<std::pair<double, std::size_t>> near;
        for (std::size_t c : casualties) {
            const int g = agents.group[c];
            if (g >= 0)
                for (std::size_t j : members[g])
                    if (j != c) tryHelp(j, c, false);
            if (!(farthest > 0)) continue;
            // One stranger at a time: only while nobody helps this casualty.
            bool helped = false;
            for (std::size_t h : helpers) helped = helped || careOf(record(agents, h)).helping == agents.id[c];
            if (helped) continue;
            near.clear();
            grid.forEachWithin(agents.pos[c], farthest, [&](int jj, const Vec2&, double d2) {
                const std::size_t j = static_cast<std::size_t>(jj);
                if (j == c || (g >= 0 && agents.group[j] == g)) return;
                const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[j])];
                if (hp.helping && hp.helpStranger > 0 && d2 <= hp.helpRadius * hp.helpRadius) near.push_back({d2, j});
            });
            std::sort(near.begin(), near.end(), [&](const auto& a, const auto& b) {
                return a.first != b.first ? a.first < b.first : agents.id[a.second] < agents.id[b.second];
            });
            for (const auto& [d2, j] : near)
                if (tryHelp(j, c, true)) break;
        }
    }
    // 4. The helpers act: to the fallen person, beside it, or walking with the injured one.
    for (std::size_t i : helpers) {
        const HealthRecord& r = record(agents, i);
        if (careOf(r).helping < 0) continue;
        CareRecord& own = care_[static_cast<std::size_t>(r.care)];  // made when it began to help
        const auto it = casualtyAt.find(own.helping);
        if (it == casualtyAt.end()) {  // the person has left (or is no longer a casualty)
            own.helping = -1;
            own.helpPhase = 0;
            continue;
        }
        const std::size_t c = it->second;
        HealthRecord& rc = record(agents, c);
        const HealthParams& hp = params_[static_cast<std::size_t>(agents.policy[i])];
        const Vec2 d = grid.offset(agents.pos[i], agents.pos[c]);  // minimum image on a torus
        const double dist = d.norm();
        const Vec2 towards = dist > 1e-12 ? Vec2(d / dist) : Vec2(0, 0);
        if (rc.fallen) {
            const double reach = agents.radius[i] + agents.radius[c] + 0.3;
            if (dist > reach + (own.helpPhase == 2 ? 0.5 : 0.0)) {
                own.helpPhase = 1;
                agents.prefVel[i] = towards * agents.prefSpeed[i];
            } else {
                if (own.helpPhase != 2 && !(own.besideSince == own.besideSince)) own.besideSince = time;
                own.helpPhase = 2;
                agents.prefVel[i] = Vec2(0, 0);
                // Helped up: the person gets up helpTime after the first helper came beside it.
                CareRecord& cc = care_[static_cast<std::size_t>(rc.care)];  // made when it fell
                cc.getUpAt = std::min(cc.getUpAt, own.besideSince + hp.helpTime);
            }
        } else {
            own.helpPhase = 3;
            if (dist > hp.escortDistance) {
                agents.prefVel[i] = towards * agents.prefSpeed[i];
            } else {
                const Vec2 v = agents.prefVel[c];
                const double s = v.norm();
                agents.prefVel[i] = s > 0 ? Vec2(v / s * std::min(s, agents.prefSpeed[i])) : Vec2(0, 0);
            }
        }
    }
}

void HealthLayer::markExit(const AgentStore& agents, std::size_t i, double time) { record(agents, i).exitTime = time; }

std::size_t HealthLayer::injuredCount() const {
    return static_cast<std::size_t>(
        std::count_if(records_.begin(), records_.end(), [](const HealthRecord& r) { return r.injured(); }));
}

std::size_t HealthLayer::fallenCount() const {
    return static_cast<std::size_t>(
        std::count_if(records_.begin(), records_.end(), [](const HealthRecord& r) { return r.everFell(); }));
}

std::size_t HealthLayer::helperCount() const {
    return static_cast<std::size_t>(
        std::count_if(care_.begin(), care_.end(), [](const CareRecord& c) { return c.isHelper(); }));
}

std::size_t HealthLayer::helpedCount() const {
    return static_cast<std::size_t>(
        std::count_if(care_.begin(), care_.end(), [](const CareRecord& c) { return c.helpers > 0; }));
}

CareRecord& HealthLayer::careFor(HealthRecord& r) {
    if (r.care < 0) {
        r.care = static_cast<int>(care_.size());
        care_.emplace_back();
    }
    return care_[static_cast<std::size_t>(r.care)];
}

double HealthLayer::meanPanic(const AgentStore& agents) const {
    if (agents.empty()) return 0.0;
    double sum = 0;
    for (std::size_t i = 0; i < agents.size(); ++i) sum += recordOf(agents, i).panic;
    return sum / static_cast<double>(agents.size());
}

std::string healthCsv(const HealthLayer& health) {
    std::string all;
    healthCsv(health, [&](std::string_view piece) { all += piece; });
    return all;
}

void healthCsv(const HealthLayer& health, const std::function<void(std::string_view)>& sink) {
    constexpr std::size_t kPiece = std::size_t{1} << 20;
    std::vector<const HealthRecord*> rows;
    for (const HealthRecord& r : health.records())
        if (r.seen) rows.push_back(&r);
    std::sort(rows.begin(), rows.end(), [](const HealthRecord* a, const HealthRecord* b) { return a->id < b->id; });
    std::string out = kHealthHeader;
    out.reserve(kPiece + 4096);
    out += '\n';
    auto optional = [&](double v) {
        out += ',';
        if (v == v) appendNumber(out, v, 10);
    };
    for (const HealthRecord* r : rows) {
        const CareRecord& c = health.careOf(*r);
        out += std::to_string(r->id);
        for (const double v : {r->peakContactAccel, r->peakForce}) { out += ','; appendNumber(out, v); }
        out += ',';
        appendNumber(out, r->timeAboveThreshold, 10);
        out += ',';
        appendNumber(out, r->dose);
        optional(r->injuredAt);
        out += ',';
        appendNumber(out, r->peakPanic);
        optional(r->exitTime);
        out += ',';
        appendNumber(out, r->meanAbsHeadingChange());
        optional(c.fellAt);
        out += ',' + std::to_string(r->falls);
        optional(c.gotUpAt);
        out += ',';
        if (c.firstHelped >= 0) out += std::to_string(c.firstHelped);
        out += ',';
        appendNumber(out, c.helpTime, 10);
        out += ',';
        appendNumber(out, c.helpDose);
        out += ',' + std::to_string(c.helpers);
        out += '\n';
        if (out.size() >= kPiece) {
            sink(out);
            out.clear();
        }
    }
    if (!out.empty()) sink(out);
}

}  // namespace ch
