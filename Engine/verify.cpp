// crowdhealth verify — runs the verification tests for every model (see verify.h and
// docs/verification.md).
//
// The tests come from the families of verify_tests_*.cpp (verify_suite.h says what a test is);
// kRows below orders them in the report and names the rows no family has built yet ("pending").
// Each test is one or more variants (scenario files of Examples/verification/), run for every
// model and seed; an Observer watches each run, the test's combine turns the outcomes of its
// variants into the Check shown, its figure draws DIR/figures/<id>.png.
//
// Runs go in memory (no run folders): up to --jobs worker threads take the next (test, variant,
// model, seed), each on one OpenMP thread, as `crowdhealth --replications` does; the main thread
// draws the progress line.
#include "verify.h"

#include "exit_codes.h"
#include "progress.h"
#include "verify_figures.h"
#include "verify_suite.h"

#include <crowdhealth/core/simulation.h>
#include <crowdhealth/io/output.h>
#include <crowdhealth/io/xml.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

#ifndef CH_SOURCE_DIR
#define CH_SOURCE_DIR ""
#endif

namespace chverify {

const std::vector<std::string>& modelNames() {
    static const std::vector<std::string> names = {"SocialForces", "SocialForces-venue", "ORCA", "RVO", "Karamouzas", "PowerLaw", "SPH"};
    return names;
}

std::set<std::string> allModels() { return {modelNames().begin(), modelNames().end()}; }

std::map<ch::AgentId, const ch::Evacuation*> evacuationsById(const ch::Simulation& sim) {
    std::map<ch::AgentId, const ch::Evacuation*> out;
    for (const ch::Evacuation& e : sim.evacuations()) out[e.id] = &e;
    return out;
}

}  // namespace chverify

namespace chcli {

namespace fs = std::filesystem;
namespace po = boost::program_options;
using chverify::Check;
using chverify::Kind;
using chverify::Outcome;
using chverify::RunContext;
using chverify::TestDef;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// The tests

/// Every row of the report, in order, with the title shown while a family has not registered it
/// (status "pending"). A family's TestDef takes the place of its row; a test no row names goes at
/// the end.
struct Row {
    const char* id;
    const char* title;
    const char* source;
};
const Row kRows[] = {
    {"rimea-1", "RiMEA 1: walking speed in a corridor", "RiMEA 4.1.1 test 1"},
    {"rimea-2", "RiMEA 2: walking speed up a stair", "RiMEA 4.1.1 test 2"},
    {"rimea-3", "RiMEA 3: walking speed down a stair", "RiMEA 4.1.1 test 3"},
    {"rimea-4", "RiMEA 4: fundamental diagram (Weidmann)", "RiMEA 4.1.1 test 4"},
    {"rimea-5", "RiMEA 5: premovement time", "RiMEA 4.1.1 test 5"},
    {"rimea-6", "RiMEA 6: movement around a corner", "RiMEA 4.1.1 test 6"},
    {"rimea-7", "RiMEA 7: demographic parameters", "RiMEA 4.1.1 test 7"},
    {"rimea-8", "RiMEA 8: parameter analysis", "RiMEA 4.1.1 test 8"},
    {"rimea-9", "RiMEA 9: crowd leaving a large room", "RiMEA 4.1.1 test 9"},
    {"rimea-10", "RiMEA 10: allocation of escape routes", "RiMEA 4.1.1 test 10"},
    {"rimea-11", "RiMEA 11: choice of escape route", "RiMEA 4.1.1 test 11"},
    {"rimea-12", "RiMEA 12: effect of bottlenecks", "RiMEA 4.1.1 test 12"},
    {"rimea-13", "RiMEA 13: congestion in front of a stair", "RiMEA 4.1.1 test 13"},
    {"rimea-14", "RiMEA 14: route choice (documented)", "RiMEA 4.1.1 test 14"},
    {"rimea-15", "RiMEA 15: large crowd around a corner", "RiMEA 4.1.1 test 15"},
    {"rimea-16", "RiMEA 16: single-file fundamental diagram", "RiMEA 4.1.1 test 16"},
    {"iso-max-flow", "ISO/NIST: maximum flow through a 1 m exit", "ISO 20414 / NIST TN 1822"},
    {"iso-corridor", "ISO/NIST: speed in a corridor (40 m at 1.0 m/s +-0.05)", "ISO 20414 / NIST TN 1822"},
    {"iso-premovement-ks", "ISO/NIST: premovement distributions (Kolmogorov-Smirnov)", "ISO 20414 / NIST TN 1822"},
    {"iso-demographics", "ISO/NIST: demographics N(1.2, 0.2) m/s", "ISO 20414 / NIST TN 1822"},
    {"iso-counterflow", "ISO/NIST: counter-flow", "ISO 20414 / NIST TN 1822"},
    {"iso-dynamic-exits", "ISO/NIST: dynamic exit availability", "ISO 20414 / NIST TN 1822"},
    {"iso-groups", "ISO/NIST: groups arrive together", "ISO 20414 / NIST TN 1822"},
    {"val-weidmann", "validation: speed vs density (Weidmann)", "Weidmann 1993"},
    {"val-sfpe", "validation: specific flow vs density (SFPE/IMO)", "SFPE handbook; IMO MSC.1/Circ.1238"},
    {"val-kretz", "validation: bottleneck flow vs width (Kretz et al. 2006)", "Kretz et al. 2006"},
};

std::vector<TestDef> makeTests() {
    std::vector<TestDef> registered;
    chverify::addBasicTests(registered);
    chverify::addFundamentalTests(registered);
    chverify::addBottleneckTests(registered);
    chverify::addEvacuationTests(registered);
    chverify::addIsoTests(registered);
    std::vector<TestDef> t;
    std::set<std::string> placed;
    for (const Row& row : kRows) {
        const auto it = std::find_if(registered.begin(), registered.end(), [&](const TestDef& d) { return d.id == row.id; });
        if (it != registered.end()) {
            t.push_back(*it);
        } else {
            TestDef d;
            d.id = row.id;
            d.title = row.title;
            d.kind = Kind::Pending;
            d.source = row.source;
            d.note = d.id == "iso-groups" ? "needs groups (future-work issue)" : "not built yet";
            t.push_back(d);
        }
        placed.insert(row.id);
    }
    for (const TestDef& d : registered)
        if (!placed.count(d.id)) t.push_back(d);
    return t;
}

bool runnable(const TestDef& t) { return t.kind == Kind::Criterion || t.kind == Kind::Validation || t.kind == Kind::Documented; }

// ---------------------------------------------------------------------------------------------
// Running

struct Job {
    std::size_t test = 0, variant = 0;
    std::string model;
    std::uint64_t seed = 1;
    Outcome outcome;
    std::string error;  ///< the run failed (loading, building, …)
    double simTime = 0;
};

/// Per test and model, over the seeds.
struct Cell {
    std::string status;  ///< pass, fail, documented, validation, error, not run
    std::size_t seeds = 0, passed = 0;
    double mean = kNaN, min = kNaN, max = kNaN;
    std::string detail;  ///< the first failing seed's, else the first seed's
    bool detailFails = false;
    bool claimed = false;
};

std::string fixedNum(double v, int decimals) {
    if (!std::isfinite(v)) return "-";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    std::string s(buf);
    if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
    return s;
}

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) {
        if (c == '"') q += '"';
        q += c;
    }
    return q + "\"";
}

/// The folder of the tests: --tests-dir, else Examples/verification under the working folder,
/// beside the program (build/bin/../../Examples) or in the sources it was built from.
std::optional<fs::path> findTestsDir(const std::string& given) {
    if (!given.empty()) return fs::path(given);
    std::vector<fs::path> candidates = {fs::current_path() / "Examples" / "verification"};
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back(self.parent_path().parent_path().parent_path() / "Examples" / "verification");
    if (std::string(CH_SOURCE_DIR).size()) candidates.push_back(fs::path(CH_SOURCE_DIR) / "Examples" / "verification");
    for (const fs::path& c : candidates)
        if (fs::is_directory(c, ec)) return c;
    return std::nullopt;
}

std::string kindWord(Kind k) {
    switch (k) {
    case Kind::Criterion: return "";
    case Kind::Validation: return "validation";
    case Kind::Documented: return "documented";
    case Kind::OutOfScope: return "out of scope";
    case Kind::Pending: return "pending";
    }
    return "";
}

}  // namespace

int verifyCommand(int argc, char* argv[]) {
    po::options_description visible("Options");
    // clang-format off
    visible.add_options()
        ("output,o", po::value<std::string>()->value_name("DIR")->default_value("verify-report"),
         "folder for report.md, verify.csv and figures/ (created if missing)")
        ("quick", "small crowds, one model per test, one seed (under a minute)")
        ("policy", po::value<std::vector<std::string>>()->multitoken()->composing()->value_name("NAME"),
         "run only these models (Examples/verification/models/NAME.xml; default: all)")
        ("test", po::value<std::vector<std::string>>()->multitoken()->composing()->value_name("ID"),
         "run only these tests (e.g. rimea-1 iso-max-flow; default: all)")
        ("jobs,j", po::value<unsigned>()->value_name("N")->default_value(0),
         "runs at a time, each on one thread (0: one per hardware thread)")
        ("seeds", po::value<unsigned>()->value_name("N")->default_value(0),
         "seeds per test and model (0: 3, or 1 with --quick; a test may fix its own)")
        ("tests-dir", po::value<std::string>()->value_name("DIR"),
         "the folder of the test scenarios (default: Examples/verification here, or beside the program)")
        ("no-figures", "write no figures (figures need gnuplot)")
        ("list", "list the tests and models, run nothing")
        ("quiet,q", "no progress line and no closing summary")
        ("help,h", "show this help");
    // clang-format on
    po::variables_map vm;
    try {
        po::store(po::command_line_parser(argc, argv).options(visible).run(), vm);
        po::notify(vm);
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth verify: " << e.what() << "\nTry 'crowdhealth verify --help'.\n";
        return kExitInput;
    }
    if (vm.count("help")) {
        std::cout << "Usage: crowdhealth verify [-o DIR] [--quick] [--policy NAME ...] [--test ID ...] [--jobs N]\n\n"
                     "Runs the verification tests (RiMEA, ISO 20414 / NIST TN 1822) and the validation against\n"
                     "experiments of Examples/verification/ for each model of Examples/verification/models/\n"
                     "(its policy id 0 replaces the test's policy id 0) over several seeds, and writes\n"
                     "DIR/report.md (test x model: pass, fail, documented, validation, out of scope, pending),\n"
                     "DIR/verify.csv and DIR/figures/. Exit status: 0 when every test passes for every model it\n"
                     "is claimed for, 1 when one does not (or a run fails), 2 for a bad command line or a file\n"
                     "that does not load. See docs/verification.md.\n\n"
                  << visible;
        return kExitOk;
    }
    const bool quick = vm.count("quick") != 0, quiet = vm.count("quiet") != 0, figures = vm.count("no-figures") == 0;
    const fs::path outDir = vm["output"].as<std::string>();
    const std::vector<TestDef> tests = makeTests();
    const std::vector<std::string>& allNames = chverify::modelNames();
    // The test whose runs each test reads: itself, or the one named by runsOf.
    std::vector<std::size_t> runsOf(tests.size());
    for (std::size_t k = 0; k < tests.size(); ++k) {
        runsOf[k] = k;
        if (tests[k].runsOf.empty()) continue;
        const auto base = std::find_if(tests.begin(), tests.end(), [&](const TestDef& b) { return b.id == tests[k].runsOf; });
        if (base == tests.end() || !base->runsOf.empty() || !runnable(*base) || !tests[k].combine) {
            std::cerr << "crowdhealth verify: internal error: test " << tests[k].id << " reads the runs of '" << tests[k].runsOf
                      << "', which is not a test with runs of its own (or it has no combine)\n";
            return kExitRuntime;
        }
        runsOf[k] = static_cast<std::size_t>(base - tests.begin());
    }

    std::vector<std::string> models = allNames;
    if (vm.count("policy")) {
        std::set<std::string> wanted;
        for (const std::string& m : vm["policy"].as<std::vector<std::string>>()) {
            if (std::find(allNames.begin(), allNames.end(), m) == allNames.end()) {
                std::cerr << "crowdhealth verify: unknown model '" << m << "'; the models are:";
                for (const std::string& k : allNames) std::cerr << " " << k;
                std::cerr << "\n";
                return kExitInput;
            }
            wanted.insert(m);
        }
        models.clear();
        for (const std::string& m : allNames)
            if (wanted.count(m)) models.push_back(m);
    }
    std::set<std::string> onlyTests;
    if (vm.count("test")) {
        for (const std::string& id : vm["test"].as<std::vector<std::string>>()) {
            if (std::none_of(tests.begin(), tests.end(), [&](const TestDef& t) { return t.id == id; })) {
                std::cerr << "crowdhealth verify: unknown test '" << id << "'; see 'crowdhealth verify --list'\n";
                return kExitInput;
            }
            onlyTests.insert(id);
        }
    }
    if (vm.count("list")) {
        for (const TestDef& t : tests) {
            const std::string k = kindWord(t.kind);
            std::cout << t.id << "  " << t.title << (k.empty() ? "" : "  (" + k + ")") << "\n";
        }
        std::cout << "models:";
        for (const std::string& m : allNames) std::cout << " " << m;
        std::cout << "\n";
        return kExitOk;
    }
    const std::optional<fs::path> testsDir = findTestsDir(vm.count("tests-dir") ? vm["tests-dir"].as<std::string>() : std::string());
    if (!testsDir) {
        std::cerr << "crowdhealth verify: cannot find Examples/verification (run from the repository's top folder, "
                     "or give --tests-dir)\n";
        return kExitInput;
    }
    const unsigned seedsWanted = vm["seeds"].as<unsigned>();
    const std::size_t defaultSeeds = seedsWanted > 0 ? seedsWanted : quick ? 1 : 3;
    auto seedsOf = [&](const TestDef& t) { return seedsWanted > 0 || quick || t.seeds == 0 ? defaultSeeds : t.seeds; };

    // ---- every model's policy, through the normal loader ----
    std::map<std::string, ch::PolicySpec> policies;
    // A model's fine step is part of the model (SPH integrates on 0.02 s): a model file with
    // delta_time_fine gives its fine step to every test it runs in.
    std::map<std::string, double> fineSteps;
    for (const std::string& m : models) {
        const fs::path file = *testsDir / "models" / (m + ".xml");
        ch::Diagnostics diags;
        const auto spec = ch::loadScenario(file.string(), diags);
        if (!spec || diags.hasErrors()) {
            diags.print(std::cerr);
            std::cerr << "crowdhealth verify: the model file " << file.string() << " does not load\n";
            return kExitInput;
        }
        const auto p = std::find_if(spec->policies.begin(), spec->policies.end(), [](const ch::PolicySpec& s) { return s.id == 0; });
        if (p == spec->policies.end()) {
            std::cerr << file.string() << ": error: the model file has no policy id 0\n";
            return kExitInput;
        }
        policies[m] = *p;
        if (spec->deltaTimeFine > 0) fineSteps[m] = spec->deltaTimeFine;
    }

    // ---- the runs ----
    std::vector<Job> jobs;
    std::set<std::size_t> toRun;  // the tests asked for, or those whose runs they read
    for (std::size_t k = 0; k < tests.size(); ++k)
        if (runnable(tests[k]) && (onlyTests.empty() || onlyTests.count(tests[k].id))) toRun.insert(runsOf[k]);
    for (const std::size_t k : toRun) {
        const TestDef& t = tests[k];
        for (const std::string& m : models) {
            if (quick && m != t.quickModel) continue;
            for (std::size_t s = 0; s < seedsOf(t); ++s)
                for (std::size_t v = 0; v < t.variants.size(); ++v) {
                    if (quick && !t.variants[v].inQuick) continue;
                    Job j;
                    j.test = k;
                    j.variant = v;
                    j.model = m;
                    j.seed = 1 + s;
                    jobs.push_back(std::move(j));
                }
        }
    }
    // Load each variant once per seed up front: a test that does not load stops everything before
    // anything runs (exit 2).
    std::map<std::tuple<std::size_t, std::size_t, std::uint64_t>, ch::ScenarioSpec> specs;
    for (const Job& j : jobs) {
        const auto key = std::make_tuple(j.test, j.variant, j.seed);
        if (specs.count(key)) continue;
        const fs::path file = *testsDir / tests[j.test].variants[j.variant].file;
        ch::Diagnostics diags;
        ch::LoadOptions lo;
        lo.seed = j.seed;
        auto spec = ch::loadScenario(file.string(), diags, lo);
        if (!spec || diags.hasErrors()) {
            diags.print(std::cerr);
            std::cerr << "crowdhealth verify: the test " << tests[j.test].id << " (" << file.string() << ") does not load\n";
            return kExitInput;
        }
        // The fine step of every model that brings one must divide the test's coarse step.
        for (const auto& [m, fine] : fineSteps) {
            const double ratio = spec->deltaTime / fine;
            if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio || ratio < 1 - 1e-9) {
                std::cerr << file.string() << ": error: delta_time " << spec->deltaTime << " s is not a multiple of model "
                          << m << "'s delta_time_fine " << fine << " s\n";
                return kExitInput;
            }
        }
        specs.emplace(key, std::move(*spec));
    }

    std::error_code ec;
    fs::create_directories(outDir, ec);
    if (ec || !fs::is_directory(outDir)) {
        std::cerr << "crowdhealth verify: cannot create " << outDir.string() << ": " << ec.message() << "\n";
        return kExitRuntime;
    }

    const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
    const unsigned jobsWanted = vm["jobs"].as<unsigned>();
    const std::size_t workers = std::max<std::size_t>(1, std::min<std::size_t>(jobs.size(), jobsWanted ? jobsWanted : hardware));
    std::atomic<std::size_t> next{0}, done{0};
    std::mutex mutex;
    std::condition_variable wake;
    std::size_t going = workers;
    const std::unique_ptr<std::atomic<double>[]> clock(new std::atomic<double>[jobs.size()]);
    const std::unique_ptr<std::atomic<int>[]> phase(new std::atomic<int>[jobs.size()]);
    for (std::size_t k = 0; k < jobs.size(); ++k) clock[k] = 0, phase[k] = 0;

    auto runOne = [&](Job& j, std::size_t k) {
        const TestDef& t = tests[j.test];
        const RunContext ctx{j.model, j.seed, j.variant, quick};
        ch::ScenarioSpec spec = specs.at({j.test, j.variant, j.seed});
        bool replaced = false;
        for (ch::PolicySpec& p : spec.policies)
            if (p.id == 0) {
                const ch::SourceLoc loc = p.loc;
                p = policies.at(j.model);
                p.id = 0;
                p.loc = loc;
                replaced = true;
            }
        if (!replaced) throw std::runtime_error("the test has no policy id 0 to replace");
        if (const auto fine = fineSteps.find(j.model); fine != fineSteps.end()) spec.deltaTimeFine = fine->second;
        if (const auto& modify = t.variants[j.variant].modify) modify(spec, ctx);
        ch::Simulation sim(std::move(spec));
        sim.setThreads(1);
        std::unique_ptr<chverify::Observer> obs = t.observer(ctx);
        obs->step(sim);
        while (!sim.finished()) {
            sim.stepCoarse();
            obs->step(sim);
            clock[k].store(sim.time(), std::memory_order_relaxed);
        }
        j.simTime = sim.time();
        j.outcome = obs->finish(sim);
    };
    auto worker = [&] {
        for (;;) {
            const std::size_t k = next.fetch_add(1);
            if (k >= jobs.size()) break;
            phase[k] = 1;
            try {
                runOne(jobs[k], k);
            } catch (const std::exception& e) {
                jobs[k].error = e.what();
            }
            phase[k] = 2;
            ++done;
            wake.notify_one();
        }
        {
            const std::lock_guard<std::mutex> lock(mutex);
            --going;
        }
        wake.notify_one();
    };

    const auto wallStart = std::chrono::steady_clock::now();
    ReplicationProgress progress(std::cerr, !quiet && ProgressBar::stderrIsTerminal(), jobs.size(), -1);
    std::vector<std::thread> pool;
    for (std::size_t w = 0; w < workers; ++w) pool.emplace_back(worker);
    {
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
            wake.wait_for(lock, std::chrono::milliseconds(100));
            const bool over = going == 0;
            std::size_t running = 0;
            double slowest = std::numeric_limits<double>::infinity();
            for (std::size_t k = 0; k < jobs.size(); ++k)
                if (phase[k] == 1) ++running, slowest = std::min(slowest, clock[k].load(std::memory_order_relaxed));
            progress.draw(done.load(), running, slowest);
            if (over) break;
        }
    }
    for (std::thread& th : pool) th.join();
    progress.finish();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();

    // ---- one Check per test, model and seed: the variants combined ----
    struct SeedResult {
        std::vector<const Outcome*> variants;
        std::string error;
    };
    std::map<std::tuple<std::size_t, std::string, std::uint64_t>, SeedResult> bySeed;
    for (const Job& j : jobs) {
        SeedResult& r = bySeed[{j.test, j.model, j.seed}];
        if (r.variants.size() < tests[j.test].variants.size()) r.variants.resize(tests[j.test].variants.size(), nullptr);
        if (!j.error.empty()) {
            if (r.error.empty())
                r.error = (tests[j.test].variants.size() > 1 ? tests[j.test].variants[j.variant].label + ": " : std::string()) + j.error;
        } else {
            r.variants[j.variant] = &j.outcome;
        }
    }
    std::map<std::pair<std::size_t, std::string>, Cell> cells;
    bool anyError = false;
    auto inRun = [&](const TestDef& t) { return onlyTests.empty() || onlyTests.count(t.id) != 0; };
    for (const auto& [key, r] : bySeed) {
        const auto& [base, model, seed] = key;
        for (std::size_t test = 0; test < tests.size(); ++test) {
            if (runsOf[test] != base || !runnable(tests[test]) || !inRun(tests[test])) continue;
            const TestDef& t = tests[test];
            Cell& c = cells[{test, model}];
            c.claimed = t.kind == Kind::Criterion && t.claimed.count(model) != 0;
            ++c.seeds;
            if (!r.error.empty()) {
                anyError = true;
                c.status = "error";
                c.detail = "seed " + std::to_string(seed) + ": " + r.error;
                continue;
            }
            Check check;
            if (t.combine) {
                // --quick may leave variants out: combine sees only those that ran.
                std::vector<const Outcome*> ran;
                for (const Outcome* o : r.variants)
                    if (o) ran.push_back(o);
                try {
                    check = t.combine(ran, RunContext{model, seed, 0, quick});
                } catch (const std::exception& e) {
                    anyError = true;
                    c.status = "error";
                    c.detail = "seed " + std::to_string(seed) + ": " + e.what();
                    continue;
                }
            } else {
                check = r.variants.front() ? r.variants.front()->check : Check{};
            }
            const double v = check.value;
            if (std::isfinite(v)) {
                const std::size_t n = c.seeds;  // running mean over the seeds with a value
                c.mean = std::isfinite(c.mean) ? c.mean + (v - c.mean) / static_cast<double>(n) : v;
                c.min = std::isfinite(c.min) ? std::min(c.min, v) : v;
                c.max = std::isfinite(c.max) ? std::max(c.max, v) : v;
            }
            if (check.pass) ++c.passed;
            // The first failing seed's detail, else the first seed's.
            if (c.detail.empty() || (!check.pass && !c.detailFails)) {
                c.detail = "seed " + std::to_string(seed) + ": " + check.detail;
                c.detailFails = !check.pass;
            }
        }
    }
    bool allClaimedPass = !anyError;
    std::size_t passCount = 0, failCount = 0, documented = 0, validated = 0;
    for (auto& [key, c] : cells) {
        if (c.status == "error") continue;
        const TestDef& t = tests[key.first];
        const bool pass = c.passed == c.seeds;
        if (t.kind == Kind::Validation) {
            c.status = "validation";
            ++validated;
        } else if (c.claimed) {
            c.status = pass ? "pass" : "fail";
            (pass ? passCount : failCount)++;
            if (!pass) allClaimedPass = false;
        } else {
            c.status = "documented";
            ++documented;
        }
    }

    // ---- figures ----
    std::map<std::size_t, std::string> figureOf;  // test → path relative to outDir
    std::vector<std::string> figureErrors;
    if (figures) {
        for (std::size_t k = 0; k < tests.size(); ++k) {
            const TestDef& t = tests[k];
            if (!t.figure) continue;
            chverify::FigureInput in;
            in.test = &t;
            if (!inRun(t)) continue;
            for (const std::string& m : models)
                if (std::any_of(jobs.begin(), jobs.end(), [&](const Job& j) { return j.test == runsOf[k] && j.model == m; }))
                    in.models.push_back(m);
            for (const Job& j : jobs)
                if (j.test == runsOf[k] && j.error.empty()) in.runs.push_back({j.model, j.seed, j.variant, &j.outcome});
            if (in.runs.empty()) continue;
            fs::create_directories(outDir / "figures", ec);
            const fs::path png = outDir / "figures" / (t.id + ".png");
            std::string err;
            try {
                err = t.figure(in, png);
            } catch (const std::exception& e) {
                err = e.what();
            }
            if (err.empty()) figureOf[k] = "figures/" + t.id + ".png";
            else figureErrors.push_back(t.id + ": " + err);
        }
    }

    // ---- report.md and verify.csv ----
    auto cellText = [&](std::size_t k, const std::string& m) -> std::string {
        const TestDef& t = tests[k];
        if (t.kind == Kind::OutOfScope || t.kind == Kind::Pending) return kindWord(t.kind);
        const auto it = cells.find({k, m});
        if (it == cells.end()) return "not run";
        const Cell& c = it->second;
        std::string s = c.status;
        if (c.status == "documented" && t.kind == Kind::Criterion)
            s = c.passed == c.seeds ? "documented (meets it)" : "documented (fails it)";
        if (c.status == "validation") s = "error";
        if (c.status == "documented" || c.status == "pass" || c.status == "fail" || c.status == "validation") {
            s += " " + fixedNum(c.mean, t.decimals);
            if (c.seeds > 1 && c.max > c.min) s += " (" + fixedNum(c.min, t.decimals) + "-" + fixedNum(c.max, t.decimals) + ")";
        }
        return s;
    };
    std::ostringstream md;
    md << "# crowdhealth verify: report\n\n"
       << (quick ? "Quick run (`--quick`: one model per test, small crowds, " : "Full run (")
       << defaultSeeds << " seed" << (defaultSeeds == 1 ? "" : "s") << " per test and model unless a test says otherwise). "
       << jobs.size() << " runs in " << fixedNum(wall, 1) << " s on " << workers << " thread" << (workers == 1 ? "" : "s")
       << ".\n\n"
       << "**Result: " << (allClaimedPass ? "every claimed test passes" : "FAILURES: a claimed test fails") << "** ("
       << passCount << " pass, " << failCount << " fail, " << documented << " documented only, " << validated
       << " validation" << (anyError ? ", runs with errors" : "") << ").\n\n"
       << "Each cell: the status and the measured value (mean over the seeds, the range in brackets). "
          "`pass`/`fail`: the criterion is claimed for that model; `documented`: measured and shown, not claimed "
          "(\"meets it\" / \"fails it\": whether the criterion holds for every seed); `error`: the validation error "
          "against experimental data (never pass / fail); `not run`: left out of this run (`--quick`, `--policy`, "
          "`--test`).\n\n";
    md << "| test |";
    for (const std::string& m : models) md << " " << m << " |";
    md << "\n|---|";
    for (std::size_t i = 0; i < models.size(); ++i) md << "---|";
    md << "\n";
    for (std::size_t k = 0; k < tests.size(); ++k) {
        if (!inRun(tests[k])) continue;
        md << "| " << tests[k].id << " |";
        for (const std::string& m : models) md << " " << cellText(k, m) << " |";
        md << "\n";
    }
    md << "\n## The tests\n\n| test | what | unit | criterion | claimed for | a failure means | source |\n|---|---|---|---|---|---|---|\n";
    for (const TestDef& t : tests) {
        if (!inRun(t)) continue;
        std::string claimed, files;
        for (const std::string& m : allNames)
            if (t.claimed.count(m)) claimed += (claimed.empty() ? "" : ", ") + m;
        if (t.kind == Kind::Criterion && claimed.empty()) claimed = "none (documented)";
        if (t.kind == Kind::Validation) claimed = "none (validation)";
        if (t.kind == Kind::Documented) claimed = "none (documented)";
        std::set<std::string> seen;
        for (const chverify::Variant& v : tests[runsOf[static_cast<std::size_t>(&t - tests.data())]].variants)
            if (seen.insert(v.file).second) files += (files.empty() ? "" : ", ") + ("`" + v.file + "`");
        const std::string what = t.kind == Kind::Pending      ? "pending: " + t.note
                                 : t.kind == Kind::OutOfScope ? "out of scope: " + t.note
                                                              : t.criterion;
        md << "| " << t.id << " | " << t.title << (files.empty() ? "" : " (" + files + ")") << " | " << t.unit << " | "
           << what << " | " << claimed << " | " << t.failureMeans << " | " << t.source << " |\n";
    }
    if (!figureOf.empty()) {
        md << "\n## Figures\n\n";
        for (const auto& [k, rel] : figureOf) md << "### " << tests[k].id << ": " << tests[k].title << "\n\n![" << tests[k].id << "](" << rel << ")\n\n";
    }
    md << "\n## Details per run set\n\n| test | model | status | seeds passing | value | detail |\n|---|---|---|---|---|---|\n";
    for (const auto& [key, c] : cells) {
        const TestDef& t = tests[key.first];
        md << "| " << t.id << " | " << key.second << " | " << c.status << " | " << c.passed << "/" << c.seeds << " | "
           << fixedNum(c.mean, t.decimals) << " " << t.unit << " | " << c.detail << " |\n";
    }

    std::ostringstream csv;
    csv << "test,model,status,claimed,seeds,seeds_passing,value_mean,value_min,value_max,unit,criterion,detail\n";
    for (std::size_t k = 0; k < tests.size(); ++k) {
        const TestDef& t = tests[k];
        if (!inRun(t)) continue;
        for (const std::string& m : models) {
            const auto it = cells.find({k, m});
            const std::string status = !runnable(t) ? kindWord(t.kind) : it == cells.end() ? "not run" : it->second.status;
            const Cell c = it == cells.end() ? Cell{} : it->second;
            csv << t.id << "," << m << "," << csvField(status) << ","
                << (t.kind == Kind::Criterion && t.claimed.count(m) ? "yes" : "no") << "," << c.seeds << "," << c.passed
                << "," << fixedNum(c.mean, 6) << "," << fixedNum(c.min, 6) << "," << fixedNum(c.max, 6) << ","
                << csvField(t.unit) << "," << csvField(runnable(t) ? t.criterion : t.note) << "," << csvField(c.detail)
                << "\n";
        }
    }
    try {
        ch::writeFileAtomic(outDir / "report.md", md.str());
        ch::writeFileAtomic(outDir / "verify.csv", csv.str());
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth verify: cannot write the report: " << e.what() << "\n";
        return kExitRuntime;
    }
    for (const std::string& e : figureErrors) std::cerr << "crowdhealth verify: warning: no figure for " << e << "\n";
    if (!quiet) {
        std::cout << "crowdhealth verify: " << jobs.size() << " runs in " << formatDuration(wall) << ": " << passCount
                  << " pass, " << failCount << " fail, " << documented << " documented, " << validated << " validation"
                  << (anyError ? ", errors (see the report)" : "") << "\n  report  " << (outDir / "report.md").string()
                  << "\n  table   " << (outDir / "verify.csv").string() << "\n";
        if (!figureOf.empty()) std::cout << "  figures " << (outDir / "figures").string() << "/ (" << figureOf.size() << ")\n";
        for (const auto& [key, c] : cells)
            if (c.status == "fail" || c.status == "error")
                std::cout << "  " << c.status << ": " << tests[key.first].id << " with " << key.second << ": " << c.detail << "\n";
    }
    return allClaimedPass ? kExitOk : kExitRuntime;
}

}  // namespace chcli
