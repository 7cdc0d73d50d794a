// `<Draw distribution="lognormal" mu sigma [min] [max]/>` of a <Source> (docs/navigation.md,
// docs/xml-reference.md): the draws have the log-mean and log-sd asked for, stay inside the
// truncation bounds, depend only on the seed; bad parameters are errors at their line.
#define BOOST_TEST_MODULE source_lognormal
#include <boost/test/unit_test.hpp>

#include "scenario_files.h"

#include <algorithm>
#include <cmath>

using namespace ch;
using test::Loaded;
using test::load;

namespace {

/// A world with one exit and a <Source> of `count` persons whose premovement is drawn by `draw`.
std::string scenario(const std::string& draw, int count = 400, std::uint64_t seed = 1) {
    return "<Simulation delta_time=\"0.1\" end_time=\"10\" seed=\"" + std::to_string(seed) +
           "\">\n"
           "<World type=\"Planar\" xmin=\"0\" xmax=\"50\" ymin=\"0\" ymax=\"50\">\n"
           "<Exit id=\"e\" xmin=\"48\" xmax=\"49\" ymin=\"0\" ymax=\"50\"/>\n<Journey id=\"j\" leave_by=\"e\"/>\n</World>\n"
           "<Policies><Policy id=\"0\" OptimizationMethod=\"gradient\"><costfunction name=\"GoalReachingForce\"/></Policy></Policies>\n"
           "<Agents>\n<Source xmin=\"1\" xmax=\"40\" ymin=\"1\" ymax=\"40\" rate=\"100\" count=\"" +
           std::to_string(count) + "\" journey=\"j\">\n<Policy id=\"0\"/>\n" + draw +
           "\n</Source>\n</Agents>\n</Simulation>\n";
}

std::vector<double> premovements(const Loaded& l) {
    std::vector<double> v;
    for (const AgentSpec& a : l.spec->agents) v.push_back(a.premovement);
    return v;
}

/// `words` at line `line` of the file, as an error.
void expectError(const std::string& name, const std::string& draw, const std::string& words) {
    const std::string xml = scenario(draw);
    const Loaded l = load(name, xml);
    BOOST_TEST(!l.spec);
    const auto before = xml.begin() + static_cast<std::ptrdiff_t>(xml.find("<Draw"));
    const std::string where = l.path + ":" + std::to_string(1 + std::count(xml.begin(), before, '\n')) + ": error: ";
    BOOST_TEST(l.messages.find(where) != std::string::npos, l.messages << "\nexpected: " << where);
    BOOST_TEST(l.messages.find(words) != std::string::npos, l.messages << "\nexpected: " << words);
}

}  // namespace

BOOST_AUTO_TEST_CASE(lognormal_draws_have_the_log_mean_and_sd_asked_for) {
    const Loaded l = load("logn.xml", scenario(R"(<Draw attribute="premovement" distribution="lognormal" mu="3.689" sigma="0.4"/>)"));
    BOOST_REQUIRE_MESSAGE(l.spec, l.messages);
    const std::vector<double> v = premovements(l);
    BOOST_REQUIRE(v.size() == 400u);
    double m = 0, s2 = 0;
    for (double x : v) {
        BOOST_TEST(x > 0);
        m += std::log(x);
    }
    m /= static_cast<double>(v.size());
    for (double x : v) s2 += (std::log(x) - m) * (std::log(x) - m);
    const double sd = std::sqrt(s2 / static_cast<double>(v.size() - 1));
    // Standard errors for n = 400: 0.4/20 = 0.02 for the mean, about 0.014 for the sd: 4 of each.
    BOOST_TEST(std::abs(m - 3.689) < 0.08, "log-mean " << m);
    BOOST_TEST(std::abs(sd - 0.4) < 0.06, "log-sd " << sd);
    // Not the normal with mean mu (values near 3.7 s): the log is what is normal.
    BOOST_TEST(*std::min_element(v.begin(), v.end()) > 8.0);
}

BOOST_AUTO_TEST_CASE(lognormal_draws_stay_inside_the_truncation_and_follow_the_seed) {
    const std::string draw = R"(<Draw attribute="premovement" distribution="lognormal" mu="3.689" sigma="0.4" min="30" max="50"/>)";
    const Loaded a = load("trunc1.xml", scenario(draw, 200, 1)), b = load("trunc1b.xml", scenario(draw, 200, 1)),
                 c = load("trunc2.xml", scenario(draw, 200, 2));
    BOOST_REQUIRE_MESSAGE(a.spec, a.messages);
    BOOST_REQUIRE(b.spec && c.spec);
    for (double x : premovements(a)) {
        BOOST_TEST(x >= 30.0);
        BOOST_TEST(x <= 50.0);
    }
    BOOST_TEST((premovements(a) == premovements(b)));
    BOOST_TEST((premovements(a) != premovements(c)));
    // A radius drawn lognormal without min is valid (its values are above 0).
    const Loaded r = load("rad.xml", scenario(R"(<Draw attribute="rad" distribution="lognormal" mu="-1.5" sigma="0.1"/>)", 20));
    BOOST_REQUIRE_MESSAGE(r.spec, r.messages);
    for (const AgentSpec& s : r.spec->agents) BOOST_TEST(s.radius > 0.15);
}

BOOST_AUTO_TEST_CASE(bad_lognormal_parameters_are_errors_at_their_line) {
    expectError("nomu.xml", R"(<Draw attribute="premovement" distribution="lognormal" sigma="0.4"/>)", "mu");
    expectError("nosigma.xml", R"(<Draw attribute="premovement" distribution="lognormal" mu="3"/>)", "sigma");
    expectError("negsigma.xml", R"(<Draw attribute="premovement" distribution="lognormal" mu="3" sigma="-0.1"/>)", "sigma");
    expectError("bigmu.xml", R"(<Draw attribute="premovement" distribution="lognormal" mu="25" sigma="0.1"/>)", "mu");
    expectError("order.xml", R"(<Draw attribute="premovement" distribution="lognormal" mu="3" sigma="0.4" min="50" max="30"/>)",
                "min must not exceed max");
    expectError("nonpos.xml", R"(<Draw attribute="premovement" distribution="lognormal" mu="3" sigma="0.4" max="0"/>)",
                "max must be too");
    expectError("unknown.xml", R"(<Draw attribute="premovement" distribution="lognormale" mu="3" sigma="0.4"/>)",
                "lognormal");
}
