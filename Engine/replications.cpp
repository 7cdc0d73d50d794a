// crowdhealth --replications: one scenario with seeds S ... S+N−1, several runs at a time (see run.h).
//
// Every seed's scenario is loaded (and the first one built) before anything is written, so a
// scenario error exits with status 2 and leaves no trace. Then up to THREADS worker threads take
// the next run, build its simulation and run it on one OpenMP thread into OUTDIR/run_<k> exactly
// as a single run does (same code: simulateAndWrite), so run k is the single run with
// --seed S+k. The main thread only draws the progress line and prints the workers' messages.
// Ctrl-C: the runs going stop after their current step and write their folders; runs not
// started yet are not started; summary.csv lists the runs that ran, interrupted ones marked.
#include "run.h"

#include "exit_codes.h"
#include "output_folder.h"
#include "plot.h"
#include "progress.h"
#include "scenario_run.h"
#include "signals.h"

#include <crowdhealth/io/output.h>
#include <crowdhealth/core/simulation.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace chcli {

namespace fs = std::filesystem;

namespace {

/// summary.csv's mean_density_at_15s is mean_density at this simulated time (s), as in van Toll
/// et al. 2021, Table 1.
constexpr double kDensityProbeTime = 15.0;

/// "run_007": three digits, more when there are more than 1000 runs (so names sort by number).
std::string runFolderName(std::size_t k, std::size_t total) {
    std::size_t digits = 3;
    for (std::size_t limit = 1000; total > limit; limit *= 10) ++digits;
    const std::string number = std::to_string(k);
    return "run_" + std::string(digits > number.size() ? digits - number.size() : 0, '0') + number;
}

/// What the worker of run k leaves for the main thread (read only after the workers are joined).
struct RunRecord {
    bool started = false;
    bool completed = false;  ///< ran (perhaps interrupted) and wrote its folder
    ch::ReplicationRow row;
};

/// Shared between the workers and the main thread.
struct Shared {
    std::mutex mutex;
    std::condition_variable wake;
    std::vector<std::string> messages;  ///< stderr lines from the workers, printed by the main thread
    std::size_t workersGoing = 0;
    std::size_t runsDone = 0;
    bool anyFailed = false;

    void say(std::string line) {
        {
            const std::lock_guard<std::mutex> lock(mutex);
            messages.push_back(std::move(line));
        }
        wake.notify_one();
    }
};

/// Per run, read by the progress line while the run goes.
struct RunClock {
    std::atomic<int> phase{0};    ///< 0 waiting, 1 running, 2 over
    std::atomic<double> time{0};  ///< simulated time (s)
};

std::string fixed(double v, int decimals) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals);
    if (res.ec != std::errc()) return ch::formatNumber(v);
    std::string s(buf, res.ptr);
    if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);  // "-0.00"
    return s;
}

/// The summary table on stdout: the columns of summary.csv, aligned, with a few decimals each.
void printTable(std::ostream& out, const std::vector<ch::ReplicationRow>& rows) {
    // Decimals per statistic column (kReplicationStatColumns order); evacuated is a count.
    constexpr std::array<int, ch::kReplicationStatColumns.size()> kDecimals = {0, 2, 3, 3, 3, 2, 3};
    const bool anyInterrupted = std::any_of(rows.begin(), rows.end(), [](const auto& r) { return r.interrupted; });

    std::vector<std::vector<std::string>> table;
    std::vector<std::string> header = {"run", "seed"};
    header.insert(header.end(), ch::kReplicationStatColumns.begin(), ch::kReplicationStatColumns.end());
    if (anyInterrupted) header.push_back("interrupted");
    table.push_back(header);

    auto cell = [](const std::optional<double>& v, int decimals) {
        return v && std::isfinite(*v) ? fixed(*v, decimals) : std::string("-");
    };
    for (const ch::ReplicationRow& r : rows) {
        std::vector<std::string> line = {r.run, std::to_string(r.seed)};
        const auto values = r.statValues();
        for (std::size_t c = 0; c < values.size(); ++c) line.push_back(cell(values[c], kDecimals[c]));
        if (anyInterrupted) line.push_back(r.interrupted ? "yes" : "no");
        table.push_back(line);
    }
    const auto stats = ch::replicationStats(rows);
    std::vector<std::string> mean = {"mean", ""}, sd = {"sd", ""}, n = {"n", ""};
    for (std::size_t c = 0; c < stats.size(); ++c) {
        const int decimals = std::max(kDecimals[c], c == 0 ? 1 : 0);  // a mean count has a fraction
        mean.push_back(cell(stats[c].mean, decimals + 1));
        sd.push_back(cell(stats[c].sd, decimals + 1));
        n.push_back(std::to_string(stats[c].count));
    }
    for (auto* line : {&mean, &sd, &n}) {
        if (anyInterrupted) line->push_back("");
        table.push_back(*line);
    }

    std::vector<std::size_t> width(header.size(), 0);
    for (const auto& line : table)
        for (std::size_t c = 0; c < line.size(); ++c) width[c] = std::max(width[c], line[c].size());
    for (std::size_t i = 0; i < table.size(); ++i) {
        if (i == rows.size() + 1) {  // a rule between the runs and the statistics
            std::size_t total = 0;
            for (const std::size_t w : width) total += w + 2;
            out << std::string(total - 2, '-') << "\n";
        }
        std::string text;
        for (std::size_t c = 0; c < table[i].size(); ++c) {
            const std::string& s = table[i][c];
            const std::string pad(width[c] - s.size(), ' ');
            if (c > 0) text += "  ";
            text += c == 0 ? s + pad : pad + s;  // the run column left-aligned, numbers right-aligned
        }
        while (!text.empty() && text.back() == ' ') text.pop_back();
        out << text << "\n";
    }
}

}  // namespace

int runReplications(const Options& o) {
    const std::size_t n = static_cast<std::size_t>(*o.replications);

    // ---- everything that can be wrong with the input, before anything is written ----
    std::vector<std::optional<ch::ScenarioSpec>> specs(n);
    specs[0] = loadSpec(o, o.seed, true);
    if (!specs[0]) return kExitInput;
    const std::uint64_t firstSeed = specs[0]->seed;
    if (firstSeed > std::numeric_limits<std::uint64_t>::max() - (n - 1)) {
        std::cerr << "crowdhealth: error: the seeds " << firstSeed << " ... " << firstSeed << "+" << (n - 1)
                  << " do not fit in 64 bits; give a smaller --seed\n"
                     "crowdhealth: nothing was simulated or written\n";
        return kExitInput;
    }
    if (!buildSimulation(*specs[0], o)) return kExitInput;  // e.g. unknown component names
    const std::optional<RunPlan> plan = planRun(o, *specs[0], true);
    if (!plan) return kExitInput;
    // Run k draws its random numbers from seed S+k only: the scenario is loaded once per seed
    // (generated agents depend on it), all now, so every seed is checked before anything is
    // written and editing the file while the runs go changes none of them. Memory: about one
    // scenario per run until the run starts (~110 KB for the 400-agent doorway).
    for (std::size_t k = 1; k < n; ++k) {
        specs[k] = loadSpec(o, firstSeed + k, false);
        if (!specs[k]) return kExitInput;
    }

    const fs::path outDir(o.output);
    std::vector<std::string> runNames(n);
    for (std::size_t k = 0; k < n; ++k) runNames[k] = runFolderName(k, n);
    // The folder and every run folder this will write into: files crowdhealth did not write
    // there refuse the whole set (unless --overwrite) before anything is written.
    if (!o.overwrite) {
        OutputFolder top(outDir);
        std::vector<std::string> unknown = top.unknownEntries();
        for (std::size_t k = 0; k < n && unknown.size() < 100; ++k) {
            if (!top.previous().count(runNames[k] + "/")) continue;  // absent, or already unknown above
            for (const std::string& u : OutputFolder(outDir / runNames[k]).unknownEntries())
                unknown.push_back(runNames[k] + "/" + u);
        }
        if (!unknown.empty()) {
            std::cerr << "crowdhealth: error: " << unknownEntriesMessage(outDir, unknown) << "\n";
            return kExitInput;
        }
    }
    if (const auto problem = outputFolderProblem(outDir)) {
        std::cerr << "crowdhealth: error: " << *problem << "\n";
        return kExitRuntime;
    }
    // The manifest lists every run folder before the first is created (a killed set leaves none
    // the next run would not know); at the end it lists summary.csv and the folders written.
    OutputFolder folder(outDir);
    {
        std::vector<std::string> planned = {"summary.csv"};
        for (const std::string& r : runNames) planned.push_back(r + "/");
        try {
            folder.announce(planned);
        } catch (const std::exception& e) {
            std::cerr << "crowdhealth: error: cannot write the outputs: " << e.what() << "\n";
            return kExitRuntime;
        }
    }

    const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
    const std::size_t atOnce = o.threads > 0 ? static_cast<std::size_t>(o.threads) : hardware;
    const std::size_t workers = std::min(n, atOnce);

    std::vector<RunRecord> records(n);
    for (std::size_t k = 0; k < n; ++k) {
        records[k].row.run = runNames[k];
        records[k].row.seed = firstSeed + k;
    }
    const std::unique_ptr<RunClock[]> clocks(new RunClock[n]);
    Shared shared;
    std::atomic<std::size_t> nextRun{0};

    // One run, in a worker thread. Writes only records[k] and clocks[k].
    auto runOne = [&](std::size_t k) {
        RunRecord& rec = records[k];
        const std::string& name = rec.row.run;
        std::unique_ptr<ch::Simulation> sim;
        try {
            sim = std::make_unique<ch::Simulation>(*specs[k]);
        } catch (const std::exception& e) {
            throw std::runtime_error("cannot build the scenario with seed " + std::to_string(rec.row.seed) + ": " +
                                     e.what());
        }
        specs[k].reset();  // the simulation holds its own copy
        const fs::path dir = outDir / name;
        if (const auto problem = outputFolderProblem(dir)) throw std::runtime_error(*problem);

        RunHooks hooks;
        hooks.afterStep = [&](const ch::Simulation& s) { clocks[k].time.store(s.time(), std::memory_order_relaxed); };
        hooks.probeMeanDensityAt = kDensityProbeTime;
        hooks.releaseAgentSpecs = true;
        const RunOutcome outcome = simulateAndWrite(*sim, *plan, dir, 1, o, hooks);
        if (!outcome.error.empty()) throw std::runtime_error(outcome.error);
        for (const std::string& w : outcome.warnings) shared.say("crowdhealth: warning: " + name + ": " + w);

        ch::ReplicationRow& row = rec.row;
        row.evacuated = sim->evacuations().size();
        row.evacuationTime = ch::runEvacuationTime(*sim);
        row.flow = ch::runFlow(*sim);
        row.peakMeanDensity = outcome.peaks.maxMeanDensity;
        row.meanDensityAt15s = outcome.probedMeanDensity;
        row.peakMaxContactAccel = outcome.peaks.maxContactAccel;
        row.peakWallPenetration = outcome.peaks.maxWallPenetration;
        row.interrupted = outcome.info.interrupted;
        rec.completed = true;
        if (outcome.info.stoppedAtSafetyCap)
            shared.say("crowdhealth: warning: " + name + " stopped at the safety cap of " +
                       ch::formatNumber(kSafetyCapSeconds) + " s with " +
                       plural(sim->agents().size() + sim->pending(), "agent") + " still in the world");
    };

    auto worker = [&] {
        for (;;) {
            if (interruptRequested()) break;  // runs not started yet stay so
            const std::size_t k = nextRun.fetch_add(1);
            if (k >= n) break;
            records[k].started = true;
            clocks[k].phase.store(1);
            bool failed = false;
            try {
                runOne(k);
            } catch (const std::exception& e) {
                failed = true;
                shared.say("crowdhealth: error: " + records[k].row.run + " (seed " + std::to_string(records[k].row.seed) +
                           "): " + e.what());
            }
            clocks[k].phase.store(2);
            {
                const std::lock_guard<std::mutex> lock(shared.mutex);
                ++shared.runsDone;
                shared.anyFailed = shared.anyFailed || failed;
            }
            shared.wake.notify_one();
        }
        {
            const std::lock_guard<std::mutex> lock(shared.mutex);
            --shared.workersGoing;
        }
        shared.wake.notify_one();
    };

    ReplicationProgress progress(std::cerr, !o.quiet && ProgressBar::stderrIsTerminal(), n,
                                 plan->useSafetyCap ? -1.0 : plan->info.endTime);
    auto drawProgress = [&](std::size_t done) {
        std::size_t running = 0;
        double slowest = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < n; ++k) {
            if (clocks[k].phase.load() != 1) continue;
            ++running;
            slowest = std::min(slowest, clocks[k].time.load(std::memory_order_relaxed));
        }
        progress.draw(done, running, slowest);
    };

    installInterruptHandlers();
    const auto wallStart = std::chrono::steady_clock::now();
    std::vector<std::thread> pool;
    shared.workersGoing = workers;
    for (std::size_t w = 0; w < workers; ++w) pool.emplace_back(worker);
    {
        std::unique_lock<std::mutex> lock(shared.mutex);
        std::size_t shownDone = 0;
        for (;;) {
            // Wakes when a run ends, a message arrives or every worker is through, else every
            // 0.1 s to redraw.
            shared.wake.wait_for(lock, std::chrono::milliseconds(100), [&] {
                return !shared.messages.empty() || shared.runsDone != shownDone || shared.workersGoing == 0;
            });
            std::vector<std::string> messages;
            messages.swap(shared.messages);
            const std::size_t done = shownDone = shared.runsDone;
            const bool over = shared.workersGoing == 0;
            lock.unlock();
            if (!messages.empty()) progress.clear();
            for (const std::string& m : messages) std::cerr << m << "\n";
            drawProgress(done);
            lock.lock();
            if (over && shared.messages.empty()) break;
        }
    }
    for (std::thread& t : pool) t.join();
    progress.finish();
    const double wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();

    // ---- summary.csv and the table ----
    std::vector<ch::ReplicationRow> rows;
    std::size_t notStarted = 0, interrupted = 0;
    for (const RunRecord& rec : records) {
        if (!rec.started) ++notStarted;
        if (!rec.completed) continue;
        rows.push_back(rec.row);
        if (rec.row.interrupted) ++interrupted;
    }
    try {
        ch::writeFileAtomic(outDir / "summary.csv", ch::replicationsCsv(rows));
        // The run folders of an earlier set that this one did not write (more replications, or
        // runs not started after Ctrl-C) go: their own files, never anything else.
        std::vector<std::string> written = {"summary.csv"};
        for (const RunRecord& rec : records)
            if (rec.started) written.push_back(rec.row.run + "/");
        for (const std::string& w : folder.settle(written)) std::cerr << "crowdhealth: warning: " << w << "\n";
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth: error: cannot write the summary: " << e.what() << "\n";
        return kExitRuntime;
    }

    const bool wasInterrupted = interruptRequested();
    if (wasInterrupted)
        std::cerr << "crowdhealth: interrupted: " << plural(interrupted, "run") << " stopped early (folders cover the "
                  << "time simulated, marked in summary.csv), " << plural(notStarted, "run")
                  << " not started; statistics use the runs that completed\n";

    if (!o.quiet) {
        std::cout << "crowdhealth: " << o.input << ", " << plural(n, "replication") << ", seeds " << firstSeed
                  << " to " << firstSeed + (n - 1) << (wasInterrupted ? " (interrupted)" : "") << "\n\n";
        printTable(std::cout, rows);
        std::cout << "\n  total wall time  " << formatDuration(wallSeconds) << " (" << ch::formatNumber(wallSeconds, 3)
                  << " s, " << plural(rows.size(), "run") << ", at most " << workers << " at a time, "
                  << plural(hardware, "hardware thread") << ")\n"
                  << "  output           " << (outDir / "summary.csv").string();
        const std::size_t started = n - notStarted;  // runs start in order
        if (started > 0)
            std::cout << " and " << (outDir / records[0].row.run).string()
                      << (started > 1 ? " ... " + (outDir / records[started - 1].row.run).string() : std::string());
        std::cout << "\n";
    }
    bool plotFailed = false;
    if (o.plot && wasInterrupted)
        std::cerr << "crowdhealth: no plots after an interruption; draw them with: crowdhealth plot " << outDir.string() << "\n";
    else if (o.plot && !rows.empty())
        plotFailed = plotOutputs(outDir, o.quiet) != kExitOk;
    if (shared.anyFailed || plotFailed) return kExitRuntime;
    return wasInterrupted ? kExitInterrupted : kExitOk;
}

}  // namespace chcli
