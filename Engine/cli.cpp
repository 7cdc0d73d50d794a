// crowdhealth — command-line parsing (see cli.h).
#include "cli.h"
#include "text_numbers.h"

#include <crowdhealth/core/plugins.h>
#include <crowdhealth/core/scenario.h>

#include <boost/program_options.hpp>

#include <charconv>
#include <cmath>
#include <ostream>
#include <sstream>

#ifndef CH_VERSION
#define CH_VERSION "unknown"
#endif

namespace chcli {

namespace po = boost::program_options;

namespace {

po::options_description visibleOptions() {
    po::options_description d("Options");
    // clang-format off
    d.add_options()
        ("input,i", po::value<std::string>()->value_name("SCENARIO"), "scenario XML file to run")
        ("output,o", po::value<std::string>()->value_name("OUTDIR"),
         "folder for the outputs (created if missing)")
        ("threads,t", po::value<std::string>()->value_name("N"),
         "OpenMP threads (default: one per hardware thread; results do not depend on it); "
         "with --replications: runs at a time, each on one thread")
        ("seed", po::value<std::string>()->value_name("N"),
         "random seed, overrides Simulation@seed (with --replications: the first run's seed)")
        ("replications", po::value<std::string>()->value_name("N"),
         "run N times with seeds S, S+1, ..., S+N-1 (S: --seed, else the scenario's) into "
         "OUTDIR/run_000 ... and write OUTDIR/summary.csv (one row per run, then mean, sd and n)")
        ("flow-first", po::value<std::string>()->value_name("N"),
         "flow is measured from the Nth evacuee (overrides <Output flow_first>, default 1)")
        ("flow-last", po::value<std::string>()->value_name("N"),
         "... to the Nth evacuee (overrides <Output flow_last>, default 350)")
        ("end-time", po::value<std::string>()->value_name("T"),
         "simulated time to stop at (s), overrides Simulation@end_time")
        ("trajectories", po::value<std::string>()->value_name("umans|txt|bin|both|none"),
         "trajectory files: UMANS output_<id>.csv (small runs), PedPy trajectories.txt, compact "
         "trajectories.bin, both (umans and txt), none, or a list such as txt,bin "
         "(default: the scenario's <Output>, else none)")
        ("trajectory-interval", po::value<std::string>()->value_name("T"),
         "seconds between trajectory frames, default every coarse step (overrides <Output "
         "trajectory_interval>)")
        ("plot", "after the run(s), draw fig3.png, health.png, schedule.png and heatmap.png into "
         "OUTDIR with gnuplot (the same as 'crowdhealth plot OUTDIR' later)")
        ("overwrite", "write into OUTDIR even if it holds files crowdhealth did not write: they are "
         "kept, files named as this run's outputs are replaced (without it such a folder is refused)")
        ("quiet,q", "no progress bar and no closing summary")
        ("timing", "say where the run's wall time went: in the simulation's steps, in recording "
         "and the rest, then the recording by recorder (safety grid, metrics, measurement, "
         "trajectories); also with --quiet")
        ("check", "validate the scenario (load and build it), print a one-line summary, write nothing")
        ("plugin", po::value<std::vector<std::string>>()->composing()->value_name("FILE"),
         "load a plugin (a shared library of cost functions and forces, docs/adding-a-policy.md) "
         "before the scenario; repeat for more (a scenario can also name them: <Plugin file=\"...\"/>)")
        ("list-policies", "list every registered cost function and force with its parameters")
        ("format", po::value<std::string>()->value_name("text|markdown"),
         "output format of --list-policies (default: text)")
        ("help,h", "show this help")
        ("version", "show the version");
    // clang-format on
    return d;
}

po::options_description hiddenOptions() {
    po::options_description d("Hidden");
    d.add_options()("debug-interrupt-after", po::value<std::string>(), "raise SIGINT after N coarse steps")(
        "debug-kill-before-summary", "raise SIGKILL once every output but summary.json is written");
    return d;
}

bool usageError(std::ostream& err, const std::string& message) {
    err << "crowdhealth: error: " << message << "\nTry 'crowdhealth --help' for more information.\n";
    return false;
}

}  // namespace

void printVersion(std::ostream& out) { out << "crowdhealth " << CH_VERSION << "\n"; }

void printHelp(std::ostream& out) {
    out << "Usage: crowdhealth -i SCENARIO -o OUTDIR [options]\n"
           "       crowdhealth -i SCENARIO -o OUTDIR --replications N [-t THREADS] [--seed S]\n"
           "       crowdhealth -i SCENARIO --check\n"
           "       crowdhealth plot DIR | compare DIR... [-o OUTDIR]   (see 'crowdhealth plot --help')\n"
           "       crowdhealth sweep -i SCENARIO -o OUTDIR --vary TARGET=VALUES [--vary ...] [--replications N]\n"
           "                         (parameter studies; see 'crowdhealth sweep --help')\n"
           "       crowdhealth calibrate -i SCENARIO --fit TARGET=LO:HI [--fit ...] --data FILE [--seeds N]\n"
           "                         (fit parameters to data; see 'crowdhealth calibrate --help')\n"
           "       crowdhealth verify [-o DIR] [--quick] [--policy NAME...] [--test ID...] [--jobs N]\n"
           "       crowdhealth --list-policies [--plugin FILE] [--format text|markdown]\n\n"
           "Runs a CrowdHealth (UMANS-compatible) crowd scenario and writes metrics.csv,\n"
           "evacuations.csv, summary.json and optionally trajectories to OUTDIR.\n"
           "With --replications N, runs the seeds S ... S+N-1 (S: --seed, else the scenario's),\n"
           "at most THREADS at a time and each on one thread, into OUTDIR/run_000, run_001, ...\n"
           "Each folder holds the files of a single run, identical to a run with --seed S+k.\n"
           "OUTDIR/summary.csv has one row per run (seed, evacuated, evacuation time, flow,\n"
           "peaks, mean density at t = 15 s, interrupted), then the rows 'mean', 'sd' (sample,\n"
           "N-1) and 'n' (the runs each uses: those not interrupted, with a value there).\n\n"
           "OUTDIR: each folder written holds .crowdhealth-manifest, the list of the files the\n"
           "run wrote. A new run into it replaces exactly those (outputs of the earlier run that\n"
           "this one does not write are removed) and deletes nothing else. A folder holding files\n"
           "crowdhealth did not write is refused (exit 2) unless --overwrite is given.\n"
           "Files are written to NAME.tmp and renamed when complete; summary.json comes last.\n"
           "Ctrl-C or SIGTERM stops after the current step and writes the outputs for the time\n"
           "simulated (every run of --replications); a second Ctrl-C kills at once.\n\n";
    out << visibleOptions() << "\n";
    out << "Exit status:\n"
           "  0    success\n"
           "  1    runtime failure (e.g. OUTDIR cannot be written; with --replications, a run\n"
           "       failed)\n"
           "  2    bad command line, scenario errors (printed as path:line: error: ...), or\n"
           "       OUTDIR holds files crowdhealth did not write (see --overwrite); nothing is\n"
           "       simulated or written\n"
           "  130  interrupted by Ctrl-C (SIGINT) or SIGTERM; outputs cover the time simulated\n";
}

std::optional<Options> parseCommandLine(int argc, const char* const argv[], std::ostream& err) {
    po::options_description all;
    all.add(visibleOptions()).add(hiddenOptions());
    po::variables_map vm;
    try {
        // No positional options: a stray word is an error, not a silently ignored scenario.
        po::store(po::command_line_parser(argc, argv).options(all).positional({}).run(), vm);
        po::notify(vm);
    } catch (const po::too_many_positional_options_error&) {
        // The likeliest mistake: `crowdhealth scenario.xml`. Name the stray word and the fix.
        std::string stray;
        for (int k = 1; k < argc; ++k)
            if (argv[k][0] != '-' && (k == 1 || argv[k - 1][0] != '-' || std::string(argv[k - 1]).find('=') != std::string::npos)) {
                stray = argv[k];
                break;
            }
        usageError(err, "unexpected argument" + (stray.empty() ? std::string() : " '" + stray + "'") +
                            ": give the scenario with -i SCENARIO and the output folder with -o OUTDIR");
        return std::nullopt;
    } catch (const po::error& e) {
        usageError(err, e.what());
        return std::nullopt;
    }

    Options o;
    const auto str = [&](const char* name) { return vm[name].as<std::string>(); };

    if (vm.count("help")) { o.command = Command::Help; return o; }
    if (vm.count("version")) { o.command = Command::Version; return o; }

    if (vm.count("format")) {
        const std::string f = str("format");
        if (f == "text") o.format = ListFormat::Text;
        else if (f == "markdown" || f == "md") o.format = ListFormat::Markdown;
        else { usageError(err, "--format must be 'text' or 'markdown', not '" + f + "'"); return std::nullopt; }
        if (!vm.count("list-policies")) { usageError(err, "--format only applies to --list-policies"); return std::nullopt; }
    }
    if (vm.count("plugin")) {
        o.plugins = vm["plugin"].as<std::vector<std::string>>();
        for (const std::string& p : o.plugins)
            if (p.empty()) { usageError(err, "--plugin needs a file name"); return std::nullopt; }
    }
    if (vm.count("list-policies")) {
        if (vm.count("check") || vm.count("input")) {
            usageError(err, "--list-policies takes no scenario (-i) and cannot be combined with --check");
            return std::nullopt;
        }
        o.command = Command::ListPolicies;
        return o;
    }

    o.command = vm.count("check") ? Command::Check : Command::Run;
    o.quiet = vm.count("quiet") != 0;
    o.timing = vm.count("timing") != 0;
    o.plot = vm.count("plot") != 0;
    o.overwrite = vm.count("overwrite") != 0;
    if (o.plot && o.command == Command::Check) {
        usageError(err, "--plot cannot be combined with --check (nothing is run to plot)");
        return std::nullopt;
    }
    if (!vm.count("input")) { usageError(err, "no scenario given: use -i SCENARIO"); return std::nullopt; }
    o.input = str("input");
    if (o.input.empty()) { usageError(err, "the scenario path (-i) is empty"); return std::nullopt; }
    if (vm.count("output")) o.output = str("output");
    if (o.command == Command::Run && o.output.empty()) {
        usageError(err, "no output folder given: use -o OUTDIR (or --check to only validate)");
        return std::nullopt;
    }

    if (vm.count("threads")) {
        std::uint64_t t = 0;
        if (!parseUnsigned(str("threads"), t) || t < 1 || t > 4096) {
            usageError(err, "--threads must be a whole number from 1 to 4096, not '" + str("threads") + "'");
            return std::nullopt;
        }
        o.threads = static_cast<int>(t);
    }
    if (vm.count("seed")) {
        std::uint64_t s = 0;
        if (!parseUnsigned(str("seed"), s)) {
            usageError(err, "--seed must be a whole number from 0 to 18446744073709551615, not '" + str("seed") + "'");
            return std::nullopt;
        }
        o.seed = s;
    }
    if (vm.count("end-time")) {
        double t = 0;
        if (!parseDouble(str("end-time"), t) || !std::isfinite(t) || t <= 0) {
            usageError(err, "--end-time must be a positive number of seconds, not '" + str("end-time") + "'");
            return std::nullopt;
        }
        o.endTime = t;
    }
    if (vm.count("trajectories")) {
        const std::string t = str("trajectories");
        if (!ch::parseTrajectoryFormats(t)) {
            usageError(err, std::string("--trajectories must be one of ") + ch::kTrajectoryFormatWords +
                                ", or a comma-separated list such as txt,bin; not '" + t + "'");
            return std::nullopt;
        }
        o.trajectories = t;
    }
    if (vm.count("trajectory-interval")) {
        double t = 0;
        if (!parseDouble(str("trajectory-interval"), t) || !std::isfinite(t) || t <= 0) {
            usageError(err, "--trajectory-interval must be a positive number of seconds, not '" +
                                str("trajectory-interval") + "'");
            return std::nullopt;
        }
        o.trajectoryInterval = t;
    }
    if (vm.count("replications")) {
        std::uint64_t n = 0;
        if (!parseUnsigned(str("replications"), n) || n < 1 || n > kMaxReplications) {
            usageError(err, "--replications must be a whole number from 1 to " + std::to_string(kMaxReplications) +
                                ", not '" + str("replications") + "'");
            return std::nullopt;
        }
        if (o.command == Command::Check) {
            usageError(err, "--replications cannot be combined with --check (check the scenario once, without it)");
            return std::nullopt;
        }
        o.replications = n;
    }
    for (const char* name : {"flow-first", "flow-last"}) {
        if (!vm.count(name)) continue;
        std::uint64_t n = 0;
        if (!parseUnsigned(str(name), n) || n < 1 || n > 1000000000) {
            usageError(err, std::string("--") + name + " must be a whole number from 1 to 1000000000, not '" +
                                str(name) + "'");
            return std::nullopt;
        }
        (std::string(name) == "flow-first" ? o.flowFirst : o.flowLast) = static_cast<int>(n);
    }
    if (o.flowFirst && o.flowLast && *o.flowLast <= *o.flowFirst) {
        usageError(err, "--flow-last (" + std::to_string(*o.flowLast) + ") must be greater than --flow-first (" +
                            std::to_string(*o.flowFirst) + ")");
        return std::nullopt;
    }
    o.killBeforeSummary = vm.count("debug-kill-before-summary") != 0;
    if (vm.count("debug-interrupt-after")) {
        std::uint64_t n = 0;
        if (!parseUnsigned(str("debug-interrupt-after"), n)) {
            usageError(err, "--debug-interrupt-after must be a whole number of steps");
            return std::nullopt;
        }
        o.interruptAfterSteps = n;
    }
    return o;
}

bool loadPlugins(const std::vector<std::string>& files, std::ostream& err) {
    for (const std::string& file : files) {
        const ch::PluginLoad load = ch::loadPlugin(ch::findPlugin(file, ""));
        if (!load.ok) {
            err << "crowdhealth: error: --plugin '" << file << "': " << load.error << "\n";
            return false;
        }
    }
    return true;
}

}  // namespace chcli
