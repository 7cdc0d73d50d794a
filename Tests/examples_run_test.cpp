// Every shipped scenario runs: each UMANS example in ../shared/umans-examples and each scenario
// under Examples/ loads without errors and steps with finite, moving agents.
#define BOOST_TEST_MODULE examples_run
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace fs = std::filesystem;
using namespace ch;

namespace {

/// A calibration template (Examples/validation): its ${…} placeholders are filled by
/// `crowdhealth calibrate` from a data file; cli_calibrate_test runs the shipped ones.
bool isTemplate(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str().find("${") != std::string::npos;
}

bool isScenario(const fs::path& p) {
    if (isTemplate(p)) return false;
    tinyxml2::XMLDocument doc;
    if (doc.LoadFile(p.string().c_str()) != tinyxml2::XML_SUCCESS) return true;  // let the loader report it
    for (auto* e = doc.FirstChildElement(); e; e = e->NextSiblingElement())
        if (std::string(e->Name()) == "Simulation") return true;
    return false;
}

std::vector<fs::path> scenariosIn(const fs::path& dir, bool recursive) {
    std::vector<fs::path> out;
    if (!fs::exists(dir)) return out;
    auto consider = [&](const fs::directory_entry& e) {
        if (e.is_regular_file() && e.path().extension() == ".xml" && isScenario(e.path())) out.push_back(e.path());
    };
    if (recursive)
        for (const auto& e : fs::recursive_directory_iterator(dir)) consider(e);
    else
        for (const auto& e : fs::directory_iterator(dir)) consider(e);
    std::sort(out.begin(), out.end());
    return out;
}

/// Loads `path`, runs `coarseSteps` steps and checks the state stays finite.
void loadAndStep(const fs::path& path, int coarseSteps) {
    Diagnostics diags;
    auto spec = loadScenario(path.string(), diags);
    std::ostringstream messages;
    diags.print(messages);
    BOOST_TEST_REQUIRE(spec.has_value(), path.string() << " failed to load:\n" << messages.str());
    Simulation sim(*spec);
    sim.setThreads(1);
    std::vector<Vec2> start = sim.agents().pos;
    for (int k = 0; k < coarseSteps && !sim.finished(); ++k) sim.stepCoarse();
    const AgentStore& A = sim.agents();
    bool finite = true;
    for (std::size_t i = 0; i < A.size(); ++i)
        finite = finite && std::isfinite(A.pos[i].x()) && std::isfinite(A.pos[i].y()) &&
                 std::isfinite(A.vel[i].x()) && std::isfinite(A.vel[i].y());
    BOOST_TEST(finite, path.string() << ": non-finite positions or velocities");
    // A scenario whose people all stand still longer than the steps run (RiMEA 5's premovement
    // times of 10-100 s, Examples/verification) has nobody to move yet.
    const bool someoneDue = std::any_of(spec->agents.begin(), spec->agents.end(), [&](const AgentSpec& a) {
        return a.startTime + a.premovement < sim.time();
    });
    if (!start.empty() && A.size() == start.size() && someoneDue) {
        double moved = 0;
        for (std::size_t i = 0; i < A.size(); ++i) moved = std::max(moved, (A.pos[i] - start[i]).norm());
        BOOST_TEST(moved > 0.1, path.string() << ": nobody moved");
    }
}

}  // namespace

BOOST_AUTO_TEST_CASE(every_umans_example_loads_and_steps) {
    const fs::path dir = fs::path(CH_SHARED_DIR) / "umans-examples";
    if (!fs::exists(dir)) {
        BOOST_TEST_MESSAGE("skipped: " << dir << " not found (shared/ must sit beside the repository)");
        return;
    }
    const auto files = scenariosIn(dir, false);
    BOOST_TEST(files.size() >= 100u, "expected the ~130 UMANS example scenarios, found " << files.size());
    for (const fs::path& f : files) {
        BOOST_TEST_CONTEXT(f.filename().string()) { loadAndStep(f, 20); }
    }
}

BOOST_AUTO_TEST_CASE(every_scenario_in_examples_runs) {
    const auto files = scenariosIn(fs::path(CH_SOURCE_DIR) / "Examples", true);
    BOOST_TEST(!files.empty());
    // Under the sanitizers (CROWDHEALTH_SHORT, scripts/test.sh --sanitize) every step is 10-20
    // times slower and the doorway's RVO runs (400 agents, 10 files) dominate CI: 10 steps there still go
    // through every part of the step (and move everyone due by more than 0.1 m); the Release
    // suite runs 50.
    const int steps = std::getenv("CROWDHEALTH_SHORT") ? 10 : 50;
    for (const fs::path& f : files) {
        BOOST_TEST_CONTEXT(f.lexically_relative(CH_SOURCE_DIR).string()) { loadAndStep(f, steps); }
    }
}

BOOST_AUTO_TEST_CASE(the_benchmark_scenes_load_with_their_crowds) {
    // Tests/benchmarks/scenes: the dense crowd of crowdhealth-bench as scenario files for timing
    // the whole program (docs/performance.md). Loaded here so they do not rot; not stepped (the
    // million-agent one alone needs ~1 GB; it is skipped under the sanitizers).
    const fs::path dir = fs::path(CH_SOURCE_DIR) / "Tests" / "benchmarks" / "scenes";
    int loaded = 0;
    for (const auto& [name, agents] : {std::pair<const char*, std::size_t>{"dense-lattice-10k.xml", 10000},
                                      {"dense-lattice-100k.xml", 99856},
                                      {"dense-lattice-1m.xml", 1000000}}) {
        if (agents > 100000 && std::getenv("CROWDHEALTH_SHORT")) continue;
        Diagnostics diags;
        const auto spec = loadScenario((dir / name).string(), diags);
        std::ostringstream messages;
        diags.print(messages);
        BOOST_TEST_REQUIRE(spec.has_value(), name << " failed to load:\n" << messages.str());
        BOOST_TEST(spec->agents.size() == agents, name);
        BOOST_TEST(spec->deltaTimeFine == 0.02, name);
        BOOST_TEST(spec->endTime == 4.0, name);
        ++loaded;
    }
    BOOST_TEST(loaded >= 2);
}
