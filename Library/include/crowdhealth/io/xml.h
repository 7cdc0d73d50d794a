// CrowdHealth — loading scenarios from XML (both UMANS dialects plus CrowdHealth's extensions).
#pragma once

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/core/params.h"
#include "crowdhealth/core/scenario.h"

#include <cstdint>
#include <optional>
#include <string>

namespace ch {

struct LoadOptions {
    /// Overrides Simulation@seed (used by --seed and replications). Generated agents
    /// (<AgentGrid>, <SpawnRectangle>) draw their random radii/noise from the final seed.
    std::optional<std::uint64_t> seed;
    /// The main file's content, used instead of reading `path` (which still names it in messages
    /// and is where relative file= paths resolve from). `crowdhealth calibrate` loads a scenario
    /// template with its ${…} placeholders filled in this way (Engine/calibrate.h).
    std::optional<std::string> text;
};

/// Loads a scenario file and every file it names (relative paths resolve against the file that
/// names them). Every problem found is added to `diags` as `path:line: error: …`; returns
/// std::nullopt when there was at least one error. Nothing is simulated or written.
std::optional<ScenarioSpec> loadScenario(const std::string& path, Diagnostics& diags,
                                         const LoadOptions& options = {});

/// Checks that `ramp` could be a <Ramp> of `spec` as the loader checks one: the component (a
/// registered one or CrowdHealth) or agents="all", a real parameter of its table that may be
/// ramped, `from` and `to` within its range, and (Component) a policy of `spec` holding it
/// (ramp.policyId absent: any policy). Returns the reason it could not, without a location
/// (e.g. "SPH has no parameter 'x' (did you mean 'y'?); its parameters: …"), or "" when it can.
/// Used by `crowdhealth sweep --vary` (Engine/sweep.cpp) so a sweep target is checked the same way.
std::string rampTargetProblem(const ScenarioSpec& spec, const RampSpec& ramp);

/// The attributes of <Simulation> with their units, defaults and ranges (the loader's table; the
/// hand-written table of docs/xml-reference.md is checked against it).
const ParamTable& simulationTable();

}  // namespace ch
