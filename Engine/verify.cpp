// crowdhealth verify — runs the verification tests for every model (see verify.h and
// docs/verification.md).
//
// The tests are a table (kTests below): each names its scenario file in Examples/verification/,
// its criterion (a function of verify_criteria.h fed by an Observer that watches the run step by
// step), the models its pass is claimed for, and its rows' texts. Rows without a file are the
// parts of the issue not done here ("pending") or not applicable to a 2D model ("out of scope"):
// they are in the report all the same, so that its matrix is complete.
//
// Runs go in memory (no run folders): up to --jobs worker threads take the next (test, model,
// seed), each on one OpenMP thread, as `crowdhealth --replications` does; the main thread draws
// the progress line.
#include "verify.h"

#include "exit_codes.h"
#include "progress.h"
#include "verify_criteria.h"

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

namespace chcli {

namespace fs = std::filesystem;
namespace po = boost::program_options;
using chverify::Check;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Observers: what each test measures while its scenario runs

/// Watches one run: step() after every coarse step, finish() once it has ended.
class Observer {
public:
    virtual ~Observer() = default;
    virtual void step(const ch::Simulation&) {}
    virtual Check finish(const ch::Simulation& sim) = 0;
};

/// The time each agent left by an exit (s), by id.
std::map<ch::AgentId, const ch::Evacuation*> evacuationsById(const ch::Simulation& sim) {
    std::map<ch::AgentId, const ch::Evacuation*> out;
    for (const ch::Evacuation& e : sim.evacuations()) out[e.id] = &e;
    return out;
}

/// RiMEA 1: the arrival time of the one person.
class ArrivalObserver : public Observer {
public:
    Check finish(const ch::Simulation& sim) override {
        std::optional<double> t;
        if (!sim.evacuations().empty()) t = sim.evacuations().front().time;
        return chverify::arrivalTime(t);
    }
};

/// RiMEA 5: when each person starts to walk — the first time it keeps at least half its preferred
/// speed for 1 s — against when it was due (its start time + premovement). Sustained speed rather
/// than a distance or a speed at one step: with social forces a person standing by the door is
/// pushed aside by everyone passing (0.07 m in one step at 13.3 s, seed 1, 46 s before its
/// premovement ended); a push lasts a step or two, walking does not.
class PremovementObserver : public Observer {
public:
    static constexpr double kWalking = 0.5;  ///< share of the preferred speed that counts as walking
    static constexpr double kSustained = 1.0;  ///< s the speed must hold
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (started_.count(A.id[i])) continue;
            const bool walking = A.vel[i].norm() >= kWalking * A.basePrefSpeed[i];
            if (!walking) {
                since_.erase(A.id[i]);
                continue;
            }
            // The start of the run of walking steps: the time the step began.
            const double t = since_.try_emplace(A.id[i], sim.time() - sim.deltaTime()).first->second;
            if (sim.time() - t >= kSustained - 1e-9) started_[A.id[i]] = t;
        }
    }
    Check finish(const ch::Simulation& sim) override {
        std::vector<chverify::StartRecord> people;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            chverify::StartRecord r;
            r.id = a.id;
            r.due = a.startTime + a.premovement;
            if (auto it = started_.find(a.id); it != started_.end()) r.start = it->second;
            people.push_back(r);
        }
        return chverify::premovementStarts(people);
    }

private:
    std::map<ch::AgentId, double> since_;    ///< start of the current run of walking steps
    std::map<ch::AgentId, double> started_;
};

/// RiMEA 6: everyone out by the exit; the deepest wall overlap of any body at any step.
class CornerObserver : public Observer {
public:
    /// m: the wall overlap allowed (docs/verification.md, RiMEA 6, says why this value).
    static constexpr double kThreshold = 0.05;
    void step(const ch::Simulation& sim) override { deepest_ = std::max(deepest_, sim.maxWallPenetration()); }
    Check finish(const ch::Simulation& sim) override {
        return chverify::cornerPassage(sim.evacuations().size(), sim.totalAgents(), deepest_, kThreshold);
    }

private:
    double deepest_ = 0;
};

/// RiMEA 7: each person's speed between x = 5 m and x = 25 m, against its group's range (the
/// groups are the scenario's agents in file order, `count` each).
class DemographicsObserver : public Observer {
public:
    struct Group {
        const char* name;
        double lo, hi;
        std::size_t count;
    };
    static constexpr double kFrom = 5, kTo = 25;  ///< m, the measuring lines
    explicit DemographicsObserver(std::vector<Group> groups) : groups_(std::move(groups)) {}
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        const double t = sim.time();
        for (std::size_t i = 0; i < A.size(); ++i) {
            Track& k = tracks_[A.id[i]];
            if (k.seen) {
                if (!k.t5) k.t5 = chverify::crossingTime(k.t, k.x, t, A.pos[i].x(), kFrom);
                if (!k.t25) k.t25 = chverify::crossingTime(k.t, k.x, t, A.pos[i].x(), kTo);
            }
            k.seen = true;
            k.t = t;
            k.x = A.pos[i].x();
        }
    }
    Check finish(const ch::Simulation& sim) override {
        std::vector<chverify::SpeedRecord> people;
        std::size_t group = 0, inGroup = 0;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            chverify::SpeedRecord r;
            r.id = a.id;
            while (group < groups_.size() && inGroup == groups_[group].count) ++group, inGroup = 0;
            if (group == groups_.size()) break;  // more agents than the groups hold: not measured
            ++inGroup;
            const Group& g = groups_[group];
            r.group = g.name;
            r.lo = g.lo;
            r.hi = g.hi;
            if (auto it = tracks_.find(a.id); it != tracks_.end() && it->second.t5 && it->second.t25)
                r.speed = (kTo - kFrom) / (*it->second.t25 - *it->second.t5);
            people.push_back(r);
        }
        return chverify::speedsInRanges(people);
    }

private:
    struct Track {
        bool seen = false;
        double t = 0, x = 0;
        std::optional<double> t5, t25;
    };
    std::vector<Group> groups_;
    std::map<ch::AgentId, Track> tracks_;
};

/// RiMEA 10: the exit each person left by against the exit of its journey.
class AllocationObserver : public Observer {
public:
    Check finish(const ch::Simulation& sim) override {
        const ch::VenueSpec& venue = sim.spec().venue;
        const auto out = evacuationsById(sim);
        std::vector<chverify::ExitRecord> people;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            chverify::ExitRecord r;
            r.id = a.id;
            const int j = venue.journeyIndex(a.journey);
            r.allocated = j >= 0 ? venue.journeys[static_cast<std::size_t>(j)].leaveBy : std::string("?");
            if (auto it = out.find(a.id); it != out.end() && it->second->exit >= 0)
                r.used = venue.targets[static_cast<std::size_t>(it->second->exit)].name;
            people.push_back(r);
        }
        return chverify::routeAllocation(people);
    }
};

/// Maximum flow: the specific flow from the 10th to the 90th person out of a 1 m exit.
class FlowObserver : public Observer {
public:
    Check finish(const ch::Simulation& sim) override {
        std::vector<double> times;
        for (const ch::Evacuation& e : sim.evacuations()) times.push_back(e.time);
        Check c = chverify::maximumFlow(chverify::specificFlow(times, 10, 90, 1.0));
        c.detail += ", " + std::to_string(times.size()) + "/" + std::to_string(sim.totalAgents()) + " out";
        return c;
    }
};

// ---------------------------------------------------------------------------------------------
// The tests

enum class Kind { Criterion, OutOfScope, Pending };

const std::vector<std::string> kModels = {"SocialForces", "SocialForces-venue", "ORCA", "RVO", "Karamouzas", "PowerLaw"};

struct TestDef {
    std::string id;           ///< --test ID, e.g. "rimea-1"
    std::string title;
    Kind kind = Kind::Criterion;
    std::string file;         ///< in Examples/verification/; empty unless Kind::Criterion
    std::string unit;         ///< of the measured value
    int decimals = 2;
    std::string criterion;    ///< the pass criterion, as the report states it
    std::string failureMeans; ///< one line: what a failure means
    std::string source;       ///< RiMEA 4.1.1 test 1, ISO 20414 …
    /// Models the pass is claimed for; for the others the result is only documented.
    std::set<std::string> claimed;
    std::string quickModel;   ///< the one model run with --quick
    std::function<std::unique_ptr<Observer>()> observer;
    std::string note;         ///< for rows without a file: why
};

std::vector<TestDef> makeTests() {
    const std::set<std::string> all(kModels.begin(), kModels.end());
    std::vector<TestDef> t;
    t.push_back({"rimea-1", "RiMEA 1: walking speed in a corridor", Kind::Criterion, "rimea-01-corridor.xml", "s", 1,
                 "arrival after 26-34 s (40 m at 1.33 m/s)",
                 "the model does not keep a lone person at its preferred speed (or the navigation detours)",
                 "RiMEA 4.1.1 test 1", all, "SocialForces", [] { return std::make_unique<ArrivalObserver>(); }, ""});
    t.push_back({"rimea-2", "RiMEA 2: walking speed up a stair", Kind::OutOfScope, "", "", 0, "", "", "RiMEA 4.1.1 test 2",
                 {}, "", nullptr, "stairs: a 2D model has none"});
    t.push_back({"rimea-3", "RiMEA 3: walking speed down a stair", Kind::OutOfScope, "", "", 0, "", "", "RiMEA 4.1.1 test 3",
                 {}, "", nullptr, "stairs: a 2D model has none"});
    t.push_back({"rimea-4", "RiMEA 4: fundamental diagram (Weidmann)", Kind::Pending, "", "", 0, "", "", "RiMEA 4.1.1 test 4",
                 {}, "", nullptr, "not built yet (validation, issue 16 item 3)"});
    t.push_back({"rimea-5", "RiMEA 5: premovement time", Kind::Criterion, "rimea-05-premovement.xml", "s", 2,
                 "nobody starts walking (half its preferred speed, held 1 s) before its premovement time (uniform 10-100 s; 0.1 s tolerance), everyone starts; value: the largest delay",
                 "people start before their premovement time ends (or never): premovement times are not honoured",
                 "RiMEA 4.1.1 test 5", all, "ORCA", [] { return std::make_unique<PremovementObserver>(); }, ""});
    t.push_back({"rimea-6", "RiMEA 6: movement around a corner", Kind::Criterion, "rimea-06-corner.xml", "m", 3,
                 "all 20 round the corner and out; no body overlaps a wall by more than 0.05 m at any step",
                 "people stay stuck at the corner or are pushed through a wall",
                 "RiMEA 4.1.1 test 6", all, "SocialForces", [] { return std::make_unique<CornerObserver>(); }, ""});
    t.push_back({"rimea-7", "RiMEA 7: demographic parameters", Kind::Criterion, "rimea-07-demographics.xml", "m/s", 3,
                 "every free walking speed (x 5-25 m) in its age group's range +-0.02 m/s; value: the largest excess",
                 "the model changes free walking speeds (or the draws leave their ranges)",
                 "RiMEA 4.1.1 test 7", all, "RVO",
                 [] {
                     return std::make_unique<DemographicsObserver>(std::vector<DemographicsObserver::Group>{
                         {"under 30", 0.58, 1.61, 14}, {"30-50", 1.41, 1.54, 12}, {"over 50", 0.68, 1.41, 12},
                         {"limited", 0.46, 0.76, 12}});
                 },
                 ""});
    for (const char* n : {"8", "9"})
        t.push_back({std::string("rimea-") + n,
                     std::string("RiMEA ") + n + (n[0] == '8' ? ": parameter analysis" : ": crowd leaving a large room"),
                     Kind::Pending, "", "", 0, "", "", std::string("RiMEA 4.1.1 test ") + n, {}, "", nullptr, "not built yet"});
    t.push_back({"rimea-10", "RiMEA 10: allocation of escape routes", Kind::Criterion, "rimea-10-allocation.xml", "persons", 0,
                 "all 24 leave, each by its allocated exit; value: how many did not",
                 "fixed routes are not followed (people take the nearest exit) or people are stuck",
                 "RiMEA 4.1.1 test 10", {"SocialForces-venue", "ORCA", "RVO", "Karamouzas", "PowerLaw"}, "SocialForces-venue", [] { return std::make_unique<AllocationObserver>(); }, ""});
    for (const char* n : {"11", "12"})
        t.push_back({std::string("rimea-") + n,
                     std::string("RiMEA ") + n + (n[1] == '1' ? ": choice of escape route" : ": effect of bottlenecks"),
                     Kind::Pending, "", "", 0, "", "", std::string("RiMEA 4.1.1 test ") + n, {}, "", nullptr, "not built yet"});
    t.push_back({"rimea-13", "RiMEA 13: congestion in front of a stair", Kind::OutOfScope, "", "", 0, "", "",
                 "RiMEA 4.1.1 test 13", {}, "", nullptr, "stairs: a 2D model has none"});
    for (const char* n : {"14", "15", "16"})
        t.push_back({std::string("rimea-") + n,
                     std::string("RiMEA ") + n +
                         (n[1] == '4' ? ": route choice (documented)"
                                      : n[1] == '5' ? ": large crowd around a corner" : ": single-file fundamental diagram"),
                     Kind::Pending, "", "", 0, "", "", std::string("RiMEA 4.1.1 test ") + n, {}, "", nullptr, "not built yet"});
    t.push_back({"iso-max-flow", "ISO/NIST: maximum flow through a 1 m exit", Kind::Criterion, "iso-max-flow.xml",
                 "P/(m s)", 2, "specific flow (10th to 90th of 100 out) <= 1.33 P/(m s)",
                 "the model lets people through a door faster than the IMO maximum (competitive egress)",
                 "ISO 20414 / NIST TN 1822", {"ORCA"}, "ORCA", [] { return std::make_unique<FlowObserver>(); }, ""});
    const std::vector<std::pair<std::string, std::string>> pending = {
        {"iso-corridor", "ISO/NIST: speed in a corridor (40 m at 1.0 m/s +-0.05)"},
        {"iso-premovement-ks", "ISO/NIST: premovement distributions (Kolmogorov-Smirnov)"},
        {"iso-demographics", "ISO/NIST: demographics N(1.2, 0.2) m/s"},
        {"iso-counterflow", "ISO/NIST: counter-flow"},
        {"iso-dynamic-exits", "ISO/NIST: dynamic exit availability"},
        {"iso-groups", "ISO/NIST: groups arrive together"},
        {"val-weidmann", "validation: speed vs density (Weidmann)"},
        {"val-sfpe", "validation: specific flow vs density (SFPE/IMO)"},
        {"val-kretz", "validation: bottleneck flow vs width (Kretz et al. 2006)"},
    };
    for (const auto& [id, title] : pending)
        t.push_back({id, title, Kind::Pending, "", "", 0, "", "", "issue 16", {}, "", nullptr,
                     id == "iso-groups" ? "needs groups (future-work issue)" : "not built yet"});
    return t;
}

// ---------------------------------------------------------------------------------------------
// Running

struct Job {
    std::size_t test = 0;
    std::string model;
    std::uint64_t seed = 1;
    Check check;
    std::string error;  ///< the run failed (loading, building, …)
    double simTime = 0;
};

/// Per test and model, over the seeds.
struct Cell {
    std::string status;  ///< pass, fail, documented, out of scope, pending, error, not run
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
std::optional<fs::path> findTestsDir(const std::string& given, const char* argv0) {
    if (!given.empty()) return fs::path(given);
    std::vector<fs::path> candidates = {fs::current_path() / "Examples" / "verification"};
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back(self.parent_path().parent_path().parent_path() / "Examples" / "verification");
    (void)argv0;
    if (std::string(CH_SOURCE_DIR).size()) candidates.push_back(fs::path(CH_SOURCE_DIR) / "Examples" / "verification");
    for (const fs::path& c : candidates)
        if (fs::is_directory(c, ec)) return c;
    return std::nullopt;
}

}  // namespace

int verifyCommand(int argc, char* argv[]) {
    po::options_description visible("Options");
    // clang-format off
    visible.add_options()
        ("output,o", po::value<std::string>()->value_name("DIR")->default_value("verify-report"),
         "folder for report.md and verify.csv (created if missing)")
        ("quick", "small crowds, one model per test, one seed (about a minute)")
        ("policy", po::value<std::vector<std::string>>()->multitoken()->composing()->value_name("NAME"),
         "run only these models (Examples/verification/models/NAME.xml; default: all)")
        ("test", po::value<std::vector<std::string>>()->multitoken()->composing()->value_name("ID"),
         "run only these tests (e.g. rimea-1 iso-max-flow; default: all)")
        ("jobs,j", po::value<unsigned>()->value_name("N")->default_value(0),
         "runs at a time, each on one thread (0: one per hardware thread)")
        ("seeds", po::value<unsigned>()->value_name("N")->default_value(0),
         "seeds per test and model (0: 3, or 1 with --quick)")
        ("tests-dir", po::value<std::string>()->value_name("DIR"),
         "the folder of the test scenarios (default: Examples/verification here, or beside the program)")
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
                     "Runs the verification tests (RiMEA, ISO 20414 / NIST TN 1822) of Examples/verification/\n"
                     "for each model of Examples/verification/models/ (its policy id 0 replaces the test's\n"
                     "policy id 0) over several seeds, and writes DIR/report.md (test x model: pass, fail,\n"
                     "documented, out of scope, pending) and DIR/verify.csv. Exit status: 0 when every test\n"
                     "passes for every model it is claimed for, 1 when one does not (or a run fails), 2 for a\n"
                     "bad command line or a file that does not load. See docs/verification.md.\n\n"
                  << visible;
        return kExitOk;
    }
    const bool quick = vm.count("quick") != 0, quiet = vm.count("quiet") != 0;
    const fs::path outDir = vm["output"].as<std::string>();
    const std::vector<TestDef> tests = makeTests();

    std::vector<std::string> models = kModels;
    if (vm.count("policy")) {
        models = vm["policy"].as<std::vector<std::string>>();
        for (const std::string& m : models)
            if (std::find(kModels.begin(), kModels.end(), m) == kModels.end()) {
                std::cerr << "crowdhealth verify: unknown model '" << m << "'; the models are:";
                for (const std::string& k : kModels) std::cerr << " " << k;
                std::cerr << "\n";
                return kExitInput;
            }
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
        for (const TestDef& t : tests)
            std::cout << t.id << "  " << t.title
                      << (t.kind == Kind::Criterion ? "" : t.kind == Kind::Pending ? "  (pending)" : "  (out of scope)") << "\n";
        std::cout << "models:";
        for (const std::string& m : kModels) std::cout << " " << m;
        std::cout << "\n";
        return kExitOk;
    }
    const std::optional<fs::path> testsDir =
        findTestsDir(vm.count("tests-dir") ? vm["tests-dir"].as<std::string>() : std::string(), argv[0]);
    if (!testsDir) {
        std::cerr << "crowdhealth verify: cannot find Examples/verification (run from the repository's top folder, "
                     "or give --tests-dir)\n";
        return kExitInput;
    }
    const unsigned seedsWanted = vm["seeds"].as<unsigned>();
    const std::size_t seeds = seedsWanted > 0 ? seedsWanted : quick ? 1 : 3;

    // ---- every model's policy, through the normal loader ----
    std::map<std::string, ch::PolicySpec> policies;
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
    }

    // ---- the runs ----
    std::vector<Job> jobs;
    for (std::size_t k = 0; k < tests.size(); ++k) {
        const TestDef& t = tests[k];
        if (t.kind != Kind::Criterion || (!onlyTests.empty() && !onlyTests.count(t.id))) continue;
        for (const std::string& m : models) {
            if (quick && m != t.quickModel) continue;
            for (std::size_t s = 0; s < seeds; ++s) {
                Job j;
                j.test = k;
                j.model = m;
                j.seed = 1 + s;
                jobs.push_back(std::move(j));
            }
        }
    }
    // Load each test once per seed up front: a test that does not load stops everything before
    // anything runs (exit 2).
    std::map<std::pair<std::size_t, std::uint64_t>, ch::ScenarioSpec> specs;
    for (const Job& j : jobs) {
        const auto key = std::make_pair(j.test, j.seed);
        if (specs.count(key)) continue;
        const fs::path file = *testsDir / tests[j.test].file;
        ch::Diagnostics diags;
        ch::LoadOptions lo;
        lo.seed = j.seed;
        auto spec = ch::loadScenario(file.string(), diags, lo);
        if (!spec || diags.hasErrors()) {
            diags.print(std::cerr);
            std::cerr << "crowdhealth verify: the test " << tests[j.test].id << " (" << file.string() << ") does not load\n";
            return kExitInput;
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
        ch::ScenarioSpec spec = specs.at({j.test, j.seed});
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
        ch::Simulation sim(std::move(spec));
        sim.setThreads(1);
        std::unique_ptr<Observer> obs = t.observer();
        obs->step(sim);
        while (!sim.finished()) {
            sim.stepCoarse();
            obs->step(sim);
            clock[k].store(sim.time(), std::memory_order_relaxed);
        }
        j.simTime = sim.time();
        j.check = obs->finish(sim);
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

    // ---- the cells ----
    std::map<std::pair<std::size_t, std::string>, Cell> cells;
    bool anyError = false;
    for (const Job& j : jobs) {
        Cell& c = cells[{j.test, j.model}];
        const TestDef& t = tests[j.test];
        c.claimed = t.claimed.count(j.model) != 0;
        ++c.seeds;
        if (!j.error.empty()) {
            anyError = true;
            c.status = "error";
            c.detail = "seed " + std::to_string(j.seed) + ": " + j.error;
            continue;
        }
        const double v = j.check.value;
        if (std::isfinite(v)) {
            const std::size_t n = c.seeds;  // running mean over the seeds with a value
            c.mean = std::isfinite(c.mean) ? c.mean + (v - c.mean) / static_cast<double>(n) : v;
            c.min = std::isfinite(c.min) ? std::min(c.min, v) : v;
            c.max = std::isfinite(c.max) ? std::max(c.max, v) : v;
        }
        if (j.check.pass) ++c.passed;
        // The first failing seed's detail, else the first seed's.
        if (c.detail.empty() || (!j.check.pass && !c.detailFails)) {
            c.detail = "seed " + std::to_string(j.seed) + ": " + j.check.detail;
            c.detailFails = !j.check.pass;
        }
    }
    bool allClaimedPass = !anyError;
    std::size_t passCount = 0, failCount = 0, documented = 0;
    for (auto& [key, c] : cells) {
        if (c.status == "error") continue;
        const bool pass = c.passed == c.seeds;
        if (c.claimed) {
            c.status = pass ? "pass" : "fail";
            (pass ? passCount : failCount)++;
            if (!pass) allClaimedPass = false;
        } else {
            c.status = "documented";
            ++documented;
        }
    }

    // ---- report.md and verify.csv ----
    auto cellText = [&](std::size_t k, const std::string& m) -> std::string {
        const TestDef& t = tests[k];
        if (t.kind == Kind::OutOfScope) return "out of scope";
        if (t.kind == Kind::Pending) return "pending";
        const auto it = cells.find({k, m});
        if (it == cells.end()) return "not run";
        const Cell& c = it->second;
        std::string s = c.status == "documented" ? std::string(c.passed == c.seeds ? "documented (meets it)" : "documented (fails it)")
                                                 : c.status;
        if (c.status == "documented" || c.status == "pass" || c.status == "fail") {
            s += " " + fixedNum(c.mean, t.decimals);
            if (c.seeds > 1 && c.max > c.min) s += " (" + fixedNum(c.min, t.decimals) + "-" + fixedNum(c.max, t.decimals) + ")";
        }
        return s;
    };
    std::ostringstream md;
    md << "# crowdhealth verify: report\n\n"
       << (quick ? "Quick run (`--quick`: one model per test, " : "Full run (")
       << seeds << " seed" << (seeds == 1 ? "" : "s") << " per test and model, seeds 1" << (seeds > 1 ? "-" + std::to_string(seeds) : "")
       << "). " << jobs.size() << " runs in " << fixedNum(wall, 1) << " s on " << workers << " thread"
       << (workers == 1 ? "" : "s") << ".\n\n"
       << "**Result: " << (allClaimedPass ? "every claimed test passes" : "FAILURES: a claimed test fails") << "** ("
       << passCount << " pass, " << failCount << " fail, " << documented << " documented only"
       << (anyError ? ", runs with errors" : "") << ").\n\n"
       << "Each cell: the status and the measured value (mean over the seeds, the range in brackets). "
          "`pass`/`fail`: the criterion is claimed for that model; `documented`: measured and shown, not claimed "
          "(\"meets it\" / \"fails it\": whether the criterion holds for every seed); `not run`: left out of this run "
          "(`--quick`, `--policy`, `--test`).\n\n";
    md << "| test |";
    for (const std::string& m : models) md << " " << m << " |";
    md << "\n|---|";
    for (std::size_t i = 0; i < models.size(); ++i) md << "---|";
    md << "\n";
    for (std::size_t k = 0; k < tests.size(); ++k) {
        if (!onlyTests.empty() && !onlyTests.count(tests[k].id)) continue;
        md << "| " << tests[k].id << " |";
        for (const std::string& m : models) md << " " << cellText(k, m) << " |";
        md << "\n";
    }
    md << "\n## The tests\n\n| test | what | unit | criterion | claimed for | a failure means | source |\n|---|---|---|---|---|---|---|\n";
    for (const TestDef& t : tests) {
        if (!onlyTests.empty() && !onlyTests.count(t.id)) continue;
        std::string claimed;
        for (const std::string& m : kModels)
            if (t.claimed.count(m)) claimed += (claimed.empty() ? "" : ", ") + m;
        if (t.kind == Kind::Criterion && claimed.empty()) claimed = "none (documented)";
        md << "| " << t.id << " | " << t.title << (t.file.empty() ? "" : " (`" + t.file + "`)") << " | " << t.unit << " | "
           << (t.kind == Kind::Criterion ? t.criterion : t.kind == Kind::Pending ? "pending: " + t.note : "out of scope: " + t.note)
           << " | " << claimed << " | " << t.failureMeans << " | " << t.source << " |\n";
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
        if (!onlyTests.empty() && !onlyTests.count(t.id)) continue;
        for (const std::string& m : models) {
            const auto it = cells.find({k, m});
            const std::string status = t.kind == Kind::OutOfScope ? "out of scope"
                                       : t.kind == Kind::Pending  ? "pending"
                                       : it == cells.end()        ? "not run"
                                                                  : it->second.status;
            const Cell c = it == cells.end() ? Cell{} : it->second;
            csv << t.id << "," << m << "," << csvField(status) << "," << (t.claimed.count(m) ? "yes" : "no") << ","
                << c.seeds << "," << c.passed << "," << fixedNum(c.mean, 6) << "," << fixedNum(c.min, 6) << ","
                << fixedNum(c.max, 6) << "," << csvField(t.unit) << ","
                << csvField(t.kind == Kind::Criterion ? t.criterion : t.note) << "," << csvField(c.detail) << "\n";
        }
    }
    try {
        ch::writeFileAtomic(outDir / "report.md", md.str());
        ch::writeFileAtomic(outDir / "verify.csv", csv.str());
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth verify: cannot write the report: " << e.what() << "\n";
        return kExitRuntime;
    }
    if (!quiet) {
        std::cout << "crowdhealth verify: " << jobs.size() << " runs in " << formatDuration(wall) << ": " << passCount
                  << " pass, " << failCount << " fail, " << documented << " documented"
                  << (anyError ? ", errors (see the report)" : "") << "\n  report  " << (outDir / "report.md").string()
                  << "\n  table   " << (outDir / "verify.csv").string() << "\n";
        for (const auto& [key, c] : cells)
            if (c.status == "fail" || c.status == "error")
                std::cout << "  " << c.status << ": " << tests[key.first].id << " with " << key.second << ": " << c.detail << "\n";
    }
    return allClaimedPass ? kExitOk : kExitRuntime;
}

}  // namespace chcli
