// Helpers for the tests of the `crowdhealth` program (Tests/cli_*_test.cpp): run it in a fresh
// folder under the build tree, read what it wrote. Include after <boost/test/unit_test.hpp>.
#pragma once

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace clitest {

namespace fs = std::filesystem;

struct Result {
    int status = -1;  ///< exit status, or -1 if the program did not exit normally
    std::string out, err;
};

inline std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// A new, empty folder for one test case: <cwd>/cli-test-tmp/<name> (the cwd of a ctest test is
/// its build folder, so nothing is written into the sources).
inline fs::path freshDir(const std::string& name) {
    const fs::path d = fs::current_path() / "cli-test-tmp" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

/// The current Boost.Test case's name, to name its folder.
inline std::string caseName() {
    return boost::unit_test::framework::current_test_case().p_name;
}

inline std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (const char c : s) {
        if (c == '\'') q += "'\\''";
        else q += c;
    }
    return q + "'";
}

/// Runs `prefix program args…` in a shell with `dir` as working folder (`prefix`: shell words put
/// before the program, already quoted, e.g. an `env …` or `xvfb-run …`; may be empty). stdout and
/// stderr are captured in files inside `dir` (named so that they never collide with a program's
/// outputs); stdin is /dev/null.
inline Result runIn(const fs::path& dir, const std::string& prefix, const std::string& program,
                    const std::vector<std::string>& args) {
    // Built with += only: GCC 12 raises a false -Wrestrict on `"literal" + std::string` at -O2.
    std::string cmd = "cd ";
    cmd += shellQuote(dir.string());
    cmd += " && ";
    cmd += prefix;
    if (!prefix.empty()) cmd += ' ';
    cmd += shellQuote(program);
    for (const std::string& a : args) {
        cmd += ' ';
        cmd += shellQuote(a);
    }
    const fs::path out = dir / "_stdout.txt", err = dir / "_stderr.txt";
    cmd += " >";
    cmd += shellQuote(out.string());
    cmd += " 2>";
    cmd += shellQuote(err.string());
    cmd += " </dev/null";
    const int raw = std::system(cmd.c_str());
    Result r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = readFile(out);
    r.err = readFile(err);
    return r;
}

/// Runs `crowdhealth args…` with `dir` as working folder (see runIn).
inline Result run(const fs::path& dir, const std::vector<std::string>& args) { return runIn(dir, "", CH_BINARY, args); }

inline std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> v;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
}

inline std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> v;
    std::string cur;
    for (const char c : s) {
        if (c == sep) { v.push_back(cur); cur.clear(); }
        else cur += c;
    }
    v.push_back(cur);
    return v;
}

/// A UMANS example shipped in ../shared (the test fails clearly if it is missing).
inline std::string umansExample(const std::string& name) {
    const fs::path p = fs::path(CH_SHARED_DIR) / "umans-examples" / name;
    BOOST_REQUIRE_MESSAGE(fs::exists(p), "missing UMANS example " << p << " (is ../shared beside the repository?)");
    return p.string();
}

/// A scenario of Tests/data/cli.
inline std::string testData(const std::string& name) {
    return (fs::path(CH_SOURCE_DIR) / "Tests" / "data" / "cli" / name).string();
}

/// Every file under dir whose name ends in ".tmp".
inline std::vector<fs::path> tmpFiles(const fs::path& dir) {
    std::vector<fs::path> v;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.path().extension() == ".tmp") v.push_back(e.path());
    return v;
}

/// The number after "key": in a JSON text (NaN if absent or null).
inline double jsonValue(const std::string& json, const std::string& key) {
    std::smatch m;
    const std::regex re("\"" + key + "\": (-?[0-9.eE+-]+)");
    if (!std::regex_search(json, m, re)) return std::nan("");
    return std::stod(m[1].str());
}

}  // namespace clitest
