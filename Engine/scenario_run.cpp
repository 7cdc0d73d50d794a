// crowdhealth — loading and running one scenario (see scenario_run.h).
#include "scenario_run.h"

#include "crowdhealth/measure/recorder.h"

#include "exit_codes.h"
#include "output_folder.h"

#include "run.h"
#include "signals.h"

#include <crowdhealth/io/xml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>

namespace chcli {

namespace fs = std::filesystem;

namespace {

/// --debug-interrupt-after raises SIGINT once per program, also when several runs go at once.
std::atomic<bool> g_raisedForTest{false};

}  // namespace

std::string plural(std::size_t n, const char* word) {
    return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

std::optional<ch::ScenarioSpec> loadSpec(const Options& o, std::optional<std::uint64_t> seed, bool printWarnings) {
    return loadSpec(o, seed, printWarnings, std::cerr);
}

std::optional<ch::ScenarioSpec> loadSpec(const Options& o, std::optional<std::uint64_t> seed, bool printWarnings,
                                         std::ostream& err) {
    ch::Diagnostics diags;
    ch::LoadOptions loadOptions;
    loadOptions.seed = seed;
    std::optional<ch::ScenarioSpec> spec;
    try {
        spec = ch::loadScenario(o.input, diags, loadOptions);
    } catch (const std::exception& e) {  // the loader should report, not throw; be safe anyway
        diags.error(ch::SourceLoc{o.input, 0}, std::string("cannot load the scenario: ") + e.what());
    }
    if (printWarnings || diags.hasErrors()) diags.print(err);  // warnings too, also on success
    if (!spec || diags.hasErrors()) {
        if (!diags.hasErrors()) err << o.input << ": error: the scenario could not be loaded\n";
        const int n = std::max(1, diags.errorCount());
        err << "crowdhealth: " << n << " error" << (n == 1 ? "" : "s") << " in " << o.input;
        if (seed && o.replications) err << " with seed " << *seed;
        err << "; nothing was simulated or written\n";
        return std::nullopt;
    }
    // --flow-first/--flow-last: one may be given alone, so check the pair the run will use.
    if (o.flowFirst) spec->output.flowFirst = *o.flowFirst;
    if (o.flowLast) spec->output.flowLast = *o.flowLast;
    if ((o.flowFirst || o.flowLast) && spec->output.flowLast <= spec->output.flowFirst) {
        err << "crowdhealth: error: the flow would run from evacuee " << spec->output.flowFirst << " to "
                  << spec->output.flowLast << " (" << (o.flowFirst ? "--flow-first" : "<Output flow_first>")
                  << " with " << (o.flowLast ? "--flow-last" : "<Output flow_last>")
                  << "); the last must come after the first\n"
                     "crowdhealth: nothing was simulated or written\n";
        return std::nullopt;
    }
    return spec;
}

std::unique_ptr<ch::Simulation> buildSimulation(ch::ScenarioSpec spec, const Options& o) {
    return buildSimulation(std::move(spec), o, std::cerr);
}

std::unique_ptr<ch::Simulation> buildSimulation(ch::ScenarioSpec spec, const Options& o, std::ostream& err) {
    // A large venue takes seconds to prepare its paths (≈ 0.2 µs per cell and field): say so first.
    if (const auto& nav = spec.venue.navigation; nav && !o.quiet && spec.world.type == ch::WorldType::Planar) {
        const double h = nav->grid.cellSize;
        const double cells = std::ceil((spec.world.xmax - spec.world.xmin) / h) * std::ceil((spec.world.ymax - spec.world.ymin) / h);
        const double fields = static_cast<double>(spec.venue.targets.size());
        if (cells * std::max(1.0, fields) > 5e6)
            err << "crowdhealth: preparing the paths of the venue (" << ch::formatNumber(cells, 3) << " cells of "
                      << ch::formatNumber(h) << " m, " << ch::formatNumber(fields) << " targets and exits, and one per "
                      << "distinct goal)…\n";
    }
    try {
        // Throws for names the registry does not know (e.g. a policy file from a newer version).
        return std::make_unique<ch::Simulation>(std::move(spec));
    } catch (const std::exception& e) {
        err << o.input << ": error: " << e.what() << "\n"
                  << "crowdhealth: the scenario cannot be built; nothing was simulated or written\n";
        return nullptr;
    }
}

std::optional<RunPlan> planRun(const Options& o, const ch::ScenarioSpec& spec, bool warn) {
    return planRun(o, spec, warn, std::cerr);
}

std::optional<RunPlan> planRun(const Options& o, const ch::ScenarioSpec& spec, bool warn, std::ostream& err) {
    RunPlan plan;
    const std::string trajectories = o.trajectories.value_or(spec.output.trajectories);
    const std::optional<ch::TrajectoryFormats> formats = ch::parseTrajectoryFormats(trajectories);
    if (!formats) {  // the loader and the command line check it already; a spec built by hand may not
        err << spec.output.loc.file << ":" << spec.output.loc.line << ": error: <Output> trajectories must be "
                  << ch::kTrajectoryFormatWords << ", or a comma-separated list of them, not '" << trajectories
                  << "'\ncrowdhealth: nothing was simulated or written\n";
        return std::nullopt;
    }
    plan.trajectories = *formats;
    if (formats->bin) {
        // trajectories.bin stores ids as uint32: refuse before the run rather than fail at its end.
        for (const ch::AgentSpec& a : spec.agents) {
            if (a.id >= 0 && static_cast<std::uint64_t>(a.id) <= ch::trajbin::kMaxId) continue;
            err << a.loc.file << ":" << a.loc.line << ": error: agent id " << a.id
                      << " does not fit in trajectories.bin (ids up to " << ch::trajbin::kMaxId
                      << "); use --trajectories txt or umans, or smaller ids\n"
                         "crowdhealth: nothing was simulated or written\n";
            return std::nullopt;
        }
    }
    plan.trajectoryInterval = o.trajectoryInterval.value_or(spec.output.trajectoryInterval);
    if (warn && o.trajectoryInterval) {
        // The loader warns about <Output trajectory_interval>; the command line's value gets the same word.
        const double steps = *o.trajectoryInterval / spec.deltaTime;
        if (steps < 1 - 1e-9)
            err << "crowdhealth: warning: --trajectory-interval " << ch::formatNumber(*o.trajectoryInterval)
                      << " s is shorter than delta_time (" << ch::formatNumber(spec.deltaTime)
                      << " s): trajectories are recorded every coarse step\n";
        else if (std::abs(steps - std::round(steps)) > 1e-9 * steps)
            err << "crowdhealth: warning: --trajectory-interval " << ch::formatNumber(*o.trajectoryInterval)
                      << " s is not a whole multiple of delta_time (" << ch::formatNumber(spec.deltaTime)
                      << " s): frames are taken at the first coarse step at or after each multiple, so they are "
                         "unevenly spaced\n";
    }

    // End time: --end-time > the scenario's > the safety cap. The cap is not set as the
    // simulation's end time, because then finished() would wait for it even once everyone left.
    plan.info.scenario = o.input;
    if (o.endTime) {
        plan.endTimeOverride = *o.endTime;
        plan.info.endTime = *o.endTime;
        plan.info.endTimeSource = "command line";
    } else if (spec.endTime >= 0) {
        plan.info.endTime = spec.endTime;
        plan.info.endTimeSource = "scenario";
    } else {
        plan.useSafetyCap = true;
        plan.info.endTime = -1;
        plan.info.endTimeSource = "none";
        if (warn)
            err << "crowdhealth: warning: " << o.input
                      << " has no end_time and no --end-time was given: the run ends when every agent has left, or "
                         "at the safety cap of "
                      << ch::formatNumber(kSafetyCapSeconds) << " s of simulated time\n";
    }
    return plan;
}

std::optional<std::string> outputFolderProblem(const fs::path& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir))
        return "cannot create the output folder '" + dir.string() + "'" +
               (ec ? ": " + ec.message() : std::string(": a file of that name exists"));
    try {
        ch::AtomicFile probe(dir / ".crowdhealth-write-test");  // removed again without commit()
    } catch (const std::exception& e) {
        return "the output folder '" + dir.string() + "' is not writable: " + e.what();
    }
    return std::nullopt;
}

std::optional<FolderProblem> checkOutputFolder(const fs::path& dir, bool overwrite) {
    if (!overwrite) {
        const std::vector<std::string> unknown = OutputFolder(dir).unknownEntries();
        if (!unknown.empty()) return FolderProblem{unknownEntriesMessage(dir, unknown), kExitInput};
    }
    if (auto problem = outputFolderProblem(dir)) return FolderProblem{*problem, kExitRuntime};
    return std::nullopt;
}

struct RunSession::Recorders {
    Recorders(const ch::ScenarioSpec& spec, std::vector<double> exitWidths)
        : metrics(spec.output.metricsInterval), safety(spec.safety), measurement(spec, std::move(exitWidths)) {
        metrics.setCrowdPressure(&safety);
    }
    ch::MetricsRecorder metrics;
    ch::SafetyRecorder safety;  // crowd measures per cell every coarse step (heat map, verdict)
    // Measurement lines and areas, and the exits' flows (flows.csv, areas.csv, verdict reasons).
    ch::MeasurementRecorder measurement;
    // The text and binary trajectories are streamed into their .tmp files during the run, and
    // renamed with the other outputs at its end (removed if the run fails).
    std::optional<ch::TrajectoryOutput> trajectory;
};

namespace {

std::vector<double> exitWidthsOf(const ch::Simulation& sim) {
    std::vector<double> widths;
    if (const ch::Navigation* nav = sim.navigation())
        for (std::size_t k = 0; k < sim.spec().venue.targets.size(); ++k) widths.push_back(nav->width(static_cast<int>(k)));
    return widths;
}

}  // namespace

RunSession::RunSession(ch::Simulation& sim, const RunPlan& plan, const fs::path& trajectoryDir, int threads)
    : sim_(sim), plan_(plan), info_(plan.info) {
    if (plan.endTimeOverride) sim.setEndTime(*plan.endTimeOverride);
    sim.setThreads(threads);  // OpenMP's thread count is per calling thread
    info_.threads = threads;
    rec_ = std::make_unique<Recorders>(sim.spec(), exitWidthsOf(sim));
    if (plan.trajectories.any())
        rec_->trajectory.emplace(trajectoryDir, plan.trajectories, plan.trajectoryInterval, sim.deltaTime(),
                                 sim.spec().output.trajectoryVelocities);
}

RunSession::~RunSession() = default;

const ch::MetricsRecorder& RunSession::metrics() const { return rec_->metrics; }
ch::MetricsPeaks RunSession::peaks() const { return rec_->metrics.peaks(); }

void RunSession::record(bool first) {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    rec_->safety.record(sim_);  // before the metrics row: it gives the crowd_pressure column
    const auto t1 = Clock::now();
    rec_->measurement.record(sim_);
    const auto t2 = Clock::now();
    if (first) rec_->metrics.sample(sim_);  // the t = 0 row, before the first step
    else rec_->metrics.maybeSample(sim_);
    const auto t3 = Clock::now();
    if (rec_->trajectory) {
        if (first) rec_->trajectory->record(sim_);  // frame 0
        else rec_->trajectory->maybeRecord(sim_);
    }
    const auto t4 = Clock::now();
    const auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
    safetySeconds_ += seconds(t0, t1);
    measurementSeconds_ += seconds(t1, t2);
    metricsSeconds_ += seconds(t2, t3);
    trajectorySeconds_ += seconds(t3, t4);
    recordSeconds_ += seconds(t0, t4);
    wallSeconds_ += seconds(t0, t4);
}

void RunSession::begin() { record(true); }

bool RunSession::done() {
    if (ended_ || sim_.finished()) return true;
    if (plan_.useSafetyCap && sim_.time() + 1e-9 * kSafetyCapSeconds >= kSafetyCapSeconds) {
        info_.stoppedAtSafetyCap = true;
        return true;
    }
    return false;
}

void RunSession::step() {
    using Clock = std::chrono::steady_clock;
    const auto wallStart = Clock::now();
    sim_.stepCoarse();
    const double seconds = std::chrono::duration<double>(Clock::now() - wallStart).count();
    stepSeconds_ += seconds;
    wallSeconds_ += seconds;
    record(false);
}

void RunSession::end() {
    if (ended_) return;
    rec_->metrics.finish(sim_);  // the row of the final time, if it is not on the interval
    rec_->measurement.finish();
    if (rec_->trajectory) rec_->trajectory->finish(sim_);  // likewise the final frame
    info_.wallTimeSeconds = wallSeconds_;
    info_.stepSeconds = stepSeconds_;
    info_.recordSeconds = recordSeconds_;
    info_.safetySeconds = safetySeconds_;
    info_.metricsSeconds = metricsSeconds_;
    info_.measurementSeconds = measurementSeconds_;
    info_.trajectorySeconds = trajectorySeconds_;
    verdict_ = verdict();  // the run's: computed while ended_ is still false
    ended_ = true;
}

ch::Verdict RunSession::verdict() const {
    if (ended_) return verdict_;
    ch::Verdict v = rec_->safety.verdict(sim_);
    ch::addReasons(v, rec_->measurement.reasons());
    return v;
}

std::vector<std::string> RunSession::write(const fs::path& outDir, const std::function<void()>& beforeSummary) {
    end();
    // The files this run writes. The manifest lists them (with the previous run's) before the
    // first is written, so a run killed while writing leaves no file the next run would not know.
    std::vector<std::string> names = {"metrics.csv", "evacuations.csv", "health.csv", "heatmap.csv"};
    if (rec_->trajectory)
        for (std::string& n : rec_->trajectory->fileNames()) names.push_back(std::move(n));
    if (rec_->measurement.hasFlows()) names.push_back("flows.csv");
    if (rec_->measurement.hasAreas()) names.push_back("areas.csv");
    names.push_back("summary.json");
    OutputFolder folder(outDir);

    // summary.json last: its presence says that every other file is complete.
    folder.announce(names);
    rec_->metrics.write(outDir / "metrics.csv");
    ch::writeFileAtomic(outDir / "evacuations.csv", ch::evacuationsCsv(sim_));
    {
        // Streamed: a million agents' health.csv is ~50 MB.
        ch::AtomicFile health(outDir / "health.csv");
        ch::healthCsv(sim_.health(), [&](std::string_view piece) { health.write(piece); });
        health.commit();
    }
    ch::writeFileAtomic(outDir / "heatmap.csv", rec_->safety.heatmapCsv());
    if (rec_->measurement.hasFlows()) ch::writeFileAtomic(outDir / "flows.csv", rec_->measurement.flowsCsv());
    if (rec_->measurement.hasAreas()) ch::writeFileAtomic(outDir / "areas.csv", rec_->measurement.areasCsv());
    if (rec_->trajectory) rec_->trajectory->commit();
    if (beforeSummary) beforeSummary();
    const ch::MetricsPeaks p = peaks();
    ch::writeFileAtomic(outDir / "summary.json", ch::summaryJson(sim_, info_, p, &verdict_));
    // Then the earlier run's files that this one did not write go, and the manifest lists
    // exactly this run's files.
    return folder.settle(names);
}

RunOutcome simulateAndWrite(ch::Simulation& sim, const RunPlan& plan, const fs::path& outDir, int threads,
                            const Options& o, const RunHooks& hooks) {
    RunOutcome result;
    result.info = plan.info;
    result.info.threads = threads;
    std::optional<RunSession> session;
    try {
        session.emplace(sim, plan, outDir, threads);
    } catch (const std::exception& e) {
        result.error = std::string("cannot write the outputs: ") + e.what();
        return result;
    }

    // The probe: the first coarse step at or after the time (same tolerance as the metrics).
    bool probeDone = !hooks.probeMeanDensityAt.has_value();
    auto probe = [&] {
        const double t = sim.time();
        const double due = *hooks.probeMeanDensityAt;
        if (t + 1e-9 * std::max(1.0, std::abs(t)) < due) return;
        probeDone = true;
        const auto& rows = session->metrics().rows();
        result.probedMeanDensity =
            !rows.empty() && rows.back().time == t ? rows.back().meanDensity : ch::measureMetrics(sim).meanDensity;
    };

    const auto wallStart = std::chrono::steady_clock::now();
    try {
        session->begin();
        if (!probeDone) probe();
        // Once every agent is in the world (at once for a crowd placed at t = 0); a no-op after.
        auto release = [&] {
            if (hooks.releaseAgentSpecs) sim.releaseAgentSpecs();
        };
        release();
        while (!session->done()) {
            session->step();
            release();
            if (!probeDone) probe();
            if (hooks.afterStep) hooks.afterStep(sim);
            if (o.interruptAfterSteps && sim.coarseSteps() >= *o.interruptAfterSteps &&
                !g_raisedForTest.exchange(true))
                std::raise(SIGINT);
            if (interruptRequested()) {  // stop after the step that was running, outputs stay valid
                session->info().interrupted = true;
                break;
            }
        }
        session->end();
    } catch (const std::exception& e) {
        if (hooks.afterLoop) hooks.afterLoop(sim);
        result.info = session->info();
        result.error = "the simulation failed at t = " + ch::formatNumber(sim.time()) + " s: " + e.what();
        return result;
    }
    if (hooks.afterLoop) hooks.afterLoop(sim);
    session->info().wallTimeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
    result.peaks = session->peaks();
    result.verdict = session->verdict();

    try {
        result.warnings = session->write(outDir, [&] {
            if (o.killBeforeSummary) std::raise(SIGKILL);  // tests: a kill at the worst instant
        });
    } catch (const std::exception& e) {
        result.error = std::string("cannot write the outputs: ") + e.what();
    }
    result.info = session->info();
    return result;
}

}  // namespace chcli
