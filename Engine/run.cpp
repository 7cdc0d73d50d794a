// crowdhealth — validating and running a scenario (see run.h).
#include "run.h"

#include "exit_codes.h"
#include "progress.h"
#include "signals.h"

#include <crowdhealth/output.h>
#include <crowdhealth/simulation.h>
#include <crowdhealth/xml.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

namespace chcli {

namespace fs = std::filesystem;

namespace {

/// Loads the scenario and builds the simulation. On any problem prints every diagnostic to
/// stderr and returns nullptr; nothing has been simulated or written by then.
std::unique_ptr<ch::Simulation> loadAndBuild(const Options& o) {
    ch::Diagnostics diags;
    ch::LoadOptions loadOptions;
    loadOptions.seed = o.seed;
    std::optional<ch::ScenarioSpec> spec;
    try {
        spec = ch::loadScenario(o.input, diags, loadOptions);
    } catch (const std::exception& e) {  // the loader should report, not throw; be safe anyway
        diags.error(ch::SourceLoc{o.input, 0}, std::string("cannot load the scenario: ") + e.what());
    }
    diags.print(std::cerr);  // warnings too, also on success
    if (!spec || diags.hasErrors()) {
        if (!diags.hasErrors()) std::cerr << o.input << ": error: the scenario could not be loaded\n";
        const int n = std::max(1, diags.errorCount());
        std::cerr << "crowdhealth: " << n << " error" << (n == 1 ? "" : "s") << " in " << o.input
                  << "; nothing was simulated or written\n";
        return nullptr;
    }
    try {
        // Throws for names the registry does not know (e.g. a policy file from a newer version).
        return std::make_unique<ch::Simulation>(*spec);
    } catch (const std::exception& e) {
        std::cerr << o.input << ": error: " << e.what() << "\n"
                  << "crowdhealth: the scenario cannot be built; nothing was simulated or written\n";
        return nullptr;
    }
}

bool validTrajectoryChoice(const std::string& t) { return t == "umans" || t == "txt" || t == "both" || t == "none"; }

/// Creates the output folder and checks that a file can be created in it, so a run does not
/// simulate for an hour and then fail to write. Prints the reason and returns false on failure.
bool prepareOutputFolder(const fs::path& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir)) {
        std::cerr << "crowdhealth: error: cannot create the output folder '" << dir.string() << "'"
                  << (ec ? ": " + ec.message() : std::string(": a file of that name exists")) << "\n";
        return false;
    }
    try {
        ch::AtomicFile probe(dir / ".crowdhealth-write-test");  // removed again without commit()
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth: error: the output folder '" << dir.string() << "' is not writable: " << e.what()
                  << "\n";
        return false;
    }
    return true;
}

std::string plural(std::size_t n, const char* word) {
    return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
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

int runScenario(const Options& o) {
    const std::unique_ptr<ch::Simulation> sim = loadAndBuild(o);
    if (!sim) return kExitInput;
    const ch::ScenarioSpec& spec = sim->spec();

    const std::string trajectories = o.trajectories.value_or(spec.output.trajectories);
    if (!validTrajectoryChoice(trajectories)) {
        std::cerr << spec.output.loc.file << ":" << spec.output.loc.line
                  << ": error: <Output> trajectories must be umans, txt, both or none, not '" << trajectories
                  << "'\ncrowdhealth: nothing was simulated or written\n";
        return kExitInput;
    }
    const bool writeUmans = trajectories == "umans" || trajectories == "both";
    const bool writePedPy = trajectories == "txt" || trajectories == "both";

    // End time: --end-time > the scenario's > the safety cap. The cap is not set as the
    // simulation's end time, because then finished() would wait for it even once everyone left.
    ch::RunInfo info;
    info.scenario = o.input;
    bool useSafetyCap = false;
    if (o.endTime) {
        sim->setEndTime(*o.endTime);
        info.endTime = *o.endTime;
        info.endTimeSource = "command line";
    } else if (sim->endTime() >= 0) {
        info.endTime = sim->endTime();
        info.endTimeSource = "scenario";
    } else {
        useSafetyCap = true;
        info.endTime = -1;
        info.endTimeSource = "none";
        std::cerr << "crowdhealth: warning: " << o.input
                  << " has no end_time and no --end-time was given: the run ends when every agent has left, or at "
                     "the safety cap of "
                  << ch::formatNumber(kSafetyCapSeconds) << " s of simulated time\n";
    }

    const fs::path outDir(o.output);
    if (!prepareOutputFolder(outDir)) return kExitRuntime;

    const int threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    sim->setThreads(threads);
    info.threads = threads;

    ch::MetricsRecorder metrics(spec.output.metricsInterval);
    ch::TrajectoryRecorder trajectory;
    const bool recordTrajectories = writeUmans || writePedPy;
    ProgressBar progress(std::cerr, !o.quiet && ProgressBar::stderrIsTerminal(), useSafetyCap ? -1.0 : info.endTime);

    installInterruptHandlers();
    bool raisedForTest = false;
    const auto wallStart = std::chrono::steady_clock::now();
    try {
        metrics.sample(*sim);  // the t = 0 row, before the first step
        if (recordTrajectories) trajectory.record(*sim);
        while (!sim->finished()) {
            if (useSafetyCap && sim->time() + 1e-9 * kSafetyCapSeconds >= kSafetyCapSeconds) {
                info.stoppedAtSafetyCap = true;
                break;
            }
            sim->stepCoarse();
            metrics.maybeSample(*sim);
            if (recordTrajectories) trajectory.record(*sim);
            progress.update(*sim);
            if (o.interruptAfterSteps && !raisedForTest && sim->coarseSteps() >= *o.interruptAfterSteps) {
                raisedForTest = true;
                std::raise(SIGINT);
            }
            if (interruptRequested()) {  // stop after the step that was running, outputs stay valid
                info.interrupted = true;
                break;
            }
        }
        metrics.finish(*sim);  // the row of the final time, if it is not on the interval
    } catch (const std::exception& e) {
        progress.finish(*sim);
        std::cerr << "crowdhealth: error: the simulation failed at t = " << ch::formatNumber(sim->time())
                  << " s: " << e.what() << "\n";
        return kExitRuntime;
    }
    progress.finish(*sim);
    info.wallTimeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();

    // summary.json last: its presence says that every other file is complete.
    try {
        metrics.write(outDir / "metrics.csv");
        ch::writeFileAtomic(outDir / "evacuations.csv", ch::evacuationsCsv(*sim));
        if (writeUmans) trajectory.writeUmans(outDir);
        if (writePedPy) trajectory.writePedPy(outDir / "trajectories.txt", sim->deltaTime());
        ch::writeFileAtomic(outDir / "summary.json", ch::summaryJson(*sim, info, metrics.peaks()));
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth: error: cannot write the outputs: " << e.what() << "\n";
        return kExitRuntime;
    }

    const std::size_t remaining = sim->agents().size() + sim->pending();
    if (info.stoppedAtSafetyCap)
        std::cerr << "crowdhealth: warning: stopped at the safety cap of " << ch::formatNumber(kSafetyCapSeconds)
                  << " s with " << plural(remaining, "agent") << " still in the world; give an end time to run longer\n";
    if (info.interrupted)
        std::cerr << "crowdhealth: interrupted at t = " << ch::formatNumber(sim->time())
                  << " s; the outputs in " << outDir.string() << " cover the time simulated\n";

    if (!o.quiet) {
        std::cout << "crowdhealth: " << o.input << (info.interrupted ? " (interrupted)" : "") << "\n"
                  << "  simulated time  " << ch::formatNumber(sim->time()) << " s in "
                  << plural(sim->coarseSteps(), "step") << " of " << ch::formatNumber(sim->deltaTime()) << " s\n"
                  << "  wall time       " << formatDuration(info.wallTimeSeconds) << " ("
                  << ch::formatNumber(info.wallTimeSeconds, 3) << " s, " << plural(threads, "thread") << ")\n"
                  << "  agents          " << sim->totalAgents() << " total, " << sim->evacuations().size()
                  << " evacuated, " << sim->leftWorld() << " left the world, " << remaining << " remaining\n"
                  << "  output          " << outDir.string() << "\n";
    }
    return info.interrupted ? kExitInterrupted : kExitOk;
}

}  // namespace chcli
