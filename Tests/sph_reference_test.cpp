// CrowdHealth tests — reproduces van Toll et al. 2021, Table 1, profile SPH (DESIGN §7): the
// doorway with rho0_max = 3, 5 and 7, mean over 3 seeds, against the published density at 15 s
// (within 10 %) and flow 349/(t350 − t1) (within 15 %). Runs the shipped example files.
// Labelled `reference` (about 10 s of simulation on one core).
// Short variant (CROWDHEALTH_SHORT set, as scripts/test.sh --sanitize does, where every run is
// 10-20 times slower): seed 1 only, to t = 18 s; its density at 15 s is checked as above (seed 1
// is within 0.2 % of the 3-seed mean at every rho0_max) and people must be leaving (at least 15
// out; the flow is 2.8-6.3 P/s); the flow is not checked.
#define BOOST_TEST_MODULE sph_reference
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include <cmath>
#include <cstdlib>
#include <string>

using namespace ch;

namespace {

bool shortVariant() { return std::getenv("CROWDHEALTH_SHORT") != nullptr; }

struct Measured {
    double density15 = 0;  ///< mean SPH density over the agents at t = 15 s (1/m²)
    double flow = 0;       ///< 349 / (t350 − t1), P/s
};

Measured runOnce(const std::string& file, std::uint64_t seed) {
    Diagnostics diags;
    LoadOptions options;
    options.seed = seed;
    auto spec = loadScenario(file, diags, options);
    BOOST_TEST_REQUIRE(spec.has_value(), "cannot load " << file);
    Simulation sim(*spec);
    sim.setThreads(1);
    Component* sph = sim.policies().at(0).findComponent("SPH");
    BOOST_TEST_REQUIRE(sph != nullptr);
    Measured m;
    while (!sim.finished() && sim.evacuations().size() < 350) {
        if (shortVariant() && sim.time() >= 18.0 - 1e-9) break;  // just past the density at 15 s
        sim.stepCoarse();
        if (std::abs(sim.time() - 15.0) < 1e-9) {
            const std::vector<double>& d = *sph->field("density");
            double sum = 0;
            for (double v : d) sum += v;
            m.density15 = d.empty() ? 0.0 : sum / static_cast<double>(d.size());
        }
    }
    const auto& ev = sim.evacuations();
    if (shortVariant()) {
        BOOST_TEST(ev.size() >= 15u, file << " seed " << seed << ": only " << ev.size() << " out by 18 s");
        return m;
    }
    BOOST_TEST_REQUIRE(ev.size() >= 350u, file << " seed " << seed << ": only " << ev.size() << " evacuated");
    m.flow = 349.0 / (ev[349].time - ev[0].time);
    return m;
}

void check(int rho0max, double paperDensity, double paperFlow) {
    const std::string file =
        std::string(CH_SOURCE_DIR) + "/Examples/doorway/vantoll/sph-rho" + std::to_string(rho0max) + ".xml";
    Measured mean;
    const int seeds = shortVariant() ? 1 : 3;
    for (int s = 1; s <= seeds; ++s) {
        const Measured m = runOnce(file, static_cast<std::uint64_t>(s));
        BOOST_TEST_MESSAGE("rho0_max " << rho0max << " seed " << s << ": density@15s " << m.density15 << ", flow " << m.flow);
        mean.density15 += m.density15 / seeds;
        mean.flow += m.flow / seeds;
    }
    BOOST_TEST_MESSAGE("rho0_max " << rho0max << " mean: density@15s " << mean.density15 << " (paper " << paperDensity
                                   << "), flow " << mean.flow << " (paper " << paperFlow << ")");
    BOOST_TEST(std::abs(mean.density15 - paperDensity) <= 0.10 * paperDensity);
    if (!shortVariant()) BOOST_TEST(std::abs(mean.flow - paperFlow) <= 0.15 * paperFlow);
}

}  // namespace

BOOST_AUTO_TEST_CASE(vantoll_sph_rho0max_3) { check(3, 3.27, 3.08); }
BOOST_AUTO_TEST_CASE(vantoll_sph_rho0max_5) { check(5, 5.09, 4.89); }
// The row where UMANS' implicit post-step contact on top of ContactForces cost 17 % of the flow
// and 10 % of the density: the shipped file does not write ContactForceScale (issue 12).
BOOST_AUTO_TEST_CASE(vantoll_sph_rho0max_7) { check(7, 6.61, 6.45); }
