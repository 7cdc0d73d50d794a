// crowdhealth verify — how a verification test is described (docs/verification.md, "Adding a
// test"). verify.cpp runs the tests; each family of tests lives in its own verify_tests_*.cpp and
// adds its TestDefs in one function declared at the end of this file.
//
// A test is one or more *variants* (a scenario file of Examples/verification/, optionally changed
// in memory: a door closed, a width, a speed), each run for every model and seed. An Observer
// watches each run step by step and returns an Outcome: its own Check, named values and rows of
// numbers for a figure. The test's `combine` turns the outcomes of all its variants for one model
// and seed into the Check the report shows (a ratio of two evacuation times, flows rising with the
// width, …); a test with one variant and no `combine` shows that variant's Check. Its `figure`, if
// any, draws DIR/figures/<id>.png from every outcome of the run.
#pragma once

#include "verify_criteria.h"

#include <crowdhealth/core/simulation.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace chverify {

/// What a run is: which model, seed and variant, and whether it is part of a quick run.
struct RunContext {
    std::string model;
    std::uint64_t seed = 1;
    std::size_t variant = 0;
    bool quick = false;
};

/// What one run measured.
struct Outcome {
    Outcome(Check c = {}) : check(std::move(c)) {}  // NOLINT: a Check is an Outcome without values
    Check check;                          ///< the variant's own criterion (combine may ignore it)
    std::map<std::string, double> values; ///< named measurements for combine and figures
    std::vector<std::vector<double>> rows;///< figure data (e.g. time, people out)
};

/// Watches one run: step() after every coarse step (and once before the first), finish() once it
/// has ended.
class Observer {
public:
    virtual ~Observer() = default;
    virtual void step(const ch::Simulation&) {}
    virtual Outcome finish(const ch::Simulation& sim) = 0;
};

/// One scenario of a test.
struct Variant {
    std::string label;  ///< "4 exits", "b = 0.8 m" (shown in figures and details)
    std::string file;   ///< in Examples/verification/
    /// Changes the loaded scenario before the run (may be empty). Called with the run's context;
    /// with ctx.quick it may shrink the crowd.
    std::function<void(ch::ScenarioSpec&, const RunContext&)> modify;
    bool inQuick = true;  ///< run with --quick
};

enum class Kind {
    Criterion,   ///< pass / fail where claimed, documented elsewhere
    Validation,  ///< an error against experimental data: shown, never pass / fail
    Documented,  ///< RiMEA asks only that the result be documented: shown, never pass / fail
    OutOfScope,  ///< not applicable to a 2D model
    Pending,     ///< not built yet
};

/// Every outcome of one test in this verify run, for its figure.
struct FigureRun {
    std::string model;
    std::uint64_t seed = 1;
    std::size_t variant = 0;
    const Outcome* outcome = nullptr;
};
struct TestDef;
struct FigureInput {
    const TestDef* test = nullptr;
    std::vector<std::string> models;  ///< in the report's order, those that ran
    std::vector<FigureRun> runs;
};

struct TestDef {
    std::string id;            ///< --test ID, e.g. "rimea-1"
    std::string title;
    Kind kind = Kind::Criterion;
    std::string unit;          ///< of the measured value
    int decimals = 2;
    std::string criterion;     ///< the pass criterion (or what the value is), as the report states it
    std::string failureMeans;  ///< one line: what a failure means
    std::string source;        ///< RiMEA 4.1.1 test 1, ISO 20414 …
    /// Models the pass is claimed for; for the others the result is only documented.
    std::set<std::string> claimed;
    std::string quickModel;    ///< the one model run with --quick
    std::vector<Variant> variants;
    std::function<std::unique_ptr<Observer>(const RunContext&)> observer;
    /// The outcomes of every variant (in order) for one model and seed → the Check shown. Empty:
    /// the only variant's Check.
    std::function<Check(const std::vector<const Outcome*>&, const RunContext&)> combine;
    /// Draws the figure into `png`; returns "" or an error. Empty: no figure.
    std::function<std::string(const FigureInput&, const std::filesystem::path& png)> figure;
    std::size_t seeds = 0;     ///< seeds for this test (0: the command's)
    /// The id of another test whose runs this one reads instead of running its own (RiMEA 4's
    /// corridor runs serve the validations against Weidmann and SFPE): that test's variants,
    /// observer, quick model and seeds apply, and it runs when either is asked for. This test
    /// brings its own kind, texts, claimed models, `combine` (required) and `figure`.
    std::string runsOf;
    std::string note;          ///< for rows without a criterion: why, or what is shown
};

/// The models of `verify` (files Examples/verification/models/<name>.xml), in the report's order.
const std::vector<std::string>& modelNames();
/// All models, as a set (for TestDef::claimed).
std::set<std::string> allModels();

/// The time each agent left by an exit, by id.
std::map<ch::AgentId, const ch::Evacuation*> evacuationsById(const ch::Simulation& sim);

// ---- the families of tests (each in its own verify_tests_*.cpp) ----
/// RiMEA 1, 5, 6, 7, 10, stairs (2, 3, 13), ISO maximum flow (verify_tests_basic.cpp).
void addBasicTests(std::vector<TestDef>& tests);
/// RiMEA 4 and 16, validation against Weidmann and SFPE/IMO (verify_tests_fundamental.cpp).
void addFundamentalTests(std::vector<TestDef>& tests);
/// RiMEA 12 (a-d), validation against Kretz et al. (verify_tests_bottleneck.cpp).
void addBottleneckTests(std::vector<TestDef>& tests);
/// RiMEA 8, 9, 11, 14, 15, ISO dynamic exits (verify_tests_evacuation.cpp).
void addEvacuationTests(std::vector<TestDef>& tests);
/// ISO/NIST corridor speed, premovement (KS), demographics, counter-flow, groups
/// (verify_tests_iso.cpp).
void addIsoTests(std::vector<TestDef>& tests);

}  // namespace chverify
