// The output writers of crowdhealth/io/output.h on their own: atomic files, number formatting,
// crowd pressure, flow.
#define BOOST_TEST_MODULE cli_writers
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/json.h>
#include <crowdhealth/io/output.h>

#include <clocale>
#include <cmath>

using namespace clitest;

BOOST_AUTO_TEST_CASE(atomic_file_appears_only_on_commit_and_leaves_no_tmp) {
    const fs::path dir = freshDir(caseName());
    const fs::path target = dir / "a.csv";
    {
        ch::AtomicFile f(target);
        f.write("x,y\n1,2\n");
        BOOST_TEST(!fs::exists(target));         // nothing under the final name while writing
        BOOST_TEST(fs::exists(f.temporary()));
        f.commit();
    }
    BOOST_TEST(readFile(target) == "x,y\n1,2\n");
    BOOST_TEST(tmpFiles(dir).empty());
}

BOOST_AUTO_TEST_CASE(abandoned_atomic_file_keeps_the_old_content_and_removes_its_tmp) {
    const fs::path dir = freshDir(caseName());
    const fs::path target = dir / "a.csv";
    ch::writeFileAtomic(target, "old\n");
    {
        ch::AtomicFile f(target);
        f.write("half a fi");
        // destroyed without commit(), as when an exception unwinds mid-write
    }
    BOOST_TEST(readFile(target) == "old\n");
    BOOST_TEST(tmpFiles(dir).empty());
}

BOOST_AUTO_TEST_CASE(atomic_file_in_a_missing_folder_throws_output_error) {
    const fs::path dir = freshDir(caseName());
    BOOST_CHECK_THROW(ch::writeFileAtomic(dir / "no" / "such" / "a.csv", "x"), ch::OutputError);
}

BOOST_AUTO_TEST_CASE(numbers_are_written_the_same_under_any_locale) {
    // Under a locale with a decimal comma, printf would write "0,5"; to_chars must not.
    const char* old = std::setlocale(LC_NUMERIC, nullptr);
    const std::string saved = old ? old : "C";
    const bool switched = std::setlocale(LC_NUMERIC, "de_DE.UTF-8") != nullptr ||
                          std::setlocale(LC_NUMERIC, "fr_FR.UTF-8") != nullptr;
    BOOST_TEST(ch::formatNumber(0.5) == "0.5");
    BOOST_TEST(ch::formatNumber(1234567.0) == "1.23457e+06");
    BOOST_TEST(ch::formatNumber(3 * 0.1) == "0.3");  // 0.30000000000000004 at 6 digits
    BOOST_TEST(ch::formatNumber(-0.0) == "0");
    BOOST_TEST(ch::formatNumber(std::nan("")) == "nan");
    BOOST_TEST(ch::jsonNumber(std::nan("")).is_null());
    BOOST_TEST(ch::jsonNumber(92 * 0.1).dump() == "9.2");
    std::setlocale(LC_NUMERIC, saved.c_str());
    BOOST_TEST_MESSAGE("decimal-comma locale " << (switched ? "used" : "not installed; checked under C only"));
}

BOOST_AUTO_TEST_CASE(json_numbers_are_readable_and_never_invalid) {
    // NaN and infinities have no JSON form: null (the library would also write null, but the
    // value must not depend on that).
    BOOST_TEST(ch::jsonNumber(std::numeric_limits<double>::infinity()).is_null());
    BOOST_TEST(ch::jsonNumber(-std::numeric_limits<double>::infinity()).is_null());
    // Whole numbers stay integers ("300", not "300.0"); -0 is 0.
    BOOST_TEST(ch::jsonNumber(300.0).dump() == "300");
    BOOST_TEST(ch::jsonNumber(-0.0).dump() == "0");
    BOOST_TEST(ch::jsonNumber(1e300).dump() == "1e+300");
    // Ten significant digits by default, fewer on request.
    BOOST_TEST(ch::jsonNumber(1.0 / 3).dump() == "0.3333333333");
    BOOST_TEST(ch::jsonNumber(18.09172345, 6).dump() == "18.0917");
    BOOST_TEST(ch::jsonNumber(2.5e-7).get<double>() == 2.5e-7);
}

BOOST_AUTO_TEST_CASE(json_text_is_valid_whatever_the_strings_hold) {
    // Quotes, backslashes, control characters and bytes that are not UTF-8 (a path on a Latin-1
    // file system): the library escapes or replaces them, the text parses back.
    ch::Json j;
    j["scenario"] = std::string("a\"b\\c\nd\x01\xe9.xml");
    j["x"] = ch::jsonNumber(std::nan(""));
    const std::string text = ch::jsonText(j);
    BOOST_TEST(text.back() == '\n');
    const ch::Json back = ch::Json::parse(text);
    BOOST_TEST(back["scenario"].get<std::string>().substr(0, 8) == std::string("a\"b\\c\nd\x01"));
    BOOST_TEST(back["x"].is_null());
}

BOOST_AUTO_TEST_CASE(broken_json_files_are_reported_with_path_and_position) {
    const fs::path dir = fs::temp_directory_path() / "crowdhealth-json-read-test";
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "bad.json") << "{\n  \"seed\": 1,\n  \"scenario\": \n";
    try {
        ch::readJsonFile(dir / "bad.json");
        BOOST_FAIL("no error for a broken file");
    } catch (const ch::JsonError& e) {
        const std::string what = e.what();
        BOOST_TEST(what.find((dir / "bad.json").string() + ": not valid JSON") == 0u, what);
        BOOST_TEST(what.find("line 4") != std::string::npos, what);
    }
    BOOST_CHECK_THROW(ch::readJsonFile(dir / "missing.json"), ch::JsonError);
    fs::remove_all(dir);
}

BOOST_AUTO_TEST_CASE(flow_counts_persons_between_the_first_and_last_evacuee) {
    std::vector<ch::Evacuation> e;
    for (int i = 0; i < 5; ++i) e.push_back({i, 10.0 + 0.5 * i});  // one every 0.5 s
    const auto f = ch::evacuationFlow(e, 1, 5);
    BOOST_REQUIRE(f.has_value());
    BOOST_TEST(*f == 2.0);  // 4 persons in 2 s
    BOOST_TEST(!ch::evacuationFlow(e, 1, 6).has_value());  // fewer evacuees than asked
    std::vector<ch::Evacuation> same = {{0, 3.0}, {1, 3.0}};
    BOOST_TEST(!ch::evacuationFlow(same, 1, 2).has_value());  // no time elapsed
}

