// The XML loader: both UMANS dialects, CrowdHealth's extensions, and every class of error with
// its file and line. Test scenarios live in Tests/data/xml/; they use the fake component below
// so these tests do not depend on any real model's parameter table.
#define BOOST_TEST_MODULE xml_loader
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/registry.h"
#include "crowdhealth/io/xml.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <utility>

using namespace ch;

namespace {

/// A do-nothing cost function with one parameter of each kind, registered only in this test.
class TestOnlyCost : public Component {
public:
    static ComponentInfo Info() {
        ComponentInfo info;
        info.name = "TestOnlyCost";
        info.summary = "test fixture: cost 0 everywhere";
        info.reference = "none";
        info.params = {
            ParamSpec::real("strength", "N", 1.0, 0, 100, "a bounded real"),
            ParamSpec::choice("mode", {"a", "b"}, 0, "a choice"),
            ParamSpec::integer("count", 1, 0, 10, "a whole number"),
        };
        info.create = [](const ParamSet& p) { return std::make_unique<TestOnlyCost>(p); };
        return info;
    }
    explicit TestOnlyCost(const ParamSet& p) { bind(p, "range", range_); }
    double cost(const Vec2&, const AgentQuery&, const StepContext&) const override { return 0.0; }
};

}  // namespace

CH_REGISTER_COMPONENT(TestOnlyCost);

namespace {

std::string data(const std::string& name) { return std::string(CH_SOURCE_DIR) + "/Tests/data/xml/" + name; }

struct Load {
    Diagnostics diags;
    std::optional<ScenarioSpec> spec;
    explicit Load(const std::string& name, const LoadOptions& options = {}) {
        spec = loadScenario(data(name), diags, options);
        std::ostringstream out;
        diags.print(out);
        BOOST_TEST_MESSAGE("diagnostics of " << name << ":\n" << out.str());
    }
    /// Formatted lines of all diagnostics.
    std::vector<std::string> lines() const {
        std::vector<std::string> out;
        for (const Diagnostic& d : diags.all()) out.push_back(d.format());
        return out;
    }
    /// True when exactly this diagnostic was reported ("<file>:<line>: error: <message>").
    bool has(const std::string& file, int line, const std::string& severityAndMessage) const {
        const std::string want = data(file) + ":" + std::to_string(line) + ": " + severityAndMessage;
        const auto all = lines();
        return std::find(all.begin(), all.end(), want) != all.end();
    }
    /// The scenario, which must have loaded without a single diagnostic.
    const ScenarioSpec& requireClean() const {
        BOOST_REQUIRE(spec.has_value());
        BOOST_TEST(diags.all().empty());
        return *spec;
    }
    int warnings() const {
        return static_cast<int>(std::count_if(diags.all().begin(), diags.all().end(),
                                              [](const Diagnostic& d) { return d.severity == Severity::Warning; }));
    }
};

#define CHECK_DIAG(load, file, line, text) BOOST_TEST((load).has(file, line, text), "missing: " << file << ":" << line << ": " << text)

/// A diagnostic a test expects in a given file: its line and "<severity>: <message>".
struct Expected {
    int line;
    std::string text;
};

/// Checks that each expected diagnostic was reported, at exactly its line of `file`.
void checkReported(const Load& L, const std::string& file, const std::vector<Expected>& expected) {
    for (const Expected& e : expected) CHECK_DIAG(L, file, e.line, e.text);
}

/// Loads `file`, which must fail, and checks that each expected diagnostic was reported in it.
Load loadFailing(const std::string& file, const std::vector<Expected>& expected) {
    Load L(file);
    BOOST_TEST(!L.spec.has_value());
    checkReported(L, file, expected);
    return L;
}

/// The registered component names as the loader lists them: "A, B, C".
std::string registeredNames() {
    std::string names;
    for (const std::string& n : Registry::instance().names()) names += (names.empty() ? "" : ", ") + n;
    return names;
}

bool near(double a, double b, double tol = 1e-12) { return std::fabs(a - b) <= tol; }

/// The motion settings of an agent, as <Agent> (or an agent generator) sets them.
struct Motion {
    double prefSpeed;
    double maxSpeed;
    double maxAcceleration;
    bool removeAtGoal;
    double startTime;
    double goalRadius;
};

/// Checks that the loader gave agent `a` exactly these motion settings.
void checkMotion(const AgentSpec& a, const Motion& want) {
    BOOST_TEST_CONTEXT("agent " << a.id) {
        BOOST_TEST(a.prefSpeed == want.prefSpeed);
        BOOST_TEST(a.maxSpeed == want.maxSpeed);
        BOOST_TEST(a.maxAcceleration == want.maxAcceleration);
        BOOST_TEST(a.removeAtGoal == want.removeAtGoal);
        BOOST_TEST(a.startTime == want.startTime);
        BOOST_TEST(a.goalRadius == want.goalRadius);
    }
}

}  // namespace

BOOST_AUTO_TEST_SUITE(dialects)

BOOST_AUTO_TEST_CASE(umans_1x_inline) {
    Load L("umans1_inline.xml");
    const ScenarioSpec& s = L.requireClean();
    BOOST_TEST(s.sourceFile == data("umans1_inline.xml"));
    BOOST_TEST(s.deltaTime == 0.05);
    BOOST_TEST(s.endTime == 20.0);
    BOOST_TEST(s.deltaTimeFine == 0.0);
    BOOST_TEST(s.fineStepsPerCoarse() == 1);
    BOOST_TEST(s.seed == 1u);
    BOOST_TEST((s.world.type == WorldType::Toric));
    BOOST_TEST(s.world.width == 12.0);
    BOOST_TEST(s.world.height == 8.0);
    BOOST_TEST(s.world.loc.line == 4);

    BOOST_REQUIRE(s.obstacles.size() == 1u);
    BOOST_REQUIRE(s.obstacles[0].points.size() == 3u);
    BOOST_TEST(s.obstacles[0].points[1].x() == 1.0);
    BOOST_TEST(s.obstacles[0].points[1].y() == -1.0);
    BOOST_TEST(s.obstacles[0].particles.empty());

    BOOST_REQUIRE(s.policies.size() == 2u);
    const PolicySpec& p3 = s.policies[0];
    BOOST_TEST(p3.id == 3);
    BOOST_TEST(p3.name == "sampler");
    BOOST_TEST(p3.contactForceScale == 10.0);
    BOOST_TEST(p3.loc.line == 14);
    BOOST_REQUIRE(p3.steps.size() == 1u);
    const StepSpec& st = p3.steps[0];
    BOOST_TEST((st.timing == StepTiming::Coarse));
    BOOST_TEST((st.method == OptimisationMethod::Sampling));
    BOOST_TEST(st.relaxationTime == 0.5);
    BOOST_TEST(st.stopAtGoal);
    BOOST_TEST((st.sampling.type == SamplingSpec::Type::Random));
    BOOST_TEST((st.sampling.base == SamplingSpec::Base::CurrentVelocity));
    BOOST_TEST((st.sampling.baseDirection == SamplingSpec::BaseDirection::PreferredVelocity));
    BOOST_TEST((st.sampling.radius == SamplingSpec::Radius::MaximumAcceleration));
    BOOST_TEST(st.sampling.angle == 180.0);
    BOOST_TEST(st.sampling.speedSamples == 4);
    BOOST_TEST(st.sampling.angleSamples == 9);
    BOOST_TEST(st.sampling.randomSamples == 50);
    BOOST_TEST(st.sampling.includeBaseAsSample);
    BOOST_REQUIRE(st.components.size() == 2u);
    const ComponentSpec& c = st.components[0];
    BOOST_TEST(c.name == "TestOnlyCost");
    BOOST_TEST(c.coeff == 2.5);
    BOOST_TEST(c.params.get("coeff") == 2.5);
    BOOST_TEST(c.params.get("range") == 4.0);
    BOOST_TEST(c.params.get("strength") == 7.0);
    BOOST_TEST(c.params.choice("mode") == "b");
    BOOST_TEST(c.params.get("count") == 3.0);
    BOOST_TEST(c.loc.line == 15);
    // The second one (written <CostFunction>) has every default filled in.
    const ComponentSpec& d = st.components[1];
    BOOST_TEST(d.coeff == 1.0);
    BOOST_TEST(d.params.get("strength") == 1.0);
    BOOST_TEST(d.params.choice("mode") == "a");
    BOOST_TEST(d.params.get("range") == Registry::commonParams()[1].defaultValue);

    // <policy> in lower case, gradient, UMANS defaults for everything else.
    const PolicySpec& p0 = s.policies[1];
    BOOST_TEST(p0.id == 0);
    BOOST_TEST(p0.contactForceScale == PolicySpec{}.contactForceScale);
    BOOST_TEST((p0.steps.at(0).method == OptimisationMethod::Gradient));
    BOOST_TEST(p0.steps.at(0).relaxationTime == 0.0);
    const SamplingSpec def;
    BOOST_TEST((p0.steps.at(0).sampling.type == def.type));
    BOOST_TEST((p0.steps.at(0).sampling.baseDirection == SamplingSpec::BaseDirection::CurrentVelocity));
    BOOST_TEST(p0.steps.at(0).sampling.speedSamples == def.speedSamples);

    BOOST_REQUIRE(s.agents.size() == 3u);
    const AgentSpec& a = s.agents[0];
    BOOST_TEST(a.id == 0);  // automatic: first free id
    BOOST_TEST(a.radius == 0.3);
    BOOST_TEST(a.mass == 2.0);
    checkMotion(a, {.prefSpeed = 1.3, .maxSpeed = 1.6, .maxAcceleration = 1e6, .removeAtGoal = true, .startTime = 1.5,
                    .goalRadius = 0.5});
    BOOST_TEST(a.position.x() == -5.0);
    BOOST_REQUIRE(a.goal.has_value());
    BOOST_TEST(a.goal->x() == 5.0);
    BOOST_TEST(a.policyId == 3);
    BOOST_REQUIRE(a.color.has_value());
    BOOST_TEST((*a.color == std::array<std::uint8_t, 3>{160, 76, 157}));
    BOOST_TEST(a.loc.line == 23);
    BOOST_TEST(a.loc.file == data("umans1_inline.xml"));

    // Defaults of UMANS' Agent::Settings, and ids: explicit 7, then the next after the highest.
    const AgentSpec& b = s.agents[1];
    BOOST_TEST(b.id == 7);
    BOOST_TEST(b.radius == 0.24);
    BOOST_TEST(b.mass == 1.0);
    checkMotion(b, {.prefSpeed = 1.4, .maxSpeed = 1.8, .maxAcceleration = 5.0, .removeAtGoal = false, .startTime = 0.0,
                    .goalRadius = -1.0});
    BOOST_TEST(!b.color.has_value());
    BOOST_TEST(b.position.y() == 2.0);
    BOOST_TEST(b.goal->y() == 4.0);
    BOOST_TEST(s.agents[2].id == 8);
    BOOST_TEST(s.agents[2].position.x() == 0.5);  // "+0.5" and " 0 " are numbers
}

BOOST_AUTO_TEST_CASE(sph_era_steps_and_spawn_rectangle) {
    Load L("sph_era.xml");
    const ScenarioSpec& s = L.requireClean();
    BOOST_TEST(s.deltaTimeFine == 0.02);
    BOOST_TEST(s.fineStep() == 0.02);
    BOOST_TEST(s.fineStepsPerCoarse() == 5);
    BOOST_TEST((s.world.type == WorldType::Planar));
    BOOST_TEST(s.world.xmin == -10.0);
    BOOST_TEST(s.world.xmax == 10.0);
    BOOST_TEST(s.world.ymin == -5.0);
    BOOST_TEST(s.world.ymax == 5.0);

    BOOST_REQUIRE(s.policies.size() == 1u);
    const PolicySpec& p = s.policies[0];
    BOOST_TEST(p.contactForceScale == 0.0);
    BOOST_REQUIRE(p.steps.size() == 2u);
    BOOST_TEST((p.steps[0].timing == StepTiming::Fine));
    BOOST_TEST(!p.steps[0].stopAtGoal);
    BOOST_TEST((p.steps[0].method == OptimisationMethod::Gradient));
    BOOST_REQUIRE(p.steps[0].components.size() == 2u);
    BOOST_TEST(p.steps[0].components[0].params.get("strength") == 3.0);
    BOOST_TEST((p.steps[1].timing == StepTiming::Coarse));
    BOOST_TEST(p.steps[1].stopAtGoal);
    BOOST_TEST((p.steps[1].method == OptimisationMethod::Sampling));
    BOOST_TEST(p.steps[1].sampling.speedSamples == 2);
    BOOST_TEST(p.steps[1].sampling.angleSamples == 5);
    BOOST_TEST(p.steps[1].components.at(0).coeff == 0.5);
    BOOST_TEST(p.steps[1].loc.line == 10);

    // 2 × 4 agents at the cell centres of [-8,-4]×[-2,2], in 3 waves (t = 1, 2, 3), ±0.1 m jitter.
    BOOST_REQUIRE(s.agents.size() == 24u);
    std::set<AgentId> ids;
    std::map<double, int> perWave;
    bool jittered = false;
    for (const AgentSpec& a : s.agents) {
        ids.insert(a.id);
        ++perWave[a.startTime];
        BOOST_TEST(a.removeAtGoal);
        BOOST_TEST(a.policyId == 0);
        BOOST_TEST(a.goal->x() == 9.0);
        BOOST_TEST(a.radius >= 0.23);
        BOOST_TEST(a.radius <= 0.27);
        const double cx = a.position.x() < -6 ? -7.0 : -5.0;
        const double cy = std::round(a.position.y() + 0.5) - 0.5;
        BOOST_TEST(std::fabs(a.position.x() - cx) <= 0.1);
        BOOST_TEST(std::fabs(a.position.y() - cy) <= 0.1);
        jittered = jittered || a.position.x() != cx;
        BOOST_TEST(a.loc.line == 16);
    }
    BOOST_TEST(jittered);
    BOOST_TEST(ids.size() == 24u);
    BOOST_TEST(*ids.begin() == 0);
    BOOST_TEST(*ids.rbegin() == 23);
    BOOST_TEST((perWave == std::map<double, int>{{1.0, 8}, {2.0, 8}, {3.0, 8}}));
    // The first wave fills the rectangle row by row from its lower-left cell.
    BOOST_TEST(std::fabs(s.agents[0].position.x() + 7.0) <= 0.1);
    BOOST_TEST(std::fabs(s.agents[0].position.y() + 1.5) <= 0.1);
}

BOOST_AUTO_TEST_CASE(external_files_resolve_against_the_naming_file) {
    // agents.xml starts with a stray <Simulation/> and holds a <!-----…> comment, as UMANS' own files do.
    Load L("external/main.xml");
    const ScenarioSpec& s = L.requireClean();
    BOOST_REQUIRE(s.agents.size() == 2u);
    BOOST_TEST(s.agents[1].position.x() == 5.0);
    BOOST_TEST(s.agents[1].id == 1);
    BOOST_TEST(s.agents[1].loc.file == data("external/parts/agents.xml"));
    BOOST_TEST(s.agents[1].loc.line == 12);
    BOOST_REQUIRE(s.policies.size() == 1u);
    BOOST_TEST(s.policies[0].steps.at(0).components.at(0).params.get("strength") == 4.0);
    BOOST_REQUIRE(s.obstacles.size() == 2u);
    BOOST_TEST(s.obstacles[0].points.size() == 2u);
    BOOST_TEST(s.obstacles[1].points.size() == 4u);
    BOOST_TEST(s.obstacles[1].loc.file == data("external/parts/obstacles.xml"));
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_SUITE(extensions)

BOOST_AUTO_TEST_CASE(seed_grid_box_output) {
    Load L("extensions.xml");
    const ScenarioSpec& s = L.requireClean();
    BOOST_TEST(s.seed == 42u);
    BOOST_TEST(s.endTime < 0.0);  // no end_time: until every agent has left
    BOOST_TEST(s.fineStepsPerCoarse() == 4);
    BOOST_TEST((s.world.type == WorldType::Infinite));

    BOOST_TEST(s.output.metricsInterval == 0.5);
    BOOST_TEST(s.output.trajectories == "both");
    BOOST_TEST(s.output.flowFirst == 2);
    BOOST_TEST(s.output.flowLast == 100);

    // Box inside <World>: CCW corners and 4 × 2 particles at the centres of 0.5 m cells.
    BOOST_REQUIRE(s.obstacles.size() == 2u);
    const ObstacleSpec& box = s.obstacles[0];
    BOOST_REQUIRE(box.points.size() == 4u);
    BOOST_TEST((box.points[0] == Vec2(0, 0)));
    BOOST_TEST((box.points[1] == Vec2(2, 0)));
    BOOST_TEST((box.points[2] == Vec2(2, 1)));
    BOOST_TEST((box.points[3] == Vec2(0, 1)));
    double area = 0;
    for (std::size_t i = 0; i < 4; ++i) {
        const Vec2& p = box.points[i];
        const Vec2& q = box.points[(i + 1) % 4];
        area += 0.5 * (p.x() * q.y() - q.x() * p.y());
    }
    BOOST_TEST(area == 2.0);  // positive: counter-clockwise
    BOOST_REQUIRE(box.particles.size() == 8u);
    std::set<std::pair<double, double>> particles;
    for (const Vec2& p : box.particles) particles.insert({p.x(), p.y()});
    for (double x : {0.25, 0.75, 1.25, 1.75})
        for (double y : {0.25, 0.75}) BOOST_TEST(particles.count({x, y}) == 1u);
    // Box inside a top-level <Obstacles>, without particles.
    BOOST_TEST(s.obstacles[1].particles.empty());
    BOOST_TEST((s.obstacles[1].points[2] == Vec2(11, 3)));

    BOOST_REQUIRE(s.agents.size() == 13u);
    BOOST_TEST(s.agents[0].mass == (0.36 / 0.24) * (0.36 / 0.24));  // mass="auto"
    // AgentGrid: 4 columns × 3 rows from (-5,-5), 1.5 m apart, radius in [0.215, 0.265].
    std::set<double> radii;
    for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 4; ++col) {
            const AgentSpec& a = s.agents.at(1 + row * 4 + col);
            BOOST_TEST(a.id == 1 + row * 4 + col);
            BOOST_TEST((a.position == Vec2(-5 + 1.5 * col, -5 + 1.5 * row)));
            BOOST_TEST(a.radius >= 0.215);
            BOOST_TEST(a.radius <= 0.265);
            BOOST_TEST(near(a.mass, (a.radius / 0.24) * (a.radius / 0.24)));
            checkMotion(a, {.prefSpeed = 1.2, .maxSpeed = 1.8, .maxAcceleration = 1000.0, .removeAtGoal = true,
                            .startTime = 2.0, .goalRadius = 0.5});
            BOOST_TEST(a.goal->x() == 20.0);
            radii.insert(a.radius);
        }
    }
    BOOST_TEST(radii.size() == 12u);  // drawn, not constant
}

std::vector<double> radii(const ScenarioSpec& s) {
    std::vector<double> out;
    for (const AgentSpec& a : s.agents) out.push_back(a.radius);
    return out;
}

BOOST_AUTO_TEST_CASE(generated_agents_depend_only_on_the_seed) {
    Load a("extensions.xml"), b("extensions.xml");
    BOOST_REQUIRE(a.spec && b.spec);
    BOOST_TEST(radii(*a.spec) == radii(*b.spec));

    LoadOptions seven;
    seven.seed = 7;
    Load c("extensions.xml", seven), d("extensions.xml", seven);
    BOOST_REQUIRE(c.spec && d.spec);
    BOOST_TEST(c.spec->seed == 7u);  // the option overrides Simulation@seed="42"
    BOOST_TEST(radii(*c.spec) == radii(*d.spec));
    BOOST_TEST(radii(*c.spec) != radii(*a.spec));

    LoadOptions fortyTwo;
    fortyTwo.seed = 42;
    Load e("extensions.xml", fortyTwo);
    BOOST_REQUIRE(e.spec);
    BOOST_TEST(radii(*e.spec) == radii(*a.spec));

    // SpawnRectangle noise as well.
    Load f("sph_era.xml", seven), g("sph_era.xml");
    BOOST_REQUIRE(f.spec && g.spec);
    BOOST_TEST(g.spec->seed == 1u);
    BOOST_TEST(f.spec->agents.at(0).position.x() != g.spec->agents.at(0).position.x());
}

BOOST_AUTO_TEST_CASE(automatic_agent_ids) {
    // auto, 1, auto, 10, auto, 5, auto  →  0, 1, 2, 10, 11, 5, 12 (UMANS: next after the highest).
    Load L("ids.xml");
    BOOST_REQUIRE(L.spec.has_value());
    std::vector<AgentId> ids;
    for (const AgentSpec& a : L.spec->agents) ids.push_back(a.id);
    BOOST_TEST((ids == std::vector<AgentId>{0, 1, 2, 10, 11, 5, 12}));
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_SUITE(errors)

BOOST_AUTO_TEST_CASE(every_error_is_reported_with_file_and_line) {
    const std::string f = "errors_many.xml";
    const Load L = loadFailing(f, {
        // Unknown attribute / element, with suggestions.
        {2, "error: unknown attribute 'end_tme' on <Simulation> (did you mean 'end_time'?)"},
        {4, "error: unknown element <Wrld> in <Simulation> (did you mean 'World'?)"},
        {8, "error: unknown attribute 'strenght' on <costfunction> (did you mean 'strength'?)"},
        {28, "error: unknown element <colour> in <Agent> (did you mean 'color'?)"},
        {24, "error: unknown attribute 'raduis' on <Agent>; allowed: id, rad, pref_speed, max_speed, "
             "max_acceleration, mass, remove_at_goal, start_time, goal_radius, premovement, journey, group"},
        // Bad words.
        {6, "error: Policy@OptimizationMethod: 'gradiant' is not one of: gradient, sampling, global "
            "(did you mean 'gradient'?)"},
        {21, "error: Agent@remove_at_goal: 'yes' is not a boolean (true, false, 1 or 0)"},
        // Unknown cost function, listing the registered names.
        {7, "error: unknown cost function 'NoSuchCost'; registered: " + registeredNames() +
                " (a component from a plugin needs <Plugin file=\"…\"/> or --plugin FILE)"},
        // Out of range, with range and unit.
        {3, "error: World@width: 0 is not in (0, inf) m"},
        {11, "error: TestOnlyCost@strength: 1000 is not in [0, 100] N"},
        {13, "error: Policy@SamplingAngle: 0 is not in (0, 360] deg"},
        {13, "error: Policy@SpeedSamples: 0 is not in [1, inf)"},
        {17, "error: Agent@rad: 0 is not in (0, 10] m"},
        {24, "error: Agent@max_speed: 25 is not in [0, 20] m/s"},
        {24, "error: Agent@start_time: -1 is not in [0, inf) s"},
        // Missing required values and elements.
        {3, "error: World@height: missing required value (expected in (0, inf) m)"},
        {21, "error: Agent: missing required element <pos x=\"…\" y=\"…\"/>"},
        {21, "error: Agent: missing required element <Policy id=\"…\"/>"},
        {13, "error: Policy 1: needs at least one <costfunction>"},
        // Non-numeric, NaN, inf, bad seed.
        {18, "error: pos@x: 'abc' is not a number"},
        {18, "error: pos@y: 'nan' is not a finite number"},
        {21, "error: Agent@pref_speed: 'inf' is not a finite number"},
        {2, "error: Simulation@seed: '-3' is not a whole number in [0, 18446744073709551615]"},
        // Duplicates and dangling references.
        {10, "error: duplicate policy id 0 (first defined at " + data(f) + ":6)"},
        {21, "error: duplicate agent id 4 (first used at " + data(f) + ":17)"},
        {19, "error: Policy@id: policy 9 does not exist (defined: 0, 1)"},
        // CrowdHealth's own elements are checked like any other.
        {31, "error: unknown attribute 'bogus' on <Schedule> (it takes no attributes)"},
        // What UMANS only warns about stays a warning.
        {17, "warning: Agent has no <goal>: it will stay where it is"},
    });
    // Nothing else: the list above is complete, so no error hides another or is reported twice.
    BOOST_TEST(L.diags.errorCount() == 27);
    BOOST_TEST(L.warnings() == 1);
}

BOOST_AUTO_TEST_CASE(structural_errors) {
    const std::string f = "structure.xml";
    const Load L = loadFailing(f, {
        {3, "error: World: xmin (5) must be less than xmax (-5)"},
        {5, "error: Policy@OptimizationMethod: in a policy made of <Step> elements, "
            "OptimizationMethod belongs on each <Step>"},
        {6, "error: Step@DeltaTime: 'medium' is not one of: coarse, fine"},
        {7, "error: TestOnlyCost@mode: 'c' is not one of: a, b (did you mean 'a'?)"},
        {10, "error: Policy@OptimizationMethod: missing required value (one of: gradient, sampling, global)"},
        {11, "error: TestOnlyCost@count: '2.5' is not a whole number"},
        {13, "error: Policy 2: needs at least one <costfunction>"},
        {18, "error: more than one <pos> in <Agent> (the first is at line 17)"},
        {21, "error: color@r: 300 is not in [0, 255]"},
        {21, "error: color@b: missing required value (expected in [0, 255])"},
        {23, "error: <Obstacle> is not allowed in <Agents>; it belongs inside <Obstacles> or <World>"},
        {24, "error: AgentGrid@columns: 0 is not in [1, inf)"},
        {24, "error: AgentGrid: rad_min (0.3 m) must not exceed rad_max (0.2 m)"},
        {24, "error: AgentGrid: missing required element <Policy id=\"…\"/>"},
        {27, "error: SpawnRectangle: AgentRadiusNoise must be smaller than AgentRadius, so every "
             "radius stays in (0, 10] m"},
        {27, "error: SpawnRectangle: EndTime is required when Interval > 0"},
        {27, "warning: SpawnRectangle has no <goal>: its agents will stay where they are"},
        {32, "error: Obstacle: needs at least 2 <Point> elements, found 1"},
        {35, "error: Box@width: -1 is not in (0, inf) m"},
        {35, "error: Box@particles: 'maybe' is not a boolean (true, false, 1 or 0)"},
        {37, "error: Output@metrics_interval: 0 is not in (0, inf) s"},
        {37, "error: Output@trajectories: 'csv' is not one of: umans, txt, bin, both, none, nor a "
             "comma-separated list of them such as txt,bin"},
        {37, "error: Output@flow_last: 5 must be greater than flow_first (10)"},
        // Several top-level elements: tolerated as UMANS does, but not silently.
        {39, "warning: <Agents> outside <Simulation> is ignored; move it inside <Simulation>"},
        {40, "error: unknown element <Scenario> at the top level; allowed here: Simulation"},
    });
    BOOST_TEST(L.diags.errorCount() == 23);
}

BOOST_AUTO_TEST_CASE(xml_syntax_error_at_its_line) {
    // tinyxml2 reports the line of the element it could not close (the unclosed <pos>).
    const Load L = loadFailing("syntax_error.xml",
                               {{6, "error: XML syntax error: mismatched element (XMLElement name=pos)"}});
    BOOST_REQUIRE(L.diags.all().size() == 1u);
}

BOOST_AUTO_TEST_CASE(missing_files_at_the_naming_element) {
    const std::string f = "missing_files.xml";
    const std::string dir = data("");
    const Load L = loadFailing(f, {
        {4, "error: cannot find file 'obstacles/none.xml' (looked for '" + dir + "obstacles/none.xml')"},
        {6, "error: cannot find file 'no/such/policies.xml' (looked for '" + dir + "no/such/policies.xml')"},
        {7, "error: cannot find file 'missing_agents.xml' (looked for '" + dir + "missing_agents.xml')"},
    });
    // No follow-up noise ("no policy defined", "no agents").
    BOOST_TEST(L.diags.all().size() == 3u);

    Diagnostics d;
    BOOST_TEST(!loadScenario(data("does_not_exist.xml"), d).has_value());
    BOOST_REQUIRE(d.all().size() == 1u);
    BOOST_TEST(d.all()[0].format() == data("does_not_exist.xml") + ": error: cannot find file '" +
                                          data("does_not_exist.xml") + "'");
}

BOOST_AUTO_TEST_CASE(errors_inside_named_files_name_those_files) {
    Load L("broken_part.xml");
    BOOST_TEST(!L.spec.has_value());
    CHECK_DIAG(L, "parts/bad_policies.xml", 4, "error: XML syntax error: mismatched element (XMLElement name=costfunction)");
    CHECK_DIAG(L, "parts/bad_agents.xml", 8, "error: Agent@rad: 11 is not in (0, 10] m");
    // The policies file is unreadable, so the agents' policy references are not also reported.
    BOOST_TEST(L.diags.errorCount() == 2);
}

BOOST_AUTO_TEST_CASE(named_file_without_the_expected_element) {
    const Load L = loadFailing("wrong_root.xml",
                               {{5, "error: file 'external/parts/policies.xml' has no <Agents> element"}});
    BOOST_TEST(L.diags.all().size() == 1u);  // no "no agents" warning on top
}

BOOST_AUTO_TEST_CASE(time_steps) {
    const Load L = loadFailing("time_steps.xml", {
        {2, "error: Simulation: delta_time (0.1 s) is not a whole multiple of delta_time_fine (0.03 s)"},
        {2, "error: Simulation@end_time: 0 is not in (0, inf) s"},
        {2, "warning: no agents: the simulation starts empty"},
    });
    BOOST_TEST(L.diags.errorCount() == 2);

    const Load M = loadFailing("no_delta_time.xml", {
        {2, "error: Simulation@delta_time: missing required value (expected in (0, inf) s)"},
        {3, "warning: World@type is missing; using Infinite"},
        {10, "warning: Agent has no <goal>: it will stay where it is"},
    });
    BOOST_TEST(M.diags.errorCount() == 1);
}

BOOST_AUTO_TEST_CASE(schedule_and_crowdhealth_load) {
    // Once planned, now implemented (Tests/health_*_test.cpp cover them in depth).
    Load L("schedule.xml");
    BOOST_REQUIRE(L.spec.has_value());
    BOOST_TEST(L.diags.errorCount() == 0);
    BOOST_REQUIRE(L.spec->ramps.size() == 1u);
    BOOST_TEST(L.spec->ramps[0].column() == "TestOnlyCost.strength");
    BOOST_TEST(L.spec->policies[0].health.has_value());
}

BOOST_AUTO_TEST_CASE(warnings_alone_do_not_fail_a_load) {
    Load L("no_agents.xml");
    BOOST_REQUIRE(L.spec.has_value());
    BOOST_TEST(L.spec->agents.empty());
    BOOST_REQUIRE(L.diags.all().size() == 1u);
    CHECK_DIAG(L, "no_agents.xml", 2, "warning: no agents: the simulation starts empty");
}

BOOST_AUTO_TEST_CASE(errors_before_the_load_do_not_count) {
    // loadScenario fails only on its own errors, even if the caller's Diagnostics already held some.
    Diagnostics d;
    d.error({"elsewhere", 1}, "earlier problem");
    BOOST_TEST(loadScenario(data("no_agents.xml"), d).has_value());
    BOOST_TEST(d.errorCount() == 1);
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_CASE(attributes_of_another_world_type_are_warned_about) {
    Load L("world_other_type_attributes.xml");
    const std::string f = "world_other_type_attributes.xml";
    BOOST_TEST(L.spec.has_value());  // a warning, not an error (UMANS ignores them)
    CHECK_DIAG(L, f, 4, "warning: World@xmin is ignored: it applies to Planar worlds, this one is Toric");
}

BOOST_AUTO_TEST_CASE(agent_names_read_as_strings_and_copies_share_them) {
    // AgentSpec::journey and ::group are SharedNames (8 bytes in a spec instead of 32): they must
    // read, compare and concatenate as the strings they hold, and outlive the spec they came from.
    SharedName none;
    BOOST_TEST(none.empty());
    BOOST_TEST(none.str().empty());
    BOOST_TEST(none == "");
    BOOST_TEST(SharedName("").empty(), "an empty text is no name");
    std::optional<SharedName> a(std::in_place, std::string("door/g2"));
    SharedName b = *a;  // a copy shares the text
    BOOST_TEST(static_cast<const void*>(&b.str()) == static_cast<const void*>(&a->str()), "copies share one block");
    BOOST_TEST(b == "door/g2");
    BOOST_TEST(b == std::string("door/g2"));
    BOOST_TEST(!(b == "door/g"));
    BOOST_TEST((SharedName("x") == SharedName("x")), "different blocks compare by content");
    BOOST_TEST(!(SharedName("x") == SharedName("y")));
    BOOST_TEST("group '" + b + "'" == "group 'door/g2'");
    a.reset();  // the last other copy goes: the text stays with b
    BOOST_TEST(b.str() == "door/g2");
    SharedName c;
    c = b;
    b = SharedName();
    BOOST_TEST(b.empty());
    BOOST_TEST(c == "door/g2");
    SharedName d(std::move(c));
    BOOST_TEST(c.empty(), "a moved-from name is empty");
    BOOST_TEST(d == "door/g2");
    std::ostringstream out;
    out << d;
    BOOST_TEST(out.str() == "door/g2");
}
