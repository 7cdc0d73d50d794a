// docs/xml-reference.md carries a section generated from the registry (every cost function and
// force with its parameter table). This test fails when that section differs from what the
// program prints now, i.e. when a component was added or its table changed without running
// scripts/gen-xml-reference.sh. It also checks the hand-written <CrowdHealth>, <Safety> and <Simulation> tables
// against the program's parameter tables. (Named cli_* so that CMake builds the program before it.)
#define BOOST_TEST_MODULE docs_reference
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/health/health.h>
#include <crowdhealth/core/registry.h>
#include <crowdhealth/health/safety.h>
#include <crowdhealth/io/xml.h>

#include <string>
#include <vector>

using namespace clitest;

namespace {

const std::string kBegin = "<!-- BEGIN GENERATED: components -->";
const std::string kEnd = "<!-- END GENERATED: components -->";
const char* kHowToFix =
    "run scripts/gen-xml-reference.sh (it rebuilds nothing: build first, or pass the program's path, "
    "e.g. scripts/gen-xml-reference.sh build/bin/crowdhealth) and commit docs/xml-reference.md";

fs::path docPath() { return fs::path(CH_SOURCE_DIR) / "docs" / "xml-reference.md"; }

/// Indices of the lines equal to `marker`.
std::vector<std::size_t> linesEqualTo(const std::vector<std::string>& lines, const std::string& marker) {
    std::vector<std::size_t> at;
    for (std::size_t i = 0; i < lines.size(); ++i)
        if (lines[i] == marker) at.push_back(i);
    return at;
}

/// The text between the marker lines (exclusive), each line followed by '\n' as the program
/// prints it.
std::string generatedSection(const std::vector<std::string>& lines, std::size_t begin, std::size_t end) {
    std::string s;
    for (std::size_t i = begin + 1; i < end; ++i) s += lines[i] + "\n";
    return s;
}

}  // namespace

BOOST_AUTO_TEST_CASE(generated_components_section_matches_the_program) {
    const fs::path doc = docPath();
    BOOST_REQUIRE_MESSAGE(fs::exists(doc), doc.string() << " is missing");
    const std::vector<std::string> docLines = lines(readFile(doc));

    const auto begins = linesEqualTo(docLines, kBegin);
    const auto ends = linesEqualTo(docLines, kEnd);
    BOOST_REQUIRE_MESSAGE(begins.size() == 1 && ends.size() == 1 && begins[0] < ends[0],
                          doc.string() << " must hold each marker once, on a line of its own, BEGIN first: '"
                                       << kBegin << "' (found " << begins.size() << "), '" << kEnd << "' (found "
                                       << ends.size() << ")");
    const std::string inDoc = generatedSection(docLines, begins[0], ends[0]);

    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"--list-policies", "--format", "markdown"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, "crowdhealth --list-policies --format markdown exited with status "
                                             << r.status << ": " << r.err);
    BOOST_REQUIRE(!r.out.empty());

    if (inDoc == r.out) return;
    // Point at the first line that differs, so the failure says what changed.
    const std::vector<std::string> want = lines(r.out), have = lines(inDoc);
    std::size_t k = 0;
    while (k < want.size() && k < have.size() && want[k] == have[k]) ++k;
    auto shown = [](const std::vector<std::string>& v, std::size_t i) -> std::string {
        if (i >= v.size()) return "(end of section)";
        return v[i].empty() ? "(empty line)" : v[i];
    };
    const std::string nowLine = shown(want, k);
    const std::string docLine = shown(have, k);
    BOOST_ERROR("docs/xml-reference.md: the generated section 'components' (line "
                << begins[0] + 2 + k << ") differs from `crowdhealth --list-policies --format markdown`:\n"
                << "  in the document: " << docLine << "\n"
                << "  the program now: " << nowLine << "\n"
                << "To fix it, " << kHowToFix << ".");
}

BOOST_AUTO_TEST_CASE(every_registered_component_has_a_heading_in_the_document) {
    // Independent of the program's printing: the registry linked into this test (the same
    // Policies/ objects) names every component, and a reader searching the reference for a name
    // must find its heading. Redundant while the section is current; a clearer message otherwise.
    const std::string text = readFile(docPath());
    const std::vector<std::string> names = ch::Registry::instance().names();
    BOOST_REQUIRE(!names.empty());
    for (const std::string& name : names)
        BOOST_TEST(text.find("\n### " + name + "\n") != std::string::npos,
                   "docs/xml-reference.md has no heading '### " << name << "'; " << kHowToFix);
}

namespace {
/// Each row of a hand-written parameter table must still carry the program's unit, default and
/// range, as `| `name` | unit | default | range |`.
void checkHandWrittenTable(const ch::ParamTable& table, const std::string& section) {
    const std::vector<std::string> docLines = lines(readFile(docPath()));
    for (const ch::ParamSpec& p : table) {
        const std::string unit = p.unit.empty() ? "-" : p.unit;
        const std::string expected =
            "| `" + p.name + "` | " + unit + " | " + p.defaultText() + " | " + p.rangeText() + " |";
        bool found = false, present = false;
        for (const std::string& l : docLines) {
            if (l.rfind("| `" + p.name + "` |", 0) != 0) continue;
            present = true;
            found = found || l.rfind(expected, 0) == 0;
        }
        BOOST_TEST(found, "docs/xml-reference.md, section " << section << ": "
                              << (present ? "the row of" : "no row for") << " '" << p.name
                              << "' should start with: " << expected);
    }
}
}  // namespace

BOOST_AUTO_TEST_CASE(crowd_health_table_matches_the_layer) {
    // The <CrowdHealth> table is written by hand (the program does not print it).
    checkHandWrittenTable(ch::crowdHealthTable(), "<CrowdHealth>");
}

BOOST_AUTO_TEST_CASE(safety_table_matches_the_program) {
    checkHandWrittenTable(ch::safetyTable(), "<Safety>");
}

BOOST_AUTO_TEST_CASE(simulation_table_rows_carry_the_loaders_unit_default_and_range) {
    // The <Simulation> table has a type column and hand-written defaults for the attributes whose
    // default is another attribute or "required"; the CrowdHealth attributes with a plain default
    // (symmetry_breaking) must match the loader's table.
    const std::vector<std::string> docLines = lines(readFile(docPath()));
    for (const ch::ParamSpec& p : ch::simulationTable()) {
        if (p.name != "symmetry_breaking") continue;
        const std::string expected = "| `" + p.name + "` **[CH]** | real | " + p.unit + " | " + p.defaultText() +
                                     " | " + p.rangeText() + " |";
        bool found = false;
        for (const std::string& l : docLines) found = found || l.rfind(expected, 0) == 0;
        BOOST_TEST(found, "docs/xml-reference.md, section <Simulation>: the row of '" << p.name
                              << "' should start with: " << expected);
    }
}
