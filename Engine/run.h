// crowdhealth — validating (--check) and running a scenario.
#pragma once

#include "cli.h"

namespace chcli {

/// Simulated time (s) at which a run without any end time stops if agents are still present
/// (they might never reach their goals, e.g. in a toric world).
inline constexpr double kSafetyCapSeconds = 3600.0;

/// --check: loads the scenario and builds the simulation; prints a one-line OK summary on
/// stdout and returns 0, or prints every error on stderr and returns 2. Writes nothing.
int checkScenario(const Options& options);

/// Loads, builds and runs the scenario, writing the outputs to options.output.
/// Returns 0, 1 (runtime failure), 2 (bad input; nothing written) or 130 (interrupted).
int runScenario(const Options& options);

}  // namespace chcli
