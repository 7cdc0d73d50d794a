// Diagnostics (message format, suggestions) and parameter tables (ranges, strict parsing).
#define BOOST_TEST_MODULE xml_diagnostics
#include <boost/test/unit_test.hpp>

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/core/params.h"

#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace ch;

BOOST_AUTO_TEST_SUITE(diagnostics)

Diagnostic make(Severity severity, const std::string& file, int line, const std::string& message) {
    Diagnostic d;
    d.severity = severity;
    d.where.file = file;
    d.where.line = line;
    d.message = message;
    return d;
}

BOOST_AUTO_TEST_CASE(format_is_compiler_style) {
    BOOST_TEST(make(Severity::Error, "dir/a.xml", 12, "Agent@rad: 0 is not in (0, 10] m").format() ==
               "dir/a.xml:12: error: Agent@rad: 0 is not in (0, 10] m");
    BOOST_TEST(make(Severity::Warning, "a.xml", 3, "Agent has no <goal>").format() ==
               "a.xml:3: warning: Agent has no <goal>");
    BOOST_TEST(make(Severity::Error, "a.xml", 0, "cannot find file 'a.xml'").format() ==
               "a.xml: error: cannot find file 'a.xml'");
}

// A location's file name is held once for all its copies (a million agents' specs carry one):
// equal names share one string, whichever thread made them, and it reads as the name itself.
BOOST_AUTO_TEST_CASE(file_names_are_shared_and_read_as_the_name) {
    const std::string path = "a/directory/name/longer/than/the/inline/buffer/scene.xml";
    const FileName a(path), b(std::string(path.c_str())), c("other.xml");
    // The same string, not two equal ones (addresses: BOOST_TEST compares C strings by content).
    auto at = [](const FileName& f) { return static_cast<const void*>(f.c_str()); };
    BOOST_TEST(at(a) == at(b));
    BOOST_TEST(at(a) != at(c));
    BOOST_TEST(a.str() == path);
    BOOST_TEST((a == b));
    BOOST_TEST(!(a == c));
    BOOST_TEST((a == path));
    const SourceLoc loc{a, 7}, copy = loc;
    BOOST_TEST(at(copy.file) == at(a));
    BOOST_TEST(FileName().empty());
    BOOST_TEST(FileName("").empty());
    BOOST_TEST(FileName().str() == "");
    BOOST_TEST(c + ":" + std::to_string(3) == "other.xml:3");
    BOOST_TEST("in " + c == "in other.xml");
    std::ostringstream out;
    out << c << ':' << 4;
    BOOST_TEST(out.str() == "other.xml:4");
    // Made from many threads at once: still one string per name.
    std::vector<const void*> seen(64, nullptr);
#pragma omp parallel for
    for (int k = 0; k < 64; ++k) seen[static_cast<std::size_t>(k)] = at(FileName("threads/" + std::to_string(k % 4) + ".xml"));
    for (int k = 0; k < 64; ++k) BOOST_TEST(seen[static_cast<std::size_t>(k)] == seen[static_cast<std::size_t>(k % 4)]);
}

BOOST_AUTO_TEST_CASE(collects_everything_in_order) {
    Diagnostics d;
    BOOST_TEST(!d.hasErrors());
    d.warning({"f.xml", 1}, "first");
    BOOST_TEST(!d.hasErrors());
    d.error({"f.xml", 2}, "second");
    d.error({"g.xml", 5}, "third");
    BOOST_TEST(d.hasErrors());
    BOOST_TEST(d.errorCount() == 2);
    BOOST_REQUIRE(d.all().size() == 3u);
    BOOST_TEST((d.all()[0].severity == Severity::Warning));
    std::ostringstream out;
    d.print(out);
    BOOST_TEST(out.str() == "f.xml:1: warning: first\nf.xml:2: error: second\ng.xml:5: error: third\n");
}

/// Checks closestMatch(word, candidates) for each {word, suggestion} ("" when nothing is close enough).
void checkSuggestions(const std::vector<std::string>& candidates,
                      const std::vector<std::pair<std::string, std::string>>& wordAndSuggestion) {
    for (const auto& [word, suggestion] : wordAndSuggestion)
        BOOST_TEST_CONTEXT("word '" << word << "'") { BOOST_TEST(closestMatch(word, candidates) == suggestion); }
}

BOOST_AUTO_TEST_CASE(closest_match_suggests_near_names_only) {
    const std::vector<std::string> attrs = {"rad", "pref_speed", "max_speed", "max_acceleration", "goal_radius"};
    checkSuggestions(attrs, {
        {"pref_sped", "pref_speed"},
        {"max_acceleraton", "max_acceleration"},
        {"RAD", "rad"},  // case-insensitive: distance 0
        {"ra", "rad"},
        {"colour", ""},  // nothing close
        {"", ""},
    });
    BOOST_TEST(closestMatch("rad", {}) == "");
    // Threshold max(2, len/3): a 12-letter word may be 4 edits away, a 3-letter one only 2.
    BOOST_TEST(closestMatch("GoalReachingFrc", {"GoalReachingForce", "SocialForcesAvoidance"}) == "GoalReachingForce");
    BOOST_TEST(closestMatch("abc", {"xyz"}) == "");
    BOOST_TEST(closestMatch("abcdefghijkl", {"abcdefghWXYZ"}) == "abcdefghWXYZ");
    BOOST_TEST(closestMatch("abcdefghijkl", {"abcdefgVWXYZ"}) == "");
    // The closest wins, not the first within the threshold.
    BOOST_TEST(closestMatch("World", {"Word", "World"}) == "World");
}

BOOST_AUTO_TEST_CASE(equals_ignore_case) {
    BOOST_TEST(equalsIgnoreCase("CostFunction", "costfunction"));
    BOOST_TEST(equalsIgnoreCase("", ""));
    BOOST_TEST(!equalsIgnoreCase("Policy", "Policies"));
    BOOST_TEST(!equalsIgnoreCase("pos", "po"));
}

BOOST_AUTO_TEST_SUITE_END()

BOOST_AUTO_TEST_SUITE(params)

ParamSpec radius() {
    ParamSpec p = ParamSpec::real("rad", "m", 0.24, 0, 10, "body radius");
    p.minExclusive = true;
    return p;
}

BOOST_AUTO_TEST_CASE(range_texts) {
    BOOST_TEST(radius().rangeText() == "(0, 10] m");
    BOOST_TEST(ParamSpec::real("k", "-", 1, 0, 10, "").rangeText() == "[0, 10]");
    ParamSpec dt = ParamSpec::real("dt", "s", 0.1, 0, 1e300, "");
    BOOST_TEST(dt.rangeText() == "[0, inf) s");
    dt.minExclusive = true;
    BOOST_TEST(dt.rangeText() == "(0, inf) s");
    BOOST_TEST(ParamSpec::real("x", "m", 0, -1e300, 1e300, "").rangeText() == "(-inf, inf) m");
    BOOST_TEST(ParamSpec::real("a", "deg", 1, 0.5, 1e6, "").rangeText() == "[0.5, 1000000] deg");
    BOOST_TEST(ParamSpec::integer("n", 3, 1, 1e300, "").rangeText() == "[1, inf)");
    BOOST_TEST(ParamSpec::boolean("b", true, "").rangeText() == "true or false");
    BOOST_TEST(ParamSpec::choice("wall", {"particles", "analytic"}, 1, "").rangeText() == "one of: particles, analytic");
}

BOOST_AUTO_TEST_CASE(default_texts) {
    BOOST_TEST(radius().defaultText() == "0.24");
    BOOST_TEST(ParamSpec::real("k", "-", 200, 0, 1e300, "").defaultText() == "200");
    BOOST_TEST(ParamSpec::real("k", "-", 1e-7, 0, 1e300, "").defaultText() == "1e-07");
    BOOST_TEST(ParamSpec::integer("n", 3, 1, 10, "").defaultText() == "3");
    BOOST_TEST(ParamSpec::boolean("b", true, "").defaultText() == "true");
    BOOST_TEST(ParamSpec::boolean("b", false, "").defaultText() == "false");
    BOOST_TEST(ParamSpec::choice("wall", {"particles", "analytic"}, 1, "").defaultText() == "analytic");
}

struct Parsed {
    bool ok;
    double value;
    std::string why;
};
Parsed parse(const ParamSpec& p, const std::string& text) {
    Parsed r{false, -12345, ""};
    r.ok = p.parse(text, r.value, r.why);
    return r;
}

/// Checks that `p` reads each text as the value next to it.
void checkValues(const ParamSpec& p, const std::vector<std::pair<std::string, double>>& textAndValue) {
    for (const auto& [text, value] : textAndValue)
        BOOST_TEST_CONTEXT(p.name << " = '" << text << "'") { BOOST_TEST(parse(p, text).value == value); }
}

/// Checks that `p` rejects each text with exactly the reason next to it.
void checkReasons(const ParamSpec& p, const std::vector<std::pair<std::string, std::string>>& textAndWhy) {
    for (const auto& [text, why] : textAndWhy)
        BOOST_TEST_CONTEXT(p.name << " = '" << text << "'") { BOOST_TEST(parse(p, text).why == why); }
}

BOOST_AUTO_TEST_CASE(real_parsing_is_strict) {
    const ParamSpec r = radius();
    BOOST_TEST(parse(r, "0.3").ok);
    checkValues(r, {
        {"0.3", 0.3},
        {" 3e-1 ", 0.3},  // surrounding blanks are not part of the value
        {"+0.3", 0.3},
    });
    BOOST_TEST(parse(r, "10").ok);  // inclusive maximum
    checkReasons(r, {
        {"0", "0 is not in (0, 10] m"},
        {"10.5", "10.5 is not in (0, 10] m"},
        {"-1", "-1 is not in (0, 10] m"},
        {"abc", "'abc' is not a number"},
        {"0.3m", "'0.3m' is not a number"},
        {"1,5", "'1,5' is not a number"},
        {"", "an empty value is not a number"},
        {"0x1", "'0x1' is not a number"},
        {"nan", "'nan' is not a finite number"},
        {"inf", "'inf' is not a finite number"},
        {"-Infinity", "'-Infinity' is not a finite number"},
        {"1e999", "'1e999' is not a finite number"},
    });
    BOOST_TEST(!parse(r, "abc").ok);
    BOOST_TEST(parse(r, "abc").value == -12345);  // untouched on failure
    const ParamSpec huge = ParamSpec::real("a_max", "m/s2", 5, 0, 1e300, "");
    BOOST_TEST(parse(huge, "1e6").value == 1e6);
}

BOOST_AUTO_TEST_CASE(integer_parsing_is_strict) {
    const ParamSpec n = ParamSpec::integer("SpeedSamples", 3, 1, 1e300, "");
    BOOST_TEST(parse(n, "15").value == 15);
    checkReasons(n, {
        {"2.5", "'2.5' is not a whole number"},
        {"3.0", "'3.0' is not a whole number"},
        {"1e3", "'1e3' is not a whole number"},
        {"x", "'x' is not a number"},
        {"0", "0 is not in [1, inf)"},
        {"99999999999999999999999", "'99999999999999999999999' is too large"},
    });
}

BOOST_AUTO_TEST_CASE(bool_and_choice_parsing) {
    const ParamSpec b = ParamSpec::boolean("remove_at_goal", false, "");
    checkValues(b, {{"true", 1.0}, {"TRUE", 1.0}, {"True", 1.0}, {"1", 1.0}});
    checkValues(b, {{"false", 0.0}, {"False", 0.0}, {"0", 0.0}});
    BOOST_TEST(parse(b, "yes").why == "'yes' is not a boolean (true, false, 1 or 0)");
    BOOST_TEST(!parse(b, "2").ok);

    const ParamSpec c = ParamSpec::choice("SamplingRadius", {"preferred speed", "maximum speed"}, 0, "");
    checkValues(c, {{"maximum speed", 1.0}, {"Maximum Speed", 1.0}});
    checkReasons(c, {
        {"maximum sped",
         "'maximum sped' is not one of: preferred speed, maximum speed (did you mean 'maximum speed'?)"},
        {"fast", "'fast' is not one of: preferred speed, maximum speed"},
    });
}

BOOST_AUTO_TEST_CASE(param_set_defaults_and_values) {
    const ParamTable table = {
        ParamSpec::real("h", "m", 1.0, 0, 10, ""),
        ParamSpec::boolean("viscous", true, ""),
        ParamSpec::choice("walls", {"particles", "analytic"}, 1, ""),
    };
    ParamSet s(table);
    BOOST_TEST(s.get("h") == 1.0);
    BOOST_TEST(s.flag("viscous"));
    BOOST_TEST(s.choice("walls") == "analytic");
    BOOST_TEST(s.has("h"));
    BOOST_TEST(!s.has("k"));
    BOOST_CHECK_THROW(s.get("k"), std::out_of_range);
    BOOST_CHECK_THROW(s.choice("h"), std::out_of_range);
    s.set("h", 2.5);
    s.set("walls", 0);
    s.set("viscous", 0);
    BOOST_TEST(s.get("h") == 2.5);
    BOOST_TEST(s.choice("walls") == "particles");
    BOOST_TEST(!s.flag("viscous"));
    BOOST_TEST(s.values().size() == 3u);
    s.set("walls", 7);
    BOOST_CHECK_THROW(s.choice("walls"), std::out_of_range);
}

BOOST_AUTO_TEST_SUITE_END()
