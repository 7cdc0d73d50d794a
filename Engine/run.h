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

/// Loads, builds and runs the scenario, writing the outputs to options.output (with
/// --replications: runReplications). Returns 0, 1 (runtime failure), 2 (bad input; nothing
/// written) or 130 (interrupted).
int runScenario(const Options& options);

/// --replications N: loads the scenario once per seed S … S+N−1 (every load checked before
/// anything is written), runs them at most options.threads at a time (each on one OpenMP thread)
/// into OUTDIR/run_000 …, writes OUTDIR/summary.csv and prints its table. Same exit statuses as
/// runScenario; 1 if any run failed.
int runReplications(const Options& options);

}  // namespace chcli
