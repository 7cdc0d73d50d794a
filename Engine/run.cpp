// crowdhealth — validating and running a scenario (see run.h).
#include "run.h"

#include "exit_codes.h"
#include "plot.h"
#include "progress.h"
#include "scenario_run.h"
#include "signals.h"

#include <crowdhealth/io/output.h>
#include <crowdhealth/core/big_alloc.h>
#include <crowdhealth/core/simulation.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

namespace chcli {

namespace fs = std::filesystem;

namespace {

/// --timing's lines: "  of which       S s in steps (P %), R s recording (Q %), O s other\n", the
/// parts of the loop's wall time (the rest: the loop's own bookkeeping and progress display), then
/// "  recording      A s safety grid (P %), B s metrics (…), C s measurement (…), D s
/// trajectories (…)\n", the recorders' shares of R (the percentages again of the wall time).
std::string timingLine(const ch::RunInfo& info) {
    const double wall = info.wallTimeSeconds;
    const double other = std::max(0.0, wall - info.stepSeconds - info.recordSeconds);
    auto share = [&](double s) { return wall > 0 ? " (" + ch::formatNumber(100.0 * s / wall, 2) + " %)" : std::string(); };
    auto part = [&](double s, const char* what) { return ch::formatNumber(s, 3) + " s " + what + share(s); };
    return "  of which       " + part(info.stepSeconds, "in steps") + ", " + part(info.recordSeconds, "recording") + ", " +
           ch::formatNumber(other, 3) + " s other\n" + "  recording      " + part(info.safetySeconds, "safety grid") +
           ", " + part(info.metricsSeconds, "metrics") + ", " + part(info.measurementSeconds, "measurement") + ", " +
           part(info.trajectorySeconds, "trajectories") + "\n";
}

/// Loads the scenario and builds the simulation. On any problem prints every diagnostic to
/// stderr and returns nullptr; nothing has been simulated or written by then.
std::unique_ptr<ch::Simulation> loadAndBuild(const Options& o) {
    // A large scene's XML tree and specs are many small blocks: heap on huge pages (issue 20;
    // a 1.9-MB, 10k-agent file: 4,500 fewer page faults). The tree takes ~7 times the file's
    // size, then the specs and the simulation reuse it; 12 times measured best.
    std::error_code ec;
    if (const std::uintmax_t size = fs::file_size(o.input, ec); !ec)
        ch::heapOnHugePages(static_cast<std::size_t>(std::min<std::uintmax_t>(size, std::uintmax_t{1} << 30)) * 12);
    std::optional<ch::ScenarioSpec> spec = loadSpec(o, o.seed, true);
    if (!spec) return nullptr;
    return buildSimulation(std::move(*spec), o);  // the simulation keeps the spec: no copy
}

}  // namespace

int checkScenario(const Options& o) {
    const std::unique_ptr<ch::Simulation> sim = loadAndBuild(o);
    if (!sim) return kExitInput;
    const ch::ScenarioSpec& spec = sim->spec();
    if (!o.quiet) {
        std::cout << "OK: " << o.input << ": " << plural(spec.agents.size(), "agent") << ", "
                  << spec.policies.size() << (spec.policies.size() == 1 ? " policy" : " policies")
                  << ", " << plural(spec.obstacles.size(), "obstacle") << ", end time ";
        if (spec.endTime >= 0) std::cout << ch::formatNumber(spec.endTime) << " s";
        else std::cout << "none (runs until every agent has left)";
        std::cout << ", delta_time " << ch::formatNumber(sim->deltaTime()) << " s\n";
    }
    return kExitOk;
}

/// OpenMP threads that wait for each other spin for a while (libgomp's default); on a machine
/// whose cores are busy with other jobs, a spinning thread burns the time slice its partner needs
/// and a run can become many times slower than on one thread. libgomp reads its settings before
/// main(), so the program cannot change them itself: it says what to do instead.
static void busyMachineNote(std::ostream& err, int threads, std::size_t agents) {
    if (threads < 2 || !ch::parallelNeighbourLoop(agents)) return;
    if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return;
    double load[1] = {0};
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (getloadavg(load, 1) != 1 || load[0] < cores - 0.5) return;
    err << "crowdhealth: note: the machine is busy (load " << ch::formatNumber(load[0], 2) << " on " << cores
        << " cores); " << threads << " threads waiting for each other may run slower than one. If so, use -t 1 or "
        << "set OMP_WAIT_POLICY=passive (results are the same)\n";
}

int runScenario(const Options& o) {
    if (o.plot && !plotAvailable("--plot")) return kExitRuntime;  // say so before a long run, not after
    if (o.replications) return runReplications(o);
    const std::unique_ptr<ch::Simulation> sim = loadAndBuild(o);
    if (!sim) return kExitInput;
    const std::optional<RunPlan> plan = planRun(o, sim->spec(), true);
    if (!plan) return kExitInput;

    const fs::path outDir(o.output);
    if (const auto problem = checkOutputFolder(outDir, o.overwrite)) {
        std::cerr << "crowdhealth: error: " << problem->message << "\n";
        return problem->exitStatus;
    }

    const int threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (!o.quiet) busyMachineNote(std::cerr, threads, sim->spec().agents.size());
    ProgressBar progress(std::cerr, !o.quiet && ProgressBar::stderrIsTerminal(),
                         plan->useSafetyCap ? -1.0 : plan->info.endTime);
    RunHooks hooks;
    hooks.afterStep = [&](const ch::Simulation& s) { progress.update(s); };
    hooks.afterLoop = [&](const ch::Simulation& s) { progress.finish(s); };
    hooks.releaseAgentSpecs = true;  // the progress line reads totalAgents(), not the specs

    installInterruptHandlers();
    const RunOutcome outcome = simulateAndWrite(*sim, *plan, outDir, threads, o, hooks);
    if (!outcome.error.empty()) {
        std::cerr << "crowdhealth: error: " << outcome.error << "\n";
        return kExitRuntime;
    }
    for (const std::string& w : outcome.warnings) std::cerr << "crowdhealth: warning: " << w << "\n";
    const ch::RunInfo& info = outcome.info;

    const std::size_t remaining = sim->agents().size() + sim->pending();
    if (info.stoppedAtSafetyCap)
        std::cerr << "crowdhealth: warning: stopped at the safety cap of " << ch::formatNumber(kSafetyCapSeconds)
                  << " s with " << plural(remaining, "agent") << " still in the world; give an end time to run longer\n";
    if (info.interrupted)
        std::cerr << "crowdhealth: interrupted at t = " << ch::formatNumber(sim->time())
                  << " s; the outputs in " << outDir.string() << " cover the time simulated\n";

    if (o.quiet && o.timing) std::cout << "crowdhealth: " << o.input << "\n" << timingLine(info);
    if (!o.quiet) {
        std::cout << "crowdhealth: " << o.input << (info.interrupted ? " (interrupted)" : "") << "\n"
                  << "  simulated time  " << ch::formatNumber(sim->time()) << " s in "
                  << plural(sim->coarseSteps(), "step") << " of " << ch::formatNumber(sim->deltaTime()) << " s\n"
                  << "  wall time       " << formatDuration(info.wallTimeSeconds) << " ("
                  << ch::formatNumber(info.wallTimeSeconds, 3) << " s, " << plural(threads, "thread") << ")\n"
                  << (o.timing ? timingLine(info) : std::string())
                  << "  agents          " << sim->totalAgents() << " total, " << sim->evacuations().size()
                  << " evacuated, " << sim->leftWorld() << " left the world, " << remaining << " remaining\n";
        if (const ch::Navigation* nav = sim->navigation(); nav != nullptr && nav->grid() != nullptr)
            std::cout << "  navigation      " << plural(nav->fieldCount(), "path field") << " on " << nav->grid()->nx() << " x "
                      << nav->grid()->ny() << " cells of " << ch::formatNumber(nav->grid()->cellSize()) << " m, prepared in "
                      << ch::formatNumber(nav->preparationSeconds(), 3) << " s\n";
        std::cout << "  output          " << outDir.string() << "\n";
        std::cout << ch::verdictText(outcome.verdict);  // the safety verdict (summary.json "verdict")
    }
    if (o.plot && info.interrupted)
        std::cerr << "crowdhealth: no plots after an interruption; draw them with: crowdhealth plot " << outDir.string() << "\n";
    else if (o.plot && plotOutputs(outDir, o.quiet) != kExitOk)
        return kExitRuntime;
    return info.interrupted ? kExitInterrupted : kExitOk;
}

}  // namespace chcli
