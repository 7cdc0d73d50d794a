// crowdhealth sweep — see sweep.h and docs/sweeps.md.
#include "sweep.h"

#include "cli.h"
#include "exit_codes.h"
#include "job_pool.h"
#include "text_numbers.h"

#include "plot_gnuplot.h"
#include "progress.h"
#include "scenario_run.h"
#include "signals.h"

#include <crowdhealth/core/plugins.h>
#include <crowdhealth/core/simulation.h>
#include <crowdhealth/health/safety.h>
#include <crowdhealth/io/output.h>
#include <crowdhealth/io/xml.h>

#include <boost/math/distributions/students_t.hpp>
#include <boost/program_options.hpp>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

namespace chcli {

namespace fs = std::filesystem;
namespace po = boost::program_options;

namespace {

/// The numeric outputs of a run, in file order (sweep.csv and sweep-summary.csv).
const std::vector<std::string> kOutputs = {"evacuated",          "evacuation_time", "flow", "peak_density",
                                           "peak_contact_accel", "injured",         "verdict_rank"};
/// Their labels on the plots.
const std::vector<std::string> kOutputLabels = {"evacuated (persons)", "evacuation time (s)",
                                                "flow (persons/s)",    "peak density (1/m^2)",
                                                "peak contact acceleration (m/s^2)", "injured (persons)",
                                                "verdict (0 safe, 1 caution, 2 dangerous, 3 critical)"};

std::optional<double> outputValue(const SweepResult& r, std::size_t k) {
    switch (k) {
        case 0: return static_cast<double>(r.evacuated);
        case 1: return r.evacuationTime;
        case 2: return r.flow;
        case 3: return r.peakDensity;
        case 4: return r.peakContactAccel;
        case 5: return static_cast<double>(r.injured);
        default: return static_cast<double>(ch::verdictRank(r.verdict));
    }
}



std::string cell(const std::optional<double>& v) { return v ? csvCell(*v) : std::string(); }



/// "run_000017": as many digits as the largest id needs, at least six.
std::string runName(std::size_t id, std::size_t total) {
    std::size_t digits = 6;
    for (std::size_t limit = 1000000; total > limit; limit *= 10) ++digits;
    const std::string number = std::to_string(id);
    return "run_" + std::string(digits > number.size() ? digits - number.size() : 0, '0') + number;
}


}  // namespace

// ---- VALUES ----------------------------------------------------------------------------------

std::optional<std::string> parseSweepValues(const std::string& text, std::vector<double>& values) {
    values.clear();
    if (text.empty()) return "no values (give a list such as 3,5,7 or a range such as 3:7:2)";
    constexpr std::size_t kMaxValues = 100000;
    if (text.find(':') != std::string::npos) {
        const std::vector<std::string> p = splitOn(text, ':');
        if (p.size() != 3) return "a range is FROM:TO:STEP (three numbers), not '" + text + "'";
        double a = 0, b = 0, step = 0;
        for (int k = 0; k < 3; ++k)
            if (!parseDouble(p[k], k == 0 ? a : k == 1 ? b : step))
                return "'" + p[k] + "' in '" + text + "' is not a number";
        if (step <= 0) return "the step of '" + text + "' must be positive";
        if (b < a) return "the range '" + text + "' ends (" + p[1] + ") before it starts (" + p[0] + ")";
        const double count = std::floor((b - a) / step + 1e-9);
        if (count + 1 > kMaxValues) return "the range '" + text + "' has more than 100000 values";
        for (std::size_t k = 0; k <= static_cast<std::size_t>(count); ++k) values.push_back(a + static_cast<double>(k) * step);
    } else {
        for (const std::string& w : splitOn(text, ',')) {
            double v = 0;
            if (w.empty()) return "an empty value in '" + text + "'";
            if (!parseDouble(w, v)) return "'" + w + "' is not a number";
            values.push_back(v);
        }
        if (values.size() > kMaxValues) return "more than 100000 values";
    }
    std::vector<double> sorted = values;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) return "a value is repeated in '" + text + "'";
    return std::nullopt;
}

// ---- (a) the runs ----------------------------------------------------------------------------

std::vector<SweepRun> expandSweep(const std::vector<SweepAxis>& axes, std::uint64_t firstSeed, std::size_t replications) {
    std::size_t combinations = 1;
    for (const SweepAxis& a : axes) combinations *= a.values.size();
    std::vector<SweepRun> runs;
    runs.reserve(combinations * replications);
    for (std::size_t c = 0; c < combinations; ++c) {
        std::vector<double> values(axes.size());
        std::size_t rest = c;
        for (std::size_t k = axes.size(); k-- > 0;) {  // the last axis varies fastest
            values[k] = axes[k].values[rest % axes[k].values.size()];
            rest /= axes[k].values.size();
        }
        for (std::size_t r = 0; r < replications; ++r) {
            SweepRun run;
            run.id = runs.size();
            run.combination = c;
            run.values = values;
            run.seed = firstSeed + r;
            runs.push_back(std::move(run));
        }
    }
    return runs;
}

// ---- (d) records ------------------------------------------------------------------------------

std::string sweepRecordText(const SweepRun& run, const SweepResult& r) {
    std::ostringstream s;
    s << "id " << run.id << "\nseed " << run.seed << "\n";
    for (const double v : run.values) s << "value " << exactNumber(v) << "\n";
    s << "evacuated " << r.evacuated << "\n"
      << "evacuation_time " << (r.evacuationTime ? exactNumber(*r.evacuationTime) : "-") << "\n"
      << "flow " << (r.flow ? exactNumber(*r.flow) : "-") << "\n"
      << "peak_density " << exactNumber(r.peakDensity) << "\n"
      << "peak_contact_accel " << exactNumber(r.peakContactAccel) << "\n"
      << "injured " << r.injured << "\n"
      << "verdict " << r.verdict << "\n"
      << "wall_time " << exactNumber(r.wallTime) << "\n"
      << "end\n";
    return s.str();
}

std::optional<SweepResult> parseSweepRecord(const std::string& text, const SweepRun& run) {
    std::map<std::string, std::string> kv;
    std::vector<std::string> values;
    std::istringstream in(text);
    std::string line;
    bool complete = false;
    while (std::getline(in, line)) {
        if (line == "end") {
            complete = true;
            break;
        }
        const auto space = line.find(' ');
        if (space == std::string::npos) return std::nullopt;
        const std::string key = line.substr(0, space), value = line.substr(space + 1);
        if (key == "value") values.push_back(value);
        else kv[key] = value;
    }
    if (!complete || kv["id"] != std::to_string(run.id) || kv["seed"] != std::to_string(run.seed) ||
        values.size() != run.values.size())
        return std::nullopt;
    for (std::size_t k = 0; k < values.size(); ++k)
        if (values[k] != exactNumber(run.values[k])) return std::nullopt;
    SweepResult r;
    r.ok = true;
    std::uint64_t u = 0;
    double d = 0;
    auto optional = [&](const std::string& key, std::optional<double>& out) {
        if (kv[key] == "-") return true;
        if (!parseDouble(kv[key], d)) return false;
        out = d;
        return true;
    };
    if (!parseUnsigned(kv["evacuated"], u)) return std::nullopt;
    r.evacuated = u;
    if (!optional("evacuation_time", r.evacuationTime) || !optional("flow", r.flow)) return std::nullopt;
    if (!parseDouble(kv["peak_density"], r.peakDensity) || !parseDouble(kv["peak_contact_accel"], r.peakContactAccel))
        return std::nullopt;
    if (!parseUnsigned(kv["injured"], u)) return std::nullopt;
    r.injured = u;
    r.verdict = kv["verdict"];
    if (r.verdict != "safe" && r.verdict != "caution" && r.verdict != "dangerous" && r.verdict != "critical")
        return std::nullopt;
    if (!parseDouble(kv["wall_time"], r.wallTime)) return std::nullopt;
    return r;
}

// ---- (c) outputs ------------------------------------------------------------------------------

std::string sweepCsv(const std::vector<SweepAxis>& axes, const std::vector<SweepRun>& runs,
                     const std::vector<std::optional<SweepResult>>& results) {
    std::string out = "run";
    for (const SweepAxis& a : axes) out += "," + a.target;
    out += ",seed,status,evacuated,evacuation_time,flow,peak_density,peak_contact_accel,injured,verdict,wall_time\n";
    for (const SweepRun& run : runs) {
        out += std::to_string(run.id);
        for (const double v : run.values) out += "," + cell(v);
        out += "," + std::to_string(run.seed);
        const std::optional<SweepResult>& r = results[run.id];
        if (!r) {
            out += ",not run,,,,,,,,\n";
        } else if (!r->ok) {
            out += ",failed,,,,,,,," + cell(r->wallTime) + "\n";
        } else {
            out += ",ok," + std::to_string(r->evacuated) + "," + cell(r->evacuationTime) + "," + cell(r->flow) + "," +
                   cell(r->peakDensity) + "," + cell(r->peakContactAccel) + "," + std::to_string(r->injured) + "," +
                   r->verdict + "," + cell(r->wallTime) + "\n";
        }
    }
    return out;
}

namespace {

/// Mean, sd, half-width of the 95 % confidence interval of the mean (Student t, n−1 degrees of
/// freedom) and n of one output over the finished runs of one combination.
struct CombinationStat {
    ch::SampleStats s;
    double ci95 = std::numeric_limits<double>::quiet_NaN();
};

CombinationStat combinationStat(const std::vector<std::optional<double>>& values) {
    CombinationStat c;
    c.s = ch::sampleStats(values);
    if (c.s.count >= 2 && std::isfinite(c.s.sd)) {
        const boost::math::students_t t(static_cast<double>(c.s.count - 1));
        c.ci95 = boost::math::quantile(t, 0.975) * c.s.sd / std::sqrt(static_cast<double>(c.s.count));
    }
    return c;
}

/// Per combination and output, its statistics; plus the runs and the failed runs per combination.
struct Summary {
    std::vector<std::vector<double>> values;  ///< per combination, the axis values
    std::vector<std::size_t> runs, failed;
    std::vector<std::vector<CombinationStat>> stats;  ///< [combination][output]
};

Summary summarise(const std::vector<SweepRun>& runs, const std::vector<std::optional<SweepResult>>& results) {
    Summary s;
    std::vector<std::vector<std::vector<std::optional<double>>>> columns;  // [combination][output][run]
    for (const SweepRun& run : runs) {
        if (run.combination >= s.values.size()) {
            s.values.push_back(run.values);
            s.runs.push_back(0);
            s.failed.push_back(0);
            columns.emplace_back(kOutputs.size());
        }
        const std::optional<SweepResult>& r = results[run.id];
        if (!r) continue;
        ++s.runs[run.combination];
        if (!r->ok) {
            ++s.failed[run.combination];
            continue;
        }
        for (std::size_t k = 0; k < kOutputs.size(); ++k) columns[run.combination][k].push_back(outputValue(*r, k));
    }
    for (const auto& c : columns) {
        std::vector<CombinationStat> row;
        for (const auto& v : c) row.push_back(combinationStat(v));
        s.stats.push_back(std::move(row));
    }
    return s;
}

}  // namespace

std::string sweepSummaryCsv(const std::vector<SweepAxis>& axes, const std::vector<SweepRun>& runs,
                            const std::vector<std::optional<SweepResult>>& results) {
    const Summary s = summarise(runs, results);
    std::string out;
    for (const SweepAxis& a : axes) out += a.target + ",";
    out += "runs,failed";
    for (const std::string& name : kOutputs) out += "," + name + "_mean," + name + "_sd," + name + "_ci95," + name + "_n";
    out += "\n";
    for (std::size_t c = 0; c < s.values.size(); ++c) {
        for (const double v : s.values[c]) out += cell(v) + ",";
        out += std::to_string(s.runs[c]) + "," + std::to_string(s.failed[c]);
        for (const CombinationStat& st : s.stats[c])
            out += "," + cell(st.s.mean) + "," + cell(st.s.sd) + "," + cell(st.ci95) + "," + std::to_string(st.s.count);
        out += "\n";
    }
    return out;
}

namespace {

// ---- plots ------------------------------------------------------------------------------------

/// "0.SPH.restDensityMax" → "sweep-0.SPH.restDensityMax.png" (characters other than letters,
/// digits, '.', '_' and '-' become '_').
std::string plotName(const std::string& target) {
    std::string s = "sweep-";
    for (const char c : target) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-') ? c : '_';
    return s + ".png";
}

/// One PNG per axis: a panel per output, the mean with its 95 % interval against the axis
/// values, one line per combination of the other axes' values. Returns the error messages.
std::vector<std::string> drawSweepPlots(const fs::path& outDir, const std::vector<SweepAxis>& axes,
                                        const std::vector<SweepRun>& runs,
                                        const std::vector<std::optional<SweepResult>>& results, std::size_t replications) {
    std::vector<std::string> errors;
    const Summary s = summarise(runs, results);
    const std::string terminal = chplot::pngTerminal(1800, 1000);
    for (std::size_t a = 0; a < axes.size(); ++a) {
        // The other axes' values of each combination name its line.
        std::map<std::vector<double>, std::vector<std::size_t>> lines;  // others → combinations (axis order)
        for (std::size_t c = 0; c < s.values.size(); ++c) {
            std::vector<double> others;
            for (std::size_t k = 0; k < axes.size(); ++k)
                if (k != a) others.push_back(s.values[c][k]);
            lines[others].push_back(c);
        }
        chplot::GnuplotJob job;
        job.cmd("set multiplot layout 2,4 title " +
                chplot::gpString("sweep: outputs against " + axes[a].target + " (mean and 95% confidence interval, " +
                                 std::to_string(replications) + (replications == 1 ? " seed" : " seeds") +
                                 " per point)") +
                " noenhanced font ',14'");
        job.cmd("set grid");
        job.cmd("set key below horizontal noenhanced font ',9'");
        job.cmd("set xlabel " + chplot::gpString(axes[a].target) + " noenhanced");
        job.cmd("set offsets graph 0.05, graph 0.05, graph 0.05, graph 0.05");
        for (std::size_t k = 0; k < kOutputs.size(); ++k) {
            job.cmd("set title " + chplot::gpString(kOutputLabels[k]) + " noenhanced");
            if (kOutputs[k] == "verdict_rank") job.cmd("set yrange [-0.3:3.3]; set ytics 1");
            else job.cmd("set autoscale y; set ytics autofreq");
            std::vector<chplot::Rows> blocks;
            std::vector<std::string> titles;
            for (const auto& [others, combos] : lines) {
                chplot::Rows rows;
                for (const std::size_t c : combos) {
                    const CombinationStat& st = s.stats[c][k];
                    if (!std::isfinite(st.s.mean)) continue;
                    const double ci = std::isfinite(st.ci95) ? st.ci95 : 0.0;
                    rows.push_back({s.values[c][a], st.s.mean, st.s.mean - ci, st.s.mean + ci});
                }
                if (rows.empty()) continue;
                std::string title;
                std::size_t o = 0;
                for (std::size_t j = 0; j < axes.size(); ++j) {
                    if (j == a) continue;
                    title += (title.empty() ? "" : ", ") + axes[j].target + " = " + cell(others[o++]);
                }
                blocks.push_back(std::move(rows));
                titles.push_back(title.empty() ? "mean" : title);
            }
            if (blocks.empty()) {  // nothing to draw (e.g. no run evacuated everybody)
                job.cmd("set label 1 'no values' at graph 0.5, graph 0.5 center");
                job.cmd("plot [0:1][0:1] NaN notitle");
                job.cmd("unset label 1");
                continue;
            }
            std::string plot = "plot ";
            for (std::size_t b = 0; b < blocks.size(); ++b)
                plot += std::string(b ? ", " : "") + "'-' using 1:2:3:4 with yerrorlines lw 2 pt 7 title " +
                        chplot::gpString(titles[b]);
            job.cmd(plot);
            for (chplot::Rows& rows : blocks) job.data(std::move(rows));
        }
        job.cmd("unset multiplot");
        const std::string err = chplot::drawPng(job, terminal, outDir / plotName(axes[a].target));
        if (!err.empty()) errors.push_back(plotName(axes[a].target) + ": " + err);
    }
    return errors;
}

// ---- the command ------------------------------------------------------------------------------

struct SweepSettings {
    std::string input;
    fs::path output;
    std::vector<SweepAxis> axes;
    std::vector<std::string> varyTexts;  ///< the --vary arguments as given
    std::size_t replications = 1;
    std::optional<std::uint64_t> seed;
    std::optional<double> endTime;
    std::size_t jobs = 0;
    bool keepRuns = false;
    bool quiet = false;
    std::optional<std::size_t> debugFailRun;
};

/// Options for the scenario pieces shared with a normal run (loadSpec, planRun, simulateAndWrite).
Options runOptions(const SweepSettings& s, bool keep) {
    Options o;
    o.input = s.input;
    o.output = s.output.string();
    o.endTime = s.endTime;
    o.quiet = true;
    o.overwrite = true;
    if (!keep) o.trajectories = "none";
    return o;
}

/// The scenario of one run: loaded with its seed, every axis value held from t = 0 by a ramp.
std::optional<ch::ScenarioSpec> runSpec(const SweepSettings& s, const SweepRun& run, bool printErrors) {
    const Options o = runOptions(s, s.keepRuns);
    std::optional<ch::ScenarioSpec> spec;
    if (printErrors) {
        spec = loadSpec(o, run.seed, true);
    } else {
        // In a worker: no printing (the first run's load has already shown every problem).
        ch::Diagnostics diags;
        ch::LoadOptions loadOptions;
        loadOptions.seed = run.seed;
        spec = ch::loadScenario(o.input, diags, loadOptions);
        if (diags.hasErrors()) spec.reset();
    }
    if (!spec) return std::nullopt;
    for (std::size_t k = 0; k < s.axes.size(); ++k) {
        ch::RampSpec r = s.axes[k].ramp;
        r.from = r.to = run.values[k];
        r.start = r.end = 0;
        spec->ramps.push_back(r);
    }
    return spec;
}

}  // namespace

/// (b) One run: build, simulate on one thread into `dir` (kept with --keep-runs, else removed),
/// and read the results. Never throws.
static SweepResult executeSweepRun(const SweepSettings& s, const SweepRun& run, const fs::path& dir,
                                   std::atomic<double>* clock) {
    SweepResult r;
    const auto start = std::chrono::steady_clock::now();
    try {
        if (s.debugFailRun && *s.debugFailRun == run.id) throw std::runtime_error("failed on purpose (--debug-fail-run)");
        std::optional<ch::ScenarioSpec> spec = runSpec(s, run, false);
        if (!spec) throw std::runtime_error("the scenario could not be loaded");
        ch::Simulation sim(std::move(*spec));  // the simulation keeps the spec: no copy
        const Options o = runOptions(s, s.keepRuns);
        const std::optional<RunPlan> plan = planRun(o, sim.spec(), false);  // checked on the first run
        if (!plan) throw std::runtime_error("the run cannot be planned");
        fs::create_directories(dir);
        RunHooks hooks;
        if (clock != nullptr) hooks.afterStep = [&](const ch::Simulation& sm) { clock->store(sm.time(), std::memory_order_relaxed); };
        hooks.releaseAgentSpecs = true;
        const RunOutcome outcome = simulateAndWrite(sim, *plan, dir, 1, o, hooks);
        if (!outcome.error.empty()) throw std::runtime_error(outcome.error);
        if (outcome.info.interrupted) throw std::runtime_error("interrupted");
        r.evacuated = sim.evacuations().size();
        r.evacuationTime = ch::runEvacuationTime(sim);
        r.flow = ch::runFlow(sim);
        r.peakDensity = outcome.peaks.maxDensity;
        r.peakContactAccel = outcome.peaks.maxContactAccel;
        r.injured = sim.health().injuredCount();
        r.verdict = outcome.verdict.level;
        r.ok = true;
    } catch (const std::exception& e) {
        r.ok = false;
        r.error = e.what();
    }
    if (!s.keepRuns) {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    r.wallTime = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

namespace {

/// A result that says why the run failed.
SweepResult failedResult(const std::string& why) {
    SweepResult r;
    r.error = why;
    return r;
}

/// What a worker sends back for one run: the record text (sweepRecordText) when it finished, else
/// "failed", its wall time and the reason on one line.
std::string sweepResultText(const SweepRun& run, const SweepResult& r) {
    if (r.ok) return sweepRecordText(run, r);
    std::string why = r.error;
    std::replace(why.begin(), why.end(), '\n', ' ');
    return "failed\nwall_time " + exactNumber(r.wallTime) + "\nerror " + why + "\n";
}

/// The result of `run` from sweepResultText. Text that reads as neither is a failed run.
SweepResult parseSweepResultText(const std::string& text, const SweepRun& run) {
    if (std::optional<SweepResult> r = parseSweepRecord(text, run)) return *r;
    const std::vector<std::string> l = splitOn(text, '\n');
    SweepResult r;
    if (l.size() >= 3 && l[0] == "failed" && l[1].rfind("wall_time ", 0) == 0 && l[2].rfind("error ", 0) == 0 &&
        parseDouble(l[1].substr(10), r.wallTime)) {
        r.error = l[2].substr(6);
        return r;
    }
    return failedResult("its result does not belong to it or cannot be read");
}

/// Under MPI every rank runs the command; the streams of all ranks but the controller go nowhere.
class SilentUnless {
public:
    explicit SilentUnless(bool speak) {
        if (speak) return;
        out_ = std::cout.rdbuf(nullptr);  // a stream without a buffer writes nothing
        err_ = std::cerr.rdbuf(nullptr);
    }
    ~SilentUnless() {
        if (out_ == nullptr && err_ == nullptr) return;
        std::cout.rdbuf(out_);
        std::cerr.rdbuf(err_);
        std::cout.clear();
        std::cerr.clear();
    }
    SilentUnless(const SilentUnless&) = delete;
    SilentUnless& operator=(const SilentUnless&) = delete;

private:
    std::streambuf* out_ = nullptr;
    std::streambuf* err_ = nullptr;
};

void printSweepHelp(std::ostream& out, const po::options_description& visible) {
    out << "Usage: crowdhealth sweep -i SCENARIO -o OUTDIR --vary TARGET=VALUES [--vary ...]\n"
           "                         [--replications N] [--seed S] [--jobs N] [--keep-runs] [--quiet]\n\n"
           "Runs the scenario for every combination of the --vary values, N times each with the seeds\n"
           "S ... S+N-1 (S: --seed, else the scenario's), at most --jobs runs at a time on this machine,\n"
           "each on one thread. Writes OUTDIR/sweep.csv (one row per run, in run order, whatever the\n"
           "order runs finish in), OUTDIR/sweep-summary.csv (per combination: mean, sd, half-width of the\n"
           "95% confidence interval (Student t) and n of every output) and OUTDIR/sweep-TARGET.png (every\n"
           "output against each varied parameter). sweep.csv does not depend on --jobs apart from its\n"
           "wall_time column.\n\n"
           "TARGET names a parameter as <Ramp> does: POLICY.COMPONENT.PARAMETER (e.g. 0.SPH.restDensityMax,\n"
           "0.CrowdHealth.panic) or agents.ATTRIBUTE (pref_speed, max_speed, max_acceleration). The value\n"
           "holds for the whole run (as a <Ramp> with from = to, from t = 0). VALUES: a list 3,5,7 or a\n"
           "range FROM:TO:STEP (TO included). A bad target or value is an error naming the --vary\n"
           "argument (exit 2) before anything runs.\n\n"
           "Resume: every finished run leaves a record in OUTDIR/.sweep/runs; the same command again runs\n"
           "only the runs without one (a failed run is tried again) and writes the same files. Other\n"
           "arguments, an edited scenario or file it reads, or a rebuilt plugin, with the same OUTDIR are\n"
           "refused (exit 2).\n"
           "MPI: `mpirun -n K crowdhealth sweep ...` (or srun) runs the same sweep on K processes: rank 0\n"
           "hands out the runs one at a time to ranks 1 ... K-1 (one run each at a time; --jobs applies\n"
           "only without MPI or with -n 1) and alone prints and writes OUTDIR. The files are the same\n"
           "as without MPI apart from wall_time (docs/sweeps.md).\n\n";
    out << visible << "\n"
        << "Exit status: 0 every run finished; 1 a run failed (marked 'failed' in sweep.csv) or OUTDIR\n"
           "cannot be written; 2 bad arguments or scenario; 130 interrupted (run the command again to\n"
           "resume).\n";
}

int usage(const std::string& message) {
    std::cerr << "crowdhealth: error: " << message << "\nTry 'crowdhealth sweep --help' for more information.\n";
    return kExitInput;
}

/// Parses TARGET of a --vary argument into a ramp (the table check comes later).
std::optional<std::string> parseTarget(const std::string& target, ch::RampSpec& ramp) {
    const std::vector<std::string> p = splitOn(target, '.');
    if (p.size() == 2 && p[0] == "agents") {
        ramp.target = ch::RampSpec::Target::Agents;
        ramp.parameter = p[1];
        if (ramp.parameter.empty()) return std::string("no attribute after 'agents.'");
        return std::nullopt;
    }
    if (p.size() != 3 || p[1].empty() || p[2].empty())
        return "TARGET must be POLICY.COMPONENT.PARAMETER (e.g. 0.SPH.restDensityMax) or agents.ATTRIBUTE (e.g. "
               "agents.pref_speed), not '" + target + "'";
    std::uint64_t id = 0;
    if (!parseUnsigned(p[0], id) || id > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
        return "the policy of '" + target + "' must be a policy id (a whole number), not '" + p[0] + "'";
    ramp.target = ch::RampSpec::Target::Component;
    ramp.policyId = static_cast<int>(id);
    ramp.component = p[1];
    ramp.parameter = p[2];
    return std::nullopt;
}

/// OUTDIR/.sweep/arguments: what makes the runs what they are (not --jobs, --quiet, --keep-runs).
std::string argumentsText(const SweepSettings& s, const ch::ScenarioSpec& spec, std::uint64_t firstSeed) {
    std::string t = "crowdhealth sweep 1\nscenario " + canonicalPath(s.input) + "\nscenario_content " +
                    fileHash(s.input) + "\n" + readFilesText(spec.includedFiles);
    for (const SweepAxis& a : s.axes) {
        t += "vary " + a.target + "=";
        for (std::size_t k = 0; k < a.values.size(); ++k) t += (k ? "," : "") + exactNumber(a.values[k]);
        t += "\n";
    }
    t += "replications " + std::to_string(s.replications) + "\nseed " + std::to_string(firstSeed) + "\n";
    t += "end_time " + (s.endTime ? exactNumber(*s.endTime) : std::string("scenario")) + "\n";
    return t;
}


}  // namespace

std::string fileHash(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::uint64_t h = 1469598103934665603ull;
    char c;
    while (in.get(c)) {
        h ^= static_cast<unsigned char>(c);
        h *= 1099511628211ull;
    }
    char buf[32];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

std::string canonicalPath(const std::string& path) {
    std::error_code ec;
    const fs::path c = fs::weakly_canonical(fs::absolute(path), ec);
    return ec ? path : c.string();
}

std::string readFilesText(const std::vector<std::string>& included) {
    std::string t;
    for (const std::string& f : included)
        t += "included " + canonicalPath(f) + " (content " + fileHash(f) + ")\n";
    for (const std::string& p : ch::loadedPlugins()) t += "plugin " + p + " (content " + fileHash(p) + ")\n";
    return t;
}

std::string firstDifference(const std::string& was, const std::string& now) {
    const auto a = splitOn(was, '\n'), b = splitOn(now, '\n');
    for (std::size_t k = 0; k < std::max(a.size(), b.size()); ++k) {
        const std::string x = k < a.size() ? a[k] : "", y = k < b.size() ? b[k] : "";
        if (x != y) return "there: '" + x + "', now: '" + y + "'";
    }
    return "";
}

std::optional<std::string> parseSweepTarget(const std::string& target, ch::RampSpec& ramp) {
    return parseTarget(target, ramp);
}

int sweepCommand(int argc, char* argv[]) {
    // Under mpirun every rank runs this command with the same arguments and makes the same checks;
    // only rank 0 (the controller) prints (job_pool.h).
    const SilentUnless silent(JobPool::rank() == 0);
    po::options_description visible("Options");
    // clang-format off
    visible.add_options()
        ("input,i", po::value<std::string>()->value_name("SCENARIO"), "scenario XML file")
        ("output,o", po::value<std::string>()->value_name("OUTDIR"), "folder for the outputs (created if missing)")
        ("vary", po::value<std::vector<std::string>>()->composing()->value_name("TARGET=VALUES"),
         "a parameter and its values, e.g. 0.SPH.restDensityMax=3:7:1 or agents.pref_speed=1,1.4; "
         "repeat for more parameters (all combinations are run)")
        ("replications", po::value<std::string>()->value_name("N"), "seeds per combination (default 1)")
        ("seed", po::value<std::string>()->value_name("S"), "first seed (default: Simulation@seed)")
        ("jobs,j", po::value<std::string>()->value_name("N"), "runs at a time, each on one thread (default: one per hardware thread; under MPI one per worker rank)")
        ("end-time", po::value<std::string>()->value_name("T"), "simulated time to stop at (s), overrides Simulation@end_time")
        ("keep-runs", "keep every run's output folder as OUTDIR/runs/run_NNNNNN (metrics.csv, summary.json, ...)")
        ("plugin", po::value<std::vector<std::string>>()->composing()->value_name("FILE"),
         "load a plugin before the scenario (as 'crowdhealth --plugin'; a scenario can also name it with <Plugin file=...>); repeatable")
        ("quiet,q", "no progress line and no closing lines")
        ("help,h", "show this help");
    po::options_description hidden("Hidden");
    hidden.add_options()("debug-fail-run", po::value<std::string>(), "make the run with this id fail (tests)");
    // clang-format on
    po::options_description all;
    all.add(visible).add(hidden);
    po::variables_map vm;
    try {
        po::store(po::command_line_parser(argc, argv).options(all).positional({}).run(), vm);
        po::notify(vm);
    } catch (const std::exception& e) {
        return usage(e.what());
    }
    if (vm.count("help")) {
        printSweepHelp(std::cout, visible);
        return kExitOk;
    }
    const auto str = [&](const char* name) { return vm[name].as<std::string>(); };
    SweepSettings s;
    if (!vm.count("input") || str("input").empty()) return usage("no scenario given: use -i SCENARIO");
    if (!vm.count("output") || str("output").empty()) return usage("no output folder given: use -o OUTDIR");
    if (!vm.count("vary")) return usage("nothing to vary: give at least one --vary TARGET=VALUES");
    s.input = str("input");
    s.output = str("output");
    s.quiet = vm.count("quiet") != 0;
    s.keepRuns = vm.count("keep-runs") != 0;
    std::uint64_t u = 0;
    if (vm.count("replications")) {
        if (!parseUnsigned(str("replications"), u) || u < 1 || u > 100000)
            return usage("--replications must be a whole number from 1 to 100000, not '" + str("replications") + "'");
        s.replications = u;
    }
    if (vm.count("seed")) {
        if (!parseUnsigned(str("seed"), u)) return usage("--seed must be a whole number, not '" + str("seed") + "'");
        s.seed = u;
    }
    if (vm.count("jobs")) {
        if (!parseUnsigned(str("jobs"), u) || u < 1 || u > 4096)
            return usage("--jobs must be a whole number from 1 to 4096, not '" + str("jobs") + "'");
        s.jobs = u;
    }
    if (vm.count("end-time")) {
        double t = 0;
        if (!parseDouble(str("end-time"), t) || t <= 0)
            return usage("--end-time must be a positive number of seconds, not '" + str("end-time") + "'");
        s.endTime = t;
    }
    if (vm.count("debug-fail-run")) {
        if (!parseUnsigned(str("debug-fail-run"), u)) return usage("--debug-fail-run needs a run id");
        s.debugFailRun = u;
    }
    std::set<std::string> seenTargets;
    for (const std::string& v : vm["vary"].as<std::vector<std::string>>()) {
        const std::string arg = "--vary '" + v + "'";
        const auto eq = v.find('=');
        if (eq == std::string::npos) return usage(arg + ": give TARGET=VALUES, e.g. 0.SPH.restDensityMax=3,5,7");
        SweepAxis a;
        a.target = v.substr(0, eq);
        if (const auto problem = parseTarget(a.target, a.ramp)) return usage(arg + ": " + *problem);
        if (const auto problem = parseSweepValues(v.substr(eq + 1), a.values)) return usage(arg + ": " + *problem);
        a.ramp.loc.file = "--vary " + a.target;
        if (!seenTargets.insert(a.ramp.column() + "@" + (a.ramp.policyId ? std::to_string(*a.ramp.policyId) : "")).second)
            return usage(arg + ": " + a.target + " is varied twice");
        s.axes.push_back(std::move(a));
        s.varyTexts.push_back(v);
    }
    std::size_t combinations = 1;
    for (const SweepAxis& a : s.axes) {
        combinations *= a.values.size();
        if (combinations * s.replications > 10000000) return usage("the sweep would have more than 10 million runs");
    }

    // ---- the checks that can differ between MPI ranks (files), then agreed on by every rank ----
    // Every rank loads the scenario (workers run jobs with it); only the controller looks at
    // OUTDIR and writes there. The job of a run is its id; its result is its record text.
    std::optional<ch::ScenarioSpec> first;
    std::vector<SweepRun> runs;
    std::size_t total = 0;
    const fs::path state = s.output / ".sweep";
    const fs::path recordsDir = state / "runs";
    const auto runDir = [&](const SweepRun& run) {
        const std::string name = runName(run.id, total);
        return s.keepRuns ? s.output / "runs" / name : state / "work" / name;
    };
    JobWork work = [&](const std::string& job, std::atomic<double>& clock) -> std::string {
        std::uint64_t id = 0;
        if (!parseUnsigned(job, id) || id >= runs.size()) return sweepResultText(SweepRun{}, failedResult("bad job '" + job + "'"));
        const SweepRun& run = runs[id];
        return sweepResultText(run, executeSweepRun(s, run, runDir(run), &clock));
    };
    JobPoolOptions poolOptions;
    poolOptions.localJobs = s.jobs;
    JobPool pool(work, poolOptions);

    const int checked = [&]() -> int {
        if (vm.count("plugin") && !loadPlugins(vm["plugin"].as<std::vector<std::string>>(), std::cerr)) return kExitInput;
        const Options base = runOptions(s, s.keepRuns);
        first = loadSpec(base, s.seed, true);
        if (!first) return kExitInput;
        const std::uint64_t firstSeed = first->seed;
        if (firstSeed > std::numeric_limits<std::uint64_t>::max() - (s.replications - 1))
            return usage("the seeds " + std::to_string(firstSeed) + " ... +" + std::to_string(s.replications - 1) +
                         " do not fit in 64 bits; give a smaller --seed");
        for (std::size_t k = 0; k < s.axes.size(); ++k) {
            const SweepAxis& a = s.axes[k];
            const std::string arg = "--vary '" + s.varyTexts[k] + "'";
            for (const double v : a.values) {
                ch::RampSpec r = a.ramp;
                r.from = r.to = v;
                const std::string problem = ch::rampTargetProblem(*first, r);
                if (!problem.empty()) return usage(arg + ": " + problem);
            }
            for (const ch::RampSpec& r : first->ramps)
                if (r.column() == a.ramp.column())
                    return usage(arg + ": the scenario ramps " + r.column() + " itself (" + r.loc.file + ":" +
                                 std::to_string(r.loc.line) + "); a sweep holds the value for the whole run, remove that <Ramp>");
        }
        runs = expandSweep(s.axes, firstSeed, s.replications);
        total = runs.size();
        {
            // Build the first run's simulation: unknown components and the like show here (exit 2).
            const std::optional<ch::ScenarioSpec> spec = runSpec(s, runs.front(), true);
            if (!spec) return kExitInput;
            try {
                ch::Simulation sim(*spec);
            } catch (const std::exception& e) {
                std::cerr << "crowdhealth: error: " << e.what() << "\n";
                return kExitInput;
            }
            if (!planRun(base, *spec, true)) return kExitInput;
        }
        if (!pool.controller()) return kExitOk;

        // ---- OUTDIR: new, or a sweep with the same arguments ----
        const std::string arguments = argumentsText(s, *first, firstSeed);
        std::error_code ec;
        if (fs::exists(state / "arguments", ec)) {
            std::ifstream in(state / "arguments", std::ios::binary);
            std::ostringstream was;
            was << in.rdbuf();
            if (was.str() != arguments) {
                std::cerr << "crowdhealth: error: " << s.output.string()
                          << " holds a sweep made with other arguments, another scenario or other files it reads ("
                          << firstDifference(was.str(), arguments)
                          << "); it is not resumed: give another -o OUTDIR, or the same arguments as before\n";
                return kExitInput;
            }
        } else if (fs::is_directory(s.output, ec) && !fs::is_empty(s.output, ec)) {
            std::cerr << "crowdhealth: error: " << s.output.string()
                      << " is not empty and holds no sweep (no .sweep/arguments); give a new or empty -o OUTDIR\n";
            return kExitInput;
        }
        try {
            fs::create_directories(recordsDir);
            if (!fs::exists(state / "arguments")) ch::writeFileAtomic(state / "arguments", arguments);
        } catch (const std::exception& e) {
            std::cerr << "crowdhealth: error: cannot write to " << s.output.string() << ": " << e.what() << "\n";
            return kExitRuntime;
        }
        return kExitOk;
    }();
    const int agreed = pool.agree(checked);
    if (agreed != kExitOk) {
        if (checked == kExitOk && pool.controller())
            std::cerr << "crowdhealth: error: another MPI rank could not load the scenario or check the arguments "
                         "(is "
                      << s.input << " readable on every host?)\n";
        return agreed;
    }
    // Ctrl-C / SIGTERM on every rank: a run going stops at its next step (reported as interrupted).
    installInterruptHandlers();
    if (!pool.controller()) {
        pool.serve();
        return pool.exitStatus();
    }

    // ---- (d) what is done already ----
    // A record being written when the sweep was killed is a NAME.tmp: never read, removed here.
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(recordsDir, ec))
        if (e.path().extension() == ".tmp") fs::remove(e.path(), ec);
    std::vector<std::optional<SweepResult>> results(total);
    std::vector<std::size_t> todo;
    for (const SweepRun& run : runs) {
        const fs::path rec = recordsDir / (runName(run.id, total) + ".txt");
        if (fs::exists(rec, ec)) {
            std::ifstream in(rec, std::ios::binary);
            std::ostringstream text;
            text << in.rdbuf();
            results[run.id] = parseSweepRecord(text.str(), run);
        }
        if (!results[run.id]) todo.push_back(run.id);
    }
    const std::size_t already = total - todo.size();

    // ---- (b) the runs to do, on the job pool (threads, or MPI ranks); records written here ----
    std::vector<std::string> jobs;
    for (const std::size_t id : todo) jobs.push_back(std::to_string(id));
    bool anyFailed = false;
    ReplicationProgress progress(std::cerr, !s.quiet && ProgressBar::stderrIsTerminal(), todo.size(),
                                 s.endTime ? *s.endTime : first->endTime);
    if (!s.quiet && already > 0)
        std::cerr << "crowdhealth: resuming " << s.output.string() << ": " << plural(already, "run") << " of " << total
                  << " already finished, " << todo.size() << " to run\n";
    const auto finished = [&](std::size_t k, const std::string& text) {
        const SweepRun& run = runs[todo[k]];
        SweepResult r = parseSweepResultText(text, run);
        std::string message;
        if (r.ok) {
            try {
                ch::writeFileAtomic(recordsDir / (runName(run.id, total) + ".txt"), sweepRecordText(run, r));
            } catch (const std::exception& e) {
                message = "crowdhealth: error: run " + std::to_string(run.id) + ": cannot write its record: " + e.what();
                anyFailed = true;
            }
        } else if (r.error != "interrupted") {
            message = "crowdhealth: error: run " + std::to_string(run.id) + " (seed " + std::to_string(run.seed) +
                      ") failed: " + r.error;
            anyFailed = true;
        }
        if (r.ok || r.error != "interrupted") results[run.id] = std::move(r);
        if (!message.empty()) {
            progress.clear();
            std::cerr << message << "\n";
        }
    };
    const auto wallStart = std::chrono::steady_clock::now();
    // Under mpirun rank 0's stderr is a pipe to mpirun, never a terminal: instead of the progress
    // line, a line of text every minute (it reads well in a batch job's log too).
    const bool logLines = !s.quiet && pool.distributed() && !ProgressBar::stderrIsTerminal();
    auto nextLog = std::chrono::steady_clock::now() + std::chrono::minutes(1);
    const auto tick = [&](const JobPoolState& st) {
        progress.draw(st.done, st.running, st.slowest);
        if (logLines && std::chrono::steady_clock::now() >= nextLog) {
            nextLog += std::chrono::minutes(1);
            std::cerr << "crowdhealth: sweep: " << st.done << " of " << todo.size() << " runs done, " << st.running
                      << " running, elapsed " << formatDuration(std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count())
                      << "\n";
        }
    };
    pool.run(jobs, finished, tick);
    progress.finish();
    const double wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
    fs::remove_all(state / "work", ec);

    const std::size_t missing = static_cast<std::size_t>(std::count_if(results.begin(), results.end(), [](const auto& r) { return !r; }));
    if (interruptRequested() || missing > 0) {
        std::cerr << "crowdhealth: interrupted: " << (total - missing) << " of " << total
                  << " runs finished and recorded in " << recordsDir.string()
                  << "; run the same command again to run the other " << missing << "\n";
        pool.finish(kExitInterrupted);
        return kExitInterrupted;
    }

    // ---- (c) the outputs, in run order ----
    try {
        ch::writeFileAtomic(s.output / "sweep.csv", sweepCsv(s.axes, runs, results));
        ch::writeFileAtomic(s.output / "sweep-summary.csv", sweepSummaryCsv(s.axes, runs, results));
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth: error: cannot write the outputs: " << e.what() << "\n";
        pool.finish(kExitRuntime);
        return kExitRuntime;
    }
    bool plotted = false;
    if (chplot::findGnuplot()) {
        const std::vector<std::string> errors = drawSweepPlots(s.output, s.axes, runs, results, s.replications);
        for (const std::string& e : errors) std::cerr << "crowdhealth: warning: plot " << e << "\n";
        plotted = errors.empty();
    } else {
        std::cerr << "crowdhealth: warning: " << chplot::missingGnuplotMessage("the sweep plots") << "\n";
    }
    const std::size_t failed = static_cast<std::size_t>(std::count_if(results.begin(), results.end(), [](const auto& r) { return r && !r->ok; }));
    if (!s.quiet) {
        std::cout << "crowdhealth sweep: " << s.input << ", " << plural(combinations, "combination") << " x "
                  << plural(s.replications, "seed") << " = " << plural(total, "run") << " (" << already
                  << " already done, " << todo.size() << " run now in " << formatDuration(wallSeconds) << ", at most "
                  << std::min(todo.size(), pool.workers()) << " at a time";
        if (pool.distributed()) std::cout << " on " << plural(pool.workers(), "MPI worker rank");
        std::cout << ")";
        if (failed > 0) std::cout << ", " << failed << " failed";
        std::cout << "\n  output  " << (s.output / "sweep.csv").string() << ", " << (s.output / "sweep-summary.csv").string();
        if (plotted) std::cout << ", " << (s.output / "sweep-*.png").string();
        std::cout << "\n";
    }
    const int status = (failed > 0 || anyFailed) ? kExitRuntime : kExitOk;
    pool.finish(status);
    return status;
}

}  // namespace chcli
