// CrowdHealth — the CrowdHealth layer (DESIGN §5, docs/crowd-health.md): crush and panic recorded
// for every pedestrian every fine step, and their effects on motion.
//
// Per fine step, in the simulation's order:
//   beginStep (after the neighbour grid is built, before preferred velocities):
//     panic update from the frozen panic of the previous step — contagion from neighbours,
//     decay, panic events, the scheduled floor `panic` — then the speeds in effect:
//       v_pref = v_base + P·max(0, v_panic − v_base)   (panicSpeedEffect)
//       injured: v_pref ×= injuredSpeedFactor, v_max = v_max,base × injuredMaxSpeedFactor (injuryEffect)
//   steerPreferred (after preferred velocities are set): herding and erratic motion turn the
//     preferred direction (each agent writes only its own prefVel; neighbours' velocities are the
//     frozen ones; random angles come from Rng(seed, id, interval index, kStreamPanic));
//   care (after steerPreferred; only when some policy has falls or helping): fallen agents get up
//     when their time has come, lie still otherwise; helpers are chosen for new casualties (group
//     members with probability helpGroup, one stranger within helpRadius with helpStranger) and
//     walk to, stand beside, or escort the person they help (their prefVel is replaced);
//   endStep (after integration): crush F = bodyMass·m_i·|a_contact,i|, its peak, time above the
//     threshold, dose ∫F dt while F > threshold, injury once the dose reaches injuryDose, a fall at
//     each multiple of fallDose (with falls on); help time and dose; heading change; peak panic.
// Without a <CrowdHealth> element a policy still gets every measurement, with the default
// thresholds, and none of the effects (injury, panic speed, erratic motion, herding, falls, help).
#pragma once

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/scenario.h"

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace ch {

/// The parameters of <CrowdHealth> (name, unit, default, range, meaning). Drives the loader,
/// ramps of component="CrowdHealth" and the reference in docs/crowd-health.md.
const ParamTable& crowdHealthTable();

/// The values of one policy's layer.
struct HealthParams {
    double bodyMass = 80;            ///< kg for mass factor 1
    double crushThreshold = 4500;    ///< N
    double injuryDose = 135000;      ///< N·s
    bool injuryEffect = true;
    double injuredSpeedFactor = 0.5;
    double injuredMaxSpeedFactor = 0.5;
    double panic = 0;                ///< scheduled floor 0..1
    double panicDecay = 0.05;        ///< 1/s
    double contagionRate = 0.5;      ///< 1/s
    double contagionRadius = 1.0;    ///< m
    double contagionThreshold = 0.1; ///< 0..1
    bool panicSpeedEffect = true;
    double panicSpeed = 1.8;         ///< m/s
    bool erratic = false;
    double erraticAngle = 30;        ///< degrees (standard deviation at panic 1)
    double erraticInterval = 0.5;    ///< s
    bool herding = false;
    double herdingWeight = 0.5;      ///< Helbing et al. 2000's p at panic 1
    double herdingRadius = 2.0;      ///< m
    // Falls (Cornes, Frank & Dorso 2017: fallen, unconscious pedestrians are obstacles)
    bool falls = false;
    double fallDose = 270000;        ///< N·s, dose at which an agent falls (again at each multiple)
    double getUpTime = 60;           ///< s on the floor without help
    double fallenRadius = 0.5;       ///< m, the body on the floor (not rampable: sets the neighbour range)
    // Altruism: helping injured and fallen people
    bool helping = false;
    double helpGroup = 1;            ///< probability that a member helps an injured member of its group
    double helpStranger = 0;         ///< probability that a stranger within helpRadius helps
    double helpRadius = 3;           ///< m
    double helpTime = 10;            ///< s beside a fallen person before both leave
    double escortDistance = 1.5;     ///< m, a helper keeps within this distance of the person it helps

    /// From a ParamSet of crowdHealthTable(). `effects` false: every effect switched off (a policy
    /// without <CrowdHealth>).
    static HealthParams from(const ParamSet& values, bool effects);
    /// Changes a Real parameter by name (ramps). False for an unknown or non-real name.
    bool set(const std::string& name, double value);
    /// Current value of a parameter by name (NaN if unknown).
    double get(const std::string& name) const;
};

/// What a pedestrian's falls and helping leave: only agents that fell, helped or were helped have
/// one (HealthLayer::careOf()), kept apart from their HealthRecord so that the record is two cache
/// lines (a million agents' records take 122 MiB instead of 244).
struct CareRecord {
    static constexpr double kNever = std::numeric_limits<double>::quiet_NaN();
    // falls
    double fellAt = kNever;          ///< s, the first fall
    double lastFellAt = kNever;      ///< s, the latest fall
    double gotUpAt = kNever;         ///< s, the latest getting up
    double getUpAt = kNever;         ///< s, when the agent on the floor gets up (while fallen)
    double standingRadius = 0;       ///< m, its radius before it fell
    Vec2 fallPosition{0, 0};         ///< m, where it (first) fell
    // helping (altruism)
    AgentId helping = -1;            ///< the person it helps now (-1: nobody)
    double besideSince = kNever;     ///< s, arrived beside the fallen person it helps
    double helpTime = 0;             ///< s spent helping (approaching, beside, escorting)
    double helpDose = 0;             ///< N·s of crush dose received while helping
    int helpPhase = 0;               ///< 0 none, 1 going to, 2 beside (stopped), 3 escorting
    AgentId firstHelped = -1;        ///< the first person it helped
    int helpers = 0;                 ///< people who came to help this one

    bool isHelper() const { return firstHelped >= 0; }
};

/// One pedestrian's health record (with its CareRecord, one row of health.csv): two cache lines
/// (records are 64-byte aligned). The fields that every fine step reads or writes come first:
/// beginStep reads only the first line, endStep the first two (the layer's per-step loops are
/// memory-bound at 100k agents).
struct alignas(64) HealthRecord {
    static constexpr double kNever = std::numeric_limits<double>::quiet_NaN();
    // first cache line: crush and panic, every step
    double peakContactAccel = 0;     ///< m/s²
    double peakForce = 0;            ///< N
    double lastForce = 0;            ///< N, last fine step
    double timeAboveThreshold = 0;   ///< s
    double dose = 0;                 ///< N·s
    double injuredAt = kNever;       ///< s
    double panic = 0;                ///< current level 0..1
    double peakPanic = 0;
    // second cache line: heading, the flags endStep tests every step, identity
    Vec2 lastHeading{0, 0};          ///< unit velocity direction of the last step (0: none)
    double headingChange = 0;        ///< rad, Σ|Δθ| while moving
    double movingTime = 0;           ///< s over which headingChange was summed
    AgentId id = -1;
    double exitTime = kNever;        ///< s, removed at its goal
    int care = -1;                   ///< index of its CareRecord (HealthLayer::careOf()); -1: none
    int falls = 0;                   ///< times fallen
    std::uint32_t policy = 0;        ///< the agent's policy index (whose layer parameters apply)
    bool fallen = false;             ///< on the floor now
    bool seen = false;               ///< the agent was in the world at some point

    bool injured() const { return injuredAt == injuredAt; }
    bool everFell() const { return falls > 0; }
    /// Mean absolute heading change (rad/s) while moving faster than 0.1 m/s; 0 if never.
    double meanAbsHeadingChange() const { return movingTime > 0 ? headingChange / movingTime : 0.0; }
};
static_assert(sizeof(HealthRecord) == 128, "HealthRecord should stay two cache lines (memory at a million agents)");

/// One fall (for the verdict: where and when).
struct FallEvent {
    AgentId id = -1;
    double time = 0;  ///< s
    Vec2 position{0, 0};
};

/// Crowd-level crush bookkeeping over the fine steps (for the verdict).
struct CrushSummary {
    double firstTime = HealthRecord::kNever;  ///< s, first fine step with someone above the threshold
    double seconds = 0;                       ///< s during which at least one agent was above it
    std::size_t samples = 0;                  ///< agent-steps above the threshold
    Vec2 positionSum{0, 0};                   ///< Σ positions of those agent-steps (centroid)
    double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
};

class HealthLayer {
public:
    /// Sets up one record per spec agent and the parameters of each policy (index = position in
    /// spec.policies, which is the simulation's policy index).
    void init(const ScenarioSpec& spec);

    /// Panic update and speeds in effect (see the file comment). `grid` holds agents.pos.
    void beginStep(AgentStore& agents, const PointGrid& grid, double time, double dt);
    /// Herding and erratic motion on agents.prefVel.
    void steerPreferred(AgentStore& agents, const PointGrid& grid, double time, std::uint64_t seed) const;
    /// Falls and helping on agents.prefVel (after steerPreferred): fallen agents want nothing;
    /// helpers are chosen for new casualties and walk to, wait beside or escort the person they
    /// help. Sequential, in agent order, with random draws from (seed, helper id, casualty id):
    /// the same result with any thread count.
    void care(AgentStore& agents, const PointGrid& grid, double time, double dt, std::uint64_t seed);
    /// Crush, injury, falls, heading, peaks after the step; `time` is the time at the end of the
    /// step. A fall sets the agent's radius (the body on the floor).
    void endStep(AgentStore& agents, double time, double dt);
    /// True while some agent lies on the floor (Simulation pins fallen agents in place).
    bool anyFallen() const { return fallenNow_ > 0; }
    /// True when active agent i lies on the floor.
    bool isFallen(const AgentStore& agents, std::size_t i) const { return recordOf(agents, i).fallen; }
    /// The largest body radius a policy's falls can give (0 without falls): the neighbour range
    /// must cover it.
    static double largestFallenRadius(const ScenarioSpec& spec);
    /// The build of endStep's per-agent part in use: 0 generic (SSE2 on x86-64), 1 AVX2, the
    /// same bits; the best this CPU runs unless setEndStepPath chose (which returns false and
    /// changes nothing for a build this CPU cannot run). For crowdhealth-bench --isa.
    static int endStepPath();
    static bool setEndStepPath(int path);
    /// Active agent i (AgentStore index) leaves at its goal at `time` (called before removal).
    void markExit(const AgentStore& agents, std::size_t i, double time);
    /// Active agent i has just entered the world.
    void activated(const AgentStore& agents, std::size_t i);
    /// The record of the agent at `specPosition` in ScenarioSpec::agents (for AgentStore::add).
    int recordFor(std::size_t specPosition) const { return recordOfSpec_[specPosition]; }
    /// Frees what recordFor() reads, once every agent is in the world (Simulation::releaseAgentSpecs).
    void releaseSpecPositions() { std::vector<int>().swap(recordOfSpec_); }
    /// Moves the records so that active agent i's is records()[i] (the others follow, in their
    /// order) and updates AgentStore::record: the per-step loops then read records in order.
    /// The simulation calls it after re-ordering the agents.
    void follow(AgentStore& agents);

    const std::vector<HealthRecord>& records() const { return records_; }
    /// The falls and helping of record r: its CareRecord, or an empty one (it never fell, helped
    /// anyone or was helped) when it has none.
    const CareRecord& careOf(const HealthRecord& r) const {
        static const CareRecord none;
        return r.care >= 0 ? care_[static_cast<std::size_t>(r.care)] : none;
    }
    /// One byte per record (index AgentStore::record): 1 when the record's lastForce exceeds its
    /// policy's crushThreshold, i.e. `r.lastForce > params(r.policy).crushThreshold`, as the last
    /// endStep left them. nullptr when these bytes cannot stand for that test: before the first
    /// endStep, or once some policy's crushThreshold differs from the one that endStep used (a
    /// ramp): the caller then reads the records. Readers of every agent's crush state (the safety
    /// recorder) touch one byte per agent instead of its 128-byte record.
    const unsigned char* crushFlags() const;
    /// Record of active agent i (AgentStore index): records are one per spec agent, found through
    /// AgentStore::record, so agents keep theirs whatever the removals and re-orderings.
    const HealthRecord& recordOf(const AgentStore& agents, std::size_t i) const;
    HealthParams& params(std::size_t policyIndex) { return params_[policyIndex]; }
    const HealthParams& params(std::size_t policyIndex) const { return params_[policyIndex]; }
    bool hasElement(std::size_t policyIndex) const { return hasElement_[policyIndex] != 0; }
    const CrushSummary& crush() const { return crush_; }
    /// Agents injured so far (all that ever existed).
    std::size_t injuredCount() const;
    /// Agents that fell at least once / that helped someone / that were helped.
    std::size_t fallenCount() const;
    std::size_t helperCount() const;
    std::size_t helpedCount() const;
    /// Every fall, in time order (ties by id).
    const std::vector<FallEvent>& fallEvents() const { return falls_; }
    /// Mean panic over the active agents (0 when none).
    double meanPanic(const AgentStore& agents) const;

private:
    HealthRecord& record(const AgentStore& agents, std::size_t i) {
        return records_[static_cast<std::size_t>(agents.record[i])];
    }
    const HealthRecord& record(const AgentStore& agents, std::size_t i) const { return recordOf(agents, i); }

    /// endStep's per-agent part for the blocks [b0, b1) of simd::kLanes agents (health.cpp);
    /// returns whether any of their agents is above its crush threshold. Runs the build that
    /// endStepPath() names; the builds share endStepBlocksBody.
    bool endStepBlocks(AgentStore& agents, double time, double dt, std::ptrdiff_t b0, std::ptrdiff_t b1);
    bool endStepBlocksGeneric(AgentStore& agents, double time, double dt, std::ptrdiff_t b0, std::ptrdiff_t b1);
    bool endStepBlocksAvx2(AgentStore& agents, double time, double dt, std::ptrdiff_t b0, std::ptrdiff_t b1);
    bool endStepBlocksBody(AgentStore& agents, double time, double dt, std::ptrdiff_t b0, std::ptrdiff_t b1);

    /// Record r's CareRecord, made (empty) when it has none. Serial code only: it may grow care_.
    CareRecord& careFor(HealthRecord& r);

    std::vector<HealthRecord> records_;      ///< one per spec agent (spec order until follow())
    std::vector<CareRecord> care_;           ///< HealthRecord::care indexes it, in the order they were needed
    std::vector<int> recordOfSpec_;          ///< spec position → index in records_
    std::vector<HealthParams> params_;       ///< per policy index
    std::vector<unsigned char> hasElement_;  ///< per policy index
    std::vector<PanicEventSpec> events_;
    std::vector<unsigned char> eventFired_;
    std::vector<double> nextPanic_;          ///< per AgentStore index (double buffer)
    double maxPanic_ = 0;                    ///< largest panic level after the last beginStep
    std::vector<unsigned char> above_;       ///< per AgentStore index: above the crush threshold this step
    std::vector<unsigned char> aboveByRecord_;  ///< per record: lastForce > its policy's threshold (crushFlags)
    std::vector<double> thresholdAtEnd_;     ///< per policy index: crushThreshold at the last endStep
    bool ended_ = false;                     ///< endStep has run since init
    CrushSummary crush_;
    std::vector<FallEvent> falls_;
    int fallenNow_ = 0;                      ///< agents on the floor now
    bool anyCasualty_ = false;               ///< someone is injured or fallen (care() has work)
    bool anyInjured_ = false;                ///< some record has ever been injured (beginStep's quiet path)
    bool anyCare_ = false;                   ///< some policy has falls or helping
    std::vector<unsigned char> fellNow_;     ///< per AgentStore index: fell in this endStep
    std::vector<int> newOf_;                 ///< follow()'s scratch: old record index → new
};

/// health.csv: header `id,peak_contact_accel,peak_force,time_above_threshold,dose,injured_at,
/// peak_panic,exit_time,mean_abs_heading_change,fell_at,falls,got_up_at,helped_id,help_time,help_dose,
/// helpers`, one row per agent that was ever in the world,
/// by id; an empty cell for "never".
std::string healthCsv(const HealthLayer& health);
/// The same text handed to `sink` in pieces of about 1 MiB (in order): written to a file as it is
/// made, a million agents' health.csv (~50 MB) never sits in memory whole.
void healthCsv(const HealthLayer& health, const std::function<void(std::string_view)>& sink);

inline constexpr const char* kHealthHeader =
    "id,peak_contact_accel,peak_force,time_above_threshold,dose,injured_at,peak_panic,exit_time,"
    "mean_abs_heading_change,fell_at,falls,got_up_at,helped_id,help_time,help_dose,helpers";

}  // namespace ch
