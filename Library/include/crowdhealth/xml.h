// CrowdHealth — loading scenarios from XML (both UMANS dialects plus CrowdHealth's extensions).
#pragma once

#include "crowdhealth/diagnostics.h"
#include "crowdhealth/scenario.h"

#include <optional>
#include <string>

namespace ch {

/// Loads a scenario file and every file it names (relative paths resolve against the file that
/// names them). Every problem found is added to `diags` as `path:line: error: …`; returns
/// std::nullopt when there was at least one error. Nothing is simulated or written.
std::optional<ScenarioSpec> loadScenario(const std::string& path, Diagnostics& diags);

}  // namespace ch
