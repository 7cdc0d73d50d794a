// The `crowdhealth` program on bad input: scenario errors and bad command lines exit with status
// 2 before anything is simulated or written (not even the output folder); runtime failures exit 1;
// --check, --list-policies and the safety cap.
#define BOOST_TEST_MODULE cli_errors
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/core/registry.h>

using namespace clitest;

BOOST_AUTO_TEST_CASE(check_on_broken_file_reports_every_error_with_its_line_and_writes_nothing) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"--check", "-i", testData("broken.xml"), "-o", "out"});
    BOOST_TEST(r.status == 2);
    // Both mistakes of broken.xml, each as path:line: error: (line 8: misspelled cost function,
    // line 13: negative radius) — all errors at once, not just the first.
    BOOST_TEST(r.err.find("broken.xml:8: error:") != std::string::npos, r.err);
    BOOST_TEST(r.err.find("broken.xml:13: error:") != std::string::npos, r.err);
    BOOST_TEST(r.err.find("SocialForcesAvoidance") != std::string::npos);  // the suggestion
    BOOST_TEST(!fs::exists(dir / "out"));
    BOOST_TEST(r.out.find("OK") == std::string::npos);
}

BOOST_AUTO_TEST_CASE(run_on_broken_file_exits_2_and_does_not_create_the_output_folder) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", testData("broken.xml"), "-o", "out", "--trajectories", "both"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find(": error:") != std::string::npos);
    BOOST_TEST(!fs::exists(dir / "out"));
    BOOST_TEST(r.out.empty());  // no summary of a run that did not happen
}

BOOST_AUTO_TEST_CASE(missing_scenario_file_exits_2_and_writes_nothing) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", "no-such-scenario.xml", "-o", "out"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("no-such-scenario.xml") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"));
}

BOOST_AUTO_TEST_CASE(check_on_good_file_prints_one_ok_line_and_writes_nothing) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"--check", "-i", umansExample("Circle50-SocialForces.xml"), "-o", "out"});
    BOOST_TEST(r.status == 0, r.err);
    const auto out = lines(r.out);
    BOOST_REQUIRE(out.size() == 1u);
    BOOST_TEST(out[0].rfind("OK:", 0) == 0u, out[0]);
    BOOST_TEST(out[0].find("50 agents") != std::string::npos, out[0]);
    BOOST_TEST(out[0].find("1 policy") != std::string::npos, out[0]);
    BOOST_TEST(out[0].find("0 obstacles") != std::string::npos, out[0]);
    BOOST_TEST(out[0].find("end time 100 s") != std::string::npos, out[0]);
    BOOST_TEST(!fs::exists(dir / "out"));
}

BOOST_AUTO_TEST_CASE(bad_command_lines_exit_2_with_a_message_and_write_nothing) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario = umansExample("Circle50-SocialForces.xml");
    const std::vector<std::vector<std::string>> bad = {
        {},                                                        // no scenario
        {"-i", scenario},                                          // no output folder
        {"-i", scenario, "-o", "out", "--threads", "0"},
        {"-i", scenario, "-o", "out", "-t", "two"},
        {"-i", scenario, "-o", "out", "--seed", "-1"},             // would wrap to 2^64-1 unchecked
        {"-i", scenario, "-o", "out", "--end-time", "-5"},
        {"-i", scenario, "-o", "out", "--end-time", "nan"},
        {"-i", scenario, "-o", "out", "--trajectories", "csv"},
        {"-i", scenario, "-o", "out", "--no-such-option"},
        {"-i", scenario, "-o", "out", "stray-word"},
        {"-i", scenario, "-o", "out", "--format", "markdown"},     // --format without --list-policies
        {"--list-policies", "--format", "html"},
    };
    for (const auto& args : bad) {
        std::string shown;
        for (const auto& a : args) shown += a + " ";
        const Result r = run(dir, args);
        BOOST_TEST(r.status == 2, "args: " << shown);
        BOOST_TEST(r.err.find("error") != std::string::npos, "args: " << shown << " stderr: " << r.err);
        BOOST_TEST(!fs::exists(dir / "out"), "args: " << shown);
    }
}

BOOST_AUTO_TEST_CASE(a_scenario_given_without_i_gets_told_how_to_pass_it) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario = umansExample("Circle50-SocialForces.xml");
    const Result r = run(dir, {scenario});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("-i SCENARIO") != std::string::npos, r.err);
    BOOST_TEST(r.err.find("Circle50-SocialForces.xml") != std::string::npos, r.err);
}

BOOST_AUTO_TEST_CASE(output_path_that_is_a_file_is_a_runtime_failure) {
    const fs::path dir = freshDir(caseName());
    { std::ofstream(dir / "out") << "not a folder\n"; }
    const Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "-q"});
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("out") != std::string::npos, r.err);
    BOOST_TEST(readFile(dir / "out") == "not a folder\n");  // untouched
}

BOOST_AUTO_TEST_CASE(list_policies_shows_every_registered_component_with_its_parameters) {
    const fs::path dir = freshDir(caseName());
    const Result text = run(dir, {"--list-policies"});
    BOOST_TEST(text.status == 0);
    const Result md = run(dir, {"--list-policies", "--format", "markdown"});
    BOOST_TEST(md.status == 0);
    // The test links the same components as the program, so the registries agree.
    const auto all = ch::Registry::instance().all();
    BOOST_REQUIRE(!all.empty());
    for (const ch::ComponentInfo* info : all) {
        BOOST_TEST(text.out.find(info->name) != std::string::npos, info->name);
        BOOST_TEST(md.out.find("### " + info->name) != std::string::npos, info->name);
        for (const ch::ParamSpec& p : ch::Registry::fullTable(*info)) {
            BOOST_TEST(text.out.find(p.description) != std::string::npos, info->name << "." << p.name);
            BOOST_TEST(md.out.find("| `" + p.name + "` |") != std::string::npos, info->name << "." << p.name);
        }
    }
    BOOST_TEST(md.out.find("| Parameter | Unit | Default | Range | Description |") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(run_without_end_time_stops_at_the_safety_cap_and_says_so) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", testData("stay.xml"), "-o", "out", "-q", "-t", "1"});
    BOOST_TEST(r.status == 0, r.err);
    BOOST_TEST(r.err.find("safety cap") != std::string::npos, r.err);
    const std::string summary = readFile(dir / "out" / "summary.json");
    BOOST_TEST(summary.find("\"stopped_at_safety_cap\": true") != std::string::npos, summary);
    BOOST_TEST(jsonValue(summary, "simulated_time") == 3600.0);
    BOOST_TEST(r.out.empty());  // --quiet
}

BOOST_AUTO_TEST_CASE(help_and_version_exit_0) {
    const fs::path dir = freshDir(caseName());
    const Result h = run(dir, {"--help"});
    BOOST_TEST(h.status == 0);
    BOOST_TEST(h.out.find("--trajectories") != std::string::npos);
    const Result v = run(dir, {"--version"});
    BOOST_TEST(v.status == 0);
    BOOST_TEST(v.out.rfind("crowdhealth ", 0) == 0u);
}

BOOST_AUTO_TEST_CASE(files_that_are_not_xml_text_exit_2_with_a_plain_message) {
    const fs::path dir = freshDir(caseName());
    const std::pair<std::string, std::string> files[] = {
        {"empty.xml", ""},
        {"utf16.xml", std::string("\xFF\xFE<\0S\0", 6)},
        {"binary.xml", std::string("\x7F" "ELF\x02\x01\x01\0\0\0", 10)},
    };
    const std::string messages[] = {"the file is empty", "UTF-16 is not supported: save it as UTF-8",
                                    "not a text file"};
    for (std::size_t k = 0; k < 3; ++k) {
        BOOST_TEST_CONTEXT(files[k].first) {
            {
                std::ofstream out(dir / files[k].first, std::ios::binary);
                out << files[k].second;
            }
            for (const bool check : {true, false}) {
                std::vector<std::string> args = {"-i", files[k].first, "-o", "out"};
                if (check) args.insert(args.begin(), "--check");
                const Result r = run(dir, args);
                BOOST_TEST(r.status == 2);
                BOOST_TEST(r.err.find(files[k].first + ":1: error: " + messages[k]) != std::string::npos, r.err);
                BOOST_TEST(!fs::exists(dir / "out"));
            }
        }
    }
}
