// ch::LoadOptions::text: a scenario loaded from text in memory under a file's name, as
// `crowdhealth calibrate` loads its filled-in templates (Engine/calibrate.h).
#define BOOST_TEST_MODULE xml_text
#include <boost/test/unit_test.hpp>

#include "crowdhealth/io/xml.h"

#include <sstream>
#include <string>

namespace {

/// The text of Examples/verification/val-kretz-bottleneck.xml, whose policy is a relative file=.
const std::string kPath = std::string(CH_SOURCE_DIR) + "/Examples/verification/val-kretz-bottleneck.xml";

}  // namespace

BOOST_AUTO_TEST_CASE(text_replaces_the_file_and_relative_paths_resolve_from_its_name) {
    // A file that does not exist, but sits in the folder of ../policies/social-forces.xml.
    const std::string name = std::string(CH_SOURCE_DIR) + "/Examples/verification/not-on-disk.xml";
    const std::string text =
        "<Simulation delta_time=\"0.1\" end_time=\"7\" seed=\"4\">\n"
        "  <World type=\"Infinite\"/>\n"
        "  <Policies file=\"../policies/social-forces.xml\"/>\n"
        "  <Agents><Agent rad=\"0.2\"><pos x=\"0\" y=\"0\"/><goal x=\"3\" y=\"0\"/><Policy id=\"0\"/></Agent></Agents>\n"
        "</Simulation>\n";
    ch::Diagnostics d;
    ch::LoadOptions o;
    o.text = text;
    const auto spec = ch::loadScenario(name, d, o);
    std::ostringstream msg;
    d.print(msg);
    BOOST_REQUIRE_MESSAGE(spec.has_value(), msg.str());
    BOOST_TEST(spec->endTime == 7.0);
    BOOST_TEST(spec->seed == 4u);
    BOOST_TEST(spec->agents.size() == 1u);
    BOOST_TEST(spec->sourceFile == name);
}

BOOST_AUTO_TEST_CASE(text_wins_over_the_file_on_disk) {
    ch::Diagnostics d;
    ch::LoadOptions o;
    const auto fromFile = ch::loadScenario(kPath, d, o);
    BOOST_REQUIRE(fromFile.has_value());
    BOOST_TEST(fromFile->agents.size() == 40u);
    o.text = "<Simulation delta_time=\"0.1\" end_time=\"5\"><World type=\"Infinite\"/><Policies file=\"../policies/social-forces.xml\"/>"
             "<Agents><Agent rad=\"0.2\"><pos x=\"0\" y=\"0\"/><goal x=\"3\" y=\"0\"/><Policy id=\"0\"/></Agent>"
             "</Agents></Simulation>";
    ch::Diagnostics d2;
    const auto fromText = ch::loadScenario(kPath, d2, o);
    std::ostringstream msg;
    d2.print(msg);
    BOOST_REQUIRE_MESSAGE(fromText.has_value(), msg.str());
    BOOST_TEST(fromText->agents.size() == 1u);
}

BOOST_AUTO_TEST_CASE(syntax_errors_name_the_file_and_line) {
    ch::Diagnostics d;
    ch::LoadOptions o;
    o.text = "<Simulation>\n  <World type=\"Infinite\"/>\n  <Policies>\n</Simulation>\n";
    BOOST_TEST(!ch::loadScenario("template.xml", d, o).has_value());
    std::ostringstream msg;
    d.print(msg);
    BOOST_TEST(msg.str().find("template.xml:") != std::string::npos, msg.str());
    BOOST_TEST(msg.str().find("XML syntax error") != std::string::npos, msg.str());
    ch::Diagnostics empty;
    o.text = "  \n";
    BOOST_TEST(!ch::loadScenario("template.xml", empty, o).has_value());
    std::ostringstream m2;
    empty.print(m2);
    BOOST_TEST(m2.str().find("template.xml:1: error: the file holds no XML element") != std::string::npos, m2.str());
}
