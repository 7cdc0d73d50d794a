#define BOOST_TEST_MODULE sampling_preferred
#include <boost/test/unit_test.hpp>

#include "test_support.h"

#include "crowdhealth/io/xml.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

// IncludePreferredAsSample (SamplingSpec::includePreferredAsSample): the sampler also scores the
// agent's preferred velocity. Off (UMANS), a lone Karamouzas walker with UMANS' grid (15 speeds up
// to max_speed = 2 m/s, every 0.143 m/s) and a preferred speed of 1.5 m/s, between two rings, walks
// at a neighbouring ring (1.429 m/s); on, at 1.5 m/s exactly (docs/verification/models.md, RiMEA 7).

using namespace ch;
using namespace ch::test;

namespace {

/// The lone walker's speed after 3 s (it walks 10 m east, nobody else about).
double freeSpeed(bool includePreferred) {
    SamplingSpec s;
    s.type = SamplingSpec::Type::Regular;
    s.base = SamplingSpec::Base::Zero;
    s.baseDirection = SamplingSpec::BaseDirection::PreferredVelocity;
    s.angle = 180;
    s.speedSamples = 15;
    s.angleSamples = 19;
    s.radius = SamplingSpec::Radius::MaximumSpeed;
    s.includeBaseAsSample = true;
    s.includePreferredAsSample = includePreferred;
    const PolicySpec p = policy(0, OptimisationMethod::Sampling, {component("Karamouzas", {{"range", 5}})}, 0.0, s);
    Simulation sim(scenario({agent(0, Vec2(0, 0), Vec2(20, 0), 0.2, 1.5, 2.0)}, {p}, 0.1, 3.0));
    sim.setThreads(1);
    while (!sim.finished()) sim.stepCoarse();
    return sim.agents().vel[0].norm();
}

}  // namespace

BOOST_AUTO_TEST_CASE(off_keeps_umans_grid) {
    // One of the two rings round 1.5 m/s (1.429 or 1.571; both 0.071 m/s off, the cost's speed-change
    // term picks the slower): a multiple of 2/14 m/s, outside the model's 0.05 m/s band.
    const double v = freeSpeed(false);
    BOOST_TEST(std::abs(v * 14 / 2.0 - std::round(v * 14 / 2.0)) < 1e-9);
    BOOST_TEST(std::abs(v - 1.5) > 0.05);
}

BOOST_AUTO_TEST_CASE(on_walks_at_the_preferred_speed) {
    BOOST_TEST(std::abs(freeSpeed(true) - 1.5) < 1e-9);
}

BOOST_AUTO_TEST_CASE(read_from_xml_default_off) {
    const std::string xml = R"(<Simulation delta_time="0.1" end_time="1"><World type="Infinite"/><Policies>
        <Policy id="0" OptimizationMethod="sampling" IncludePreferredAsSample="true"><costfunction name="Karamouzas"/></Policy>
        <Policy id="1" OptimizationMethod="sampling"><costfunction name="Karamouzas"/></Policy></Policies>
        <Agents><Agent><pos x="0" y="0"/><goal x="1" y="0"/><Policy id="0"/></Agent></Agents></Simulation>)";
    const std::filesystem::path file = std::filesystem::temp_directory_path() / "sampling_preferred_test.xml";
    { std::ofstream(file) << xml; }
    Diagnostics diags;
    const auto spec = loadScenario(file.string(), diags);
    std::filesystem::remove(file);
    BOOST_TEST_REQUIRE(static_cast<bool>(spec));
    BOOST_TEST(!diags.hasErrors());
    BOOST_TEST(spec->policies.at(0).steps.at(0).sampling.includePreferredAsSample);
    BOOST_TEST(!spec->policies.at(1).steps.at(0).sampling.includePreferredAsSample);
}
