// CrowdHealth — ScenarioSpec: the plain description of a run that the XML loader produces.
// No XML type appears past this point (DESIGN §2); tests and embedding programs can build a
// ScenarioSpec by hand.
#pragma once

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/shared_name.h"
#include "crowdhealth/core/types.h"
#include "crowdhealth/measure/measurement.h"
#include "crowdhealth/navigation/venue.h"

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ch {

enum class WorldType {
    Infinite,  ///< unbounded plane (UMANS 1.x)
    Toric,     ///< wraps around in x and y; neighbours are found across the border (UMANS 1.x)
    Planar     ///< bounded rectangle [xmin,xmax]×[ymin,ymax]; agents that leave it are removed
};

struct WorldSpec {
    WorldType type = WorldType::Infinite;
    double width = 0, height = 0;  ///< Toric: period in x and y (m), the world spans [-w/2, w/2)
    double xmin = 0, xmax = 0, ymin = 0, ymax = 0;  ///< Planar bounds (m)
    SourceLoc loc;
};

/// A closed polygon obstacle (UMANS <Obstacle>); its edges become wall segments.
struct ObstacleSpec {
    std::vector<Vec2> points;  ///< vertices in order (m); the polygon is closed implicitly
    /// Static SPH boundary particles packed inside (from <Box particles="true">); empty otherwise.
    std::vector<Vec2> particles;
    SourceLoc loc;
};

enum class OptimisationMethod { Gradient, Sampling, Global };
enum class StepTiming { Coarse, Fine };

/// UMANS' sampling settings (attributes of <Policy> or <Step>).
struct SamplingSpec {
    enum class Type { Regular, Random } type = Type::Regular;
    enum class Base { Zero, CurrentVelocity } base = Base::Zero;
    enum class BaseDirection { Unit, CurrentVelocity, PreferredVelocity } baseDirection =
        BaseDirection::CurrentVelocity;
    enum class Radius { PreferredSpeed, MaximumSpeed, MaximumAcceleration } radius = Radius::PreferredSpeed;
    double angle = 360;        ///< full opening angle of the sampled cone (degrees)
    int speedSamples = 3;      ///< regular sampling: rings
    int angleSamples = 11;     ///< regular sampling: directions per ring
    int randomSamples = 100;   ///< random sampling: samples per agent per step
    bool includeBaseAsSample = false;
    /// Also score the agent's preferred velocity (not UMANS: its regular grid seldom holds it, so a
    /// cost that wants exactly v_pref, as Karamouzas' with nothing ahead, gets the nearest ring).
    bool includePreferredAsSample = false;
};

/// One cost function or force inside a step, with its weight (`coeff`) and parameters.
struct ComponentSpec {
    std::string name;       ///< registered name, e.g. "SocialForcesAvoidance"
    double coeff = 1.0;     ///< weight in the step's sum (UMANS `coeff`)
    ParamSet params;        ///< every parameter of the component's table, defaults filled in
    /// The parameters the file wrote, with their places: a default that depends on the rest of
    /// the scenario (SPH@walls) is only resolved where the file is silent, and settings that
    /// conflict are warned about at their lines.
    std::map<std::string, SourceLoc> written;
    SourceLoc loc;
};

/// A per-agent weight of a whole step that follows a per-agent field of a component of the same
/// policy (CrowdHealth's extension, <Step BlendField BlendFrom BlendTo>): the step's acceleration
/// and reported contact are multiplied by
///     w_i = clamp((f_i − from) / (to − from), 0, 1),
/// 0 at `from`, 1 at `to` (from > to gives a weight that falls as f rises). Two steps with swapped
/// from/to blend linearly between two step lists, e.g. van Toll et al. 2021's density blend
/// κ = clamp((ρ_i − 2)/2, 0, 1): navigation step from=4 to=2 (weight 1 − κ), SPH step from=2 to=4 (κ).
struct BlendSpec {
    std::string component;  ///< registered name; the policy's first component with that name
    std::string field;      ///< its per-agent field (Component::field), e.g. "density"
    double from = 0, to = 1;  ///< in the field's unit; from ≠ to
    SourceLoc loc;
};

/// A policy step: an optimisation method over a weighted list of components, on a time step.
struct StepSpec {
    StepTiming timing = StepTiming::Coarse;
    OptimisationMethod method = OptimisationMethod::Gradient;
    double relaxationTime = 0;  ///< s; 0 = reach the optimum within one step (UMANS)
    bool stopAtGoal = true;     ///< agents that reached their goal stand still (UMANS behaviour)
    SamplingSpec sampling;
    std::vector<ComponentSpec> components;
    std::optional<BlendSpec> blend;  ///< absent: weight 1 for every agent
    SourceLoc loc;
};

/// The CrowdHealth layer of a policy (<CrowdHealth> inside <Policy>, docs/crowd-health.md): its
/// values for every parameter of crowdHealthTable() (crowdhealth/health/health.h), defaults filled in.
struct CrowdHealthSpec {
    ParamSet params;
    SourceLoc loc;
};

struct PolicySpec {
    int id = 0;
    std::string name;
    std::vector<StepSpec> steps;
    /// UMANS' post-clamp contact force stiffness (N/m per unit mass, applied after the
    /// acceleration clamp); 0 disables it. The loader sets it to 0 when the file does not write
    /// ContactForceScale and a step lists a component that models contact (ContactForces), so
    /// body contact is applied once (docs/policies.md, "Contact is applied once").
    double contactForceScale = 62.5;
    /// Absent: crush and panic are still measured with the layer's defaults, with no effect on
    /// motion (docs/crowd-health.md).
    std::optional<CrowdHealthSpec> health;
    SourceLoc loc;
};

/// <Ramp> in <Schedule>: moves one parameter linearly from `from` (at `start`) to `to` (at `end`)
/// and holds `to` afterwards. The first ramp of a parameter (in file order) also holds `from`
/// from t = 0 until its start, so the file's own value is replaced for the whole run; a later
/// ramp of the same parameter acts only from its own start (chains: 3→7, then 7→3).
struct RampSpec {
    enum class Target { Component, Agents };
    Target target = Target::Component;
    std::optional<int> policyId;  ///< Component: absent = every policy that has the component
    std::string component;        ///< registered component name, or "CrowdHealth" (the layer)
    std::string parameter;        ///< a Real parameter of its table; Agents: pref_speed, max_speed, max_acceleration
    double from = 0, to = 0;      ///< in the parameter's unit
    double start = 0, end = 0;    ///< s, start <= end
    SourceLoc loc;
    /// Column name in metrics.csv: "<component>.<parameter>" or "agents.<parameter>".
    std::string column() const { return (target == Target::Agents ? std::string("agents") : component) + "." + parameter; }
    /// The value at time t (s): from at start, to at end and after, linear between (t >= start).
    double valueAt(double t) const {
        if (t >= end) return to;
        if (t <= start) return from;
        return from + (to - from) * ((t - start) / (end - start));
    }
};

/// <PanicEvent time x y radius strength/> in <Schedule>: at `time` every agent within `radius` of
/// (x, y) gets panic = max(panic, strength).
struct PanicEventSpec {
    double time = 0;            ///< s
    Vec2 position{0, 0};        ///< m
    double radius = 1;          ///< m
    double strength = 1;        ///< 0..1
    SourceLoc loc;
};

/// One agent of the scenario. The members are ordered by alignment, not by meaning (the 16-byte
/// aligned vectors, then the 8-byte values, the 4-byte values, the bytes), so that no padding is
/// left between them; its names are SharedNames (8 bytes, shared by the agents that repeat them)
/// and its colour is three bytes. 176 bytes (288 before the reordering and the shared file name of
/// SourceLoc, 240 with two std::string names and int colours): a million agents' specs coexist
/// with the agent store while the simulation is set up (issue 20).
struct AgentSpec {
    Vec2 position{0, 0};        ///< m
    std::optional<Vec2> goal;   ///< m; absent: the agent stays where it is (UMANS warns)
    AgentId id = -1;            ///< -1: assigned automatically (next free id, in file order)
    double radius = 0.24;       ///< m
    double prefSpeed = 1.4;     ///< m/s
    double maxSpeed = 1.8;      ///< m/s
    double maxAcceleration = 5.0;  ///< m/s²
    double mass = 1.0;          ///< dimensionless body-mass factor (van Toll: (rad/0.24)²)
    double goalRadius = -1;     ///< m; < 0 means "the agent's radius" (UMANS)
    double startTime = 0;       ///< s; the agent appears at this time
    /// s the agent stands after appearing before it starts walking (RiMEA's premovement time).
    double premovement = 0;
    /// A <Journey> of the venue (crowdhealth/navigation/venue.h); empty: walk to `goal` (UMANS).
    SharedName journey;
    /// The agent's social group (Agent@group, or AgentGrid@group_size); empty: walks alone.
    SharedName group;
    SourceLoc loc;
    int policyId = 0;
    /// Index into VenueSpec::sources for an agent a source creates: its position is chosen when it
    /// arrives (Navigation::place); -1 for every other agent.
    int source = -1;
    /// Index of `group` in ScenarioSpec::groups (set by the loader); -1: no group.
    int groupIndex = -1;
    std::optional<std::array<std::uint8_t, 3>> color;  ///< RGB 0..255 for viewers
    bool removeAtGoal = false;
};
static_assert(sizeof(AgentSpec) <= 176, "AgentSpec grew past 176 bytes (memory at a million agents): "
                                        "keep its members ordered by alignment");

struct OutputSpec {
    double metricsInterval = 1.0;     ///< s between rows of metrics.csv
    /// "umans", "txt", "bin", "both" (umans and txt), "none", or a comma-separated list such as
    /// "txt,bin" (parseTrajectoryFormats()).
    std::string trajectories = "none";
    /// s between trajectory frames; 0 (attribute absent) = every coarse step (delta_time).
    double trajectoryInterval = 0;
    bool trajectoryVelocities = false;  ///< trajectories.bin records carry vx, vy as well
    int flowFirst = 1, flowLast = 350;  ///< flow is measured from the Nth to the Mth evacuee
    SourceLoc loc;
};

/// The thresholds of the safety verdict and the grid of the crowd measures (<Safety>,
/// crowdhealth/health/safety.h; docs/crowd-health.md gives the source of each default).
struct SafetyThresholds {
    double cellSize = 1.0;            ///< m, grid cell of the crowd measures and the heat map
    double gaussianRadius = 0.7;      ///< m, R of the Gaussian weights
    double densityCaution = 2.17;     ///< persons/m², Fruin's walkway level of service F (< 0.46 m²/person)
    double densityDangerous = 4.0;    ///< persons/m², Still: moving crowds at risk above ~4
    double densityCritical = 6.0;     ///< persons/m², Still: crowd collapse/shock waves at ~6–7
    double crowdPressureCritical = 0.02;  ///< 1/s², Helbing et al. 2007: onset of crowd turbulence;
                                          ///< counted only where density > densityCaution
    /// s, time constant of the exponential time averages of crowd pressure (the local velocity's
    /// mean and variance in time, and the density, at each place; crowdhealth/health/safety.h).
    double pressureWindow = 5.0;
    double minDuration = 1.0;         ///< s a density/pressure condition must hold (anywhere) to count
    double doseDangerousFraction = 0.5;  ///< crush is `dangerous` once a dose reaches this share of injuryDose
    /// P/(m·s): an exit or measurement line whose specific flow stays above it (for minDuration)
    /// is at capacity — 1.33, the maximum specific flow of the IMO guidelines (MSC.1/Circ.1533)
    /// and the SFPE handbook's hydraulic model.
    double flowCapacity = 1.33;
    /// s: the specific flow compared with flowCapacity is the crossings of the last flowWindow
    /// seconds (a sustained rate, not the count of one interval).
    double flowWindow = 10.0;
};

/// The trajectory files a run writes (<Output trajectories>, crowdhealth --trajectories).
struct TrajectoryFormats {
    bool umans = false;  ///< one output_<id>.csv per agent (UMANS)
    bool txt = false;    ///< trajectories.txt (PedPy)
    bool bin = false;    ///< trajectories.bin (compact binary, see crowdhealth/io/output.h)
    bool any() const { return umans || txt || bin; }
};

/// The words parseTrajectoryFormats() accepts, for messages: "umans, txt, bin, both, none".
inline constexpr const char* kTrajectoryFormatWords = "umans, txt, bin, both, none";

/// Reads a trajectory choice: one of umans, txt, bin, both (= umans and txt) or none, or a
/// comma-separated list of umans, txt, bin and both (e.g. "txt,bin"; spaces around the commas are
/// allowed). nullopt when a word is unknown, empty, or "none" is combined with another.
std::optional<TrajectoryFormats> parseTrajectoryFormats(const std::string& text);

/// Everything needed to build a Simulation.
struct ScenarioSpec {
    std::string sourceFile;   ///< the main XML file (for messages and summaries)
    /// Plugins named by <Plugin file="…"/> (canonical paths, in file order), loaded by the loader.
    std::vector<std::string> plugins;
    /// Every other file the loader read for this scenario: the files named by file= of <Policies>,
    /// <Agents> and <Obstacles> (XML, DXF, WKT), as opened, in the order read. The main file is
    /// sourceFile. Sweep and calibrate hash them so that a resumed run notices an edited one.
    std::vector<std::string> includedFiles;
    double deltaTime = 0.1;   ///< coarse step (s)
    double deltaTimeFine = 0; ///< fine step (s); 0 = same as deltaTime
    double endTime = -1;      ///< s; < 0 = run until every agent has left (or --end-time)
    std::uint64_t seed = 1;
    /// Symmetry breaking (m; Simulation@symmetry_breaking): every fine step each agent that is held
    /// up (wants to walk but moves slower than half its preferred speed) has its new position moved
    /// by a point drawn uniformly from a disc of this radius, keyed by (seed, agent id, step), so
    /// exactly symmetric scenarios (UMANS' circles and crossings) do not deadlock in double
    /// precision. 0 switches it off. Default 1e-6 m: the order of the rounding of UMANS'
    /// single-precision positions, far below anything measured (docs/policies.md).
    static constexpr double kDefaultSymmetryBreaking = 1e-6;
    double symmetryBreaking = kDefaultSymmetryBreaking;
    WorldSpec world;
    std::vector<ObstacleSpec> obstacles;
    std::vector<PolicySpec> policies;
    std::vector<AgentSpec> agents;
    /// The social groups' names, in the order of their first member (AgentSpec::groupIndex).
    std::vector<std::string> groups;
    std::vector<RampSpec> ramps;             ///< <Schedule><Ramp>, in file order
    std::vector<PanicEventSpec> panicEvents; ///< <Schedule><PanicEvent>, in file order
    OutputSpec output;
    SafetyThresholds safety;                 ///< <Safety>; defaults without it
    /// Navigation, targets, exits, journeys, sources (DESIGN §8); empty: UMANS' straight goals.
    VenueSpec venue;
    /// Measurement lines and areas (<Measurement>, crowdhealth/measure/measurement.h); empty: none.
    MeasurementSpec measurement;

    double fineStep() const { return deltaTimeFine > 0 ? deltaTimeFine : deltaTime; }
    /// Number of fine steps per coarse step (validated by the loader to be a whole number).
    int fineStepsPerCoarse() const;
};

}  // namespace ch
