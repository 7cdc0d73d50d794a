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
//   endStep (after integration): crush F = bodyMass·m_i·|a_contact,i|, its peak, time above the
//     threshold, dose ∫F dt while F > threshold, injury once the dose reaches injuryDose; heading
//     change of the velocity; peak panic.
// Without a <CrowdHealth> element a policy still gets every measurement, with the default
// thresholds, and none of the effects (injury, panic speed, erratic motion, herding).
#pragma once

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/grid.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/scenario.h"

#include <cstdint>
#include <limits>
#include <string>
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

    /// From a ParamSet of crowdHealthTable(). `effects` false: every effect switched off (a policy
    /// without <CrowdHealth>).
    static HealthParams from(const ParamSet& values, bool effects);
    /// Changes a Real parameter by name (ramps). False for an unknown or non-real name.
    bool set(const std::string& name, double value);
    /// Current value of a parameter by name (NaN if unknown).
    double get(const std::string& name) const;
};

/// One pedestrian's health record (one row of health.csv).
struct HealthRecord {
    static constexpr double kNever = std::numeric_limits<double>::quiet_NaN();
    AgentId id = -1;
    std::size_t policy = 0;          ///< the agent's policy index (whose layer parameters apply)
    bool seen = false;               ///< the agent was in the world at some point
    double peakContactAccel = 0;     ///< m/s²
    double peakForce = 0;            ///< N
    double timeAboveThreshold = 0;   ///< s
    double dose = 0;                 ///< N·s
    double injuredAt = kNever;       ///< s
    double panic = 0;                ///< current level 0..1
    double peakPanic = 0;
    double exitTime = kNever;        ///< s, removed at its goal
    double headingChange = 0;        ///< rad, Σ|Δθ| while moving
    double movingTime = 0;           ///< s over which headingChange was summed
    double lastForce = 0;            ///< N, last fine step
    Vec2 lastHeading{0, 0};          ///< unit velocity direction of the last step (0: none)

    bool injured() const { return injuredAt == injuredAt; }
    /// Mean absolute heading change (rad/s) while moving faster than 0.1 m/s; 0 if never.
    double meanAbsHeadingChange() const { return movingTime > 0 ? headingChange / movingTime : 0.0; }
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
    /// Crush, injury, heading, peaks after the step; `time` is the time at the end of the step.
    void endStep(const AgentStore& agents, double time, double dt);
    /// Active agent i (AgentStore index) leaves at its goal at `time` (called before removal).
    void markExit(const AgentStore& agents, std::size_t i, double time);
    /// Active agent i has just entered the world.
    void activated(const AgentStore& agents, std::size_t i);
    /// The record of the agent at `specPosition` in ScenarioSpec::agents (for AgentStore::add).
    int recordFor(std::size_t specPosition) const { return recordOfSpec_[specPosition]; }
    /// Moves the records so that active agent i's is records()[i] (the others follow, in their
    /// order) and updates AgentStore::record: the per-step loops then read records in order.
    /// The simulation calls it after re-ordering the agents.
    void follow(AgentStore& agents);

    const std::vector<HealthRecord>& records() const { return records_; }
    /// Record of active agent i (AgentStore index): records are one per spec agent, found through
    /// AgentStore::record, so agents keep theirs whatever the removals and re-orderings.
    const HealthRecord& recordOf(const AgentStore& agents, std::size_t i) const;
    HealthParams& params(std::size_t policyIndex) { return params_[policyIndex]; }
    const HealthParams& params(std::size_t policyIndex) const { return params_[policyIndex]; }
    bool hasElement(std::size_t policyIndex) const { return hasElement_[policyIndex] != 0; }
    const CrushSummary& crush() const { return crush_; }
    /// Agents injured so far (all that ever existed).
    std::size_t injuredCount() const;
    /// Mean panic over the active agents (0 when none).
    double meanPanic(const AgentStore& agents) const;

private:
    HealthRecord& record(const AgentStore& agents, std::size_t i) {
        return records_[static_cast<std::size_t>(agents.record[i])];
    }
    const HealthRecord& record(const AgentStore& agents, std::size_t i) const { return recordOf(agents, i); }

    std::vector<HealthRecord> records_;      ///< one per spec agent (spec order until follow())
    std::vector<int> recordOfSpec_;          ///< spec position → index in records_
    std::vector<HealthParams> params_;       ///< per policy index
    std::vector<unsigned char> hasElement_;  ///< per policy index
    std::vector<PanicEventSpec> events_;
    std::vector<unsigned char> eventFired_;
    std::vector<double> nextPanic_;          ///< per AgentStore index (double buffer)
    double maxPanic_ = 0;                    ///< largest panic level after the last beginStep
    std::vector<unsigned char> above_;       ///< per AgentStore index: above the crush threshold this step
    CrushSummary crush_;
};

/// health.csv: header `id,peak_contact_accel,peak_force,time_above_threshold,dose,injured_at,
/// peak_panic,exit_time,mean_abs_heading_change`, one row per agent that was ever in the world,
/// by id; an empty cell for "never".
std::string healthCsv(const HealthLayer& health);

inline constexpr const char* kHealthHeader =
    "id,peak_contact_accel,peak_force,time_above_threshold,dose,injured_at,peak_panic,exit_time,"
    "mean_abs_heading_change";

}  // namespace ch
