// Helpers for the tests of the `crowdhealth` program (Tests/cli_*_test.cpp): run it in a fresh
// folder under the build tree, read what it wrote. Include after <boost/test/unit_test.hpp>.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <thread>

#include <algorithm>
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
/// Writes `text` to `file`, creating its folder.
inline void writeText(const fs::path& file, const std::string& text) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << text;
}

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

/// `crowdhealth args…` (or `program args…`) started in the background (fork + exec) with `dir` as
/// working folder, stdout and stderr into dir/_stdout.txt and dir/_stderr.txt; for tests that send
/// signals.
class Background {
public:
    Background(const fs::path& dir, const std::vector<std::string>& args) : Background(dir, CH_BINARY, args) {}
    Background(const fs::path& dir, const std::string& program, const std::vector<std::string>& args) : dir_(dir) {
        std::vector<std::string> argv = {program};
        argv.insert(argv.end(), args.begin(), args.end());
        const std::string out = (dir / "_stdout.txt").string(), err = (dir / "_stderr.txt").string();
        pid_ = fork();
        if (pid_ == 0) {  // the child: only async-signal-safe calls until exec
            if (chdir(dir.c_str()) != 0) _exit(127);
            const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
            const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
            const int in = open("/dev/null", O_RDONLY);
            if (o < 0 || e < 0 || in < 0) _exit(127);
            dup2(o, 1); dup2(e, 2); dup2(in, 0);
            std::vector<char*> a;
            for (std::string& s : argv) a.push_back(s.data());
            a.push_back(nullptr);
            execv(a[0], a.data());
            _exit(127);
        }
    }
    ~Background() {
        if (pid_ > 0 && !reaped_) { ::kill(pid_, SIGKILL); waitpid(pid_, nullptr, 0); }
    }
    Background(const Background&) = delete;
    Background& operator=(const Background&) = delete;

    pid_t pid() const { return pid_; }
    void signal(int signo) const { ::kill(pid_, signo); }
    /// Waits for the end: the exit status, or 1000 + the signal that killed it.
    int wait() {
        int raw = 0;
        waitpid(pid_, &raw, 0);
        reaped_ = true;
        if (WIFEXITED(raw)) return WEXITSTATUS(raw);
        if (WIFSIGNALED(raw)) return 1000 + WTERMSIG(raw);
        return -1;
    }
    /// True while the program has not ended (it is not reaped).
    bool running() {
        if (reaped_) return false;
        int raw = 0;
        if (waitpid(pid_, &raw, WNOHANG) == 0) return true;
        reaped_ = true;
        return false;
    }
    std::string err() const { return readFile(dir_ / "_stderr.txt"); }
    std::string out() const { return readFile(dir_ / "_stdout.txt"); }

private:
    fs::path dir_;
    pid_t pid_ = -1;
    bool reaped_ = false;
};

/// Polls `condition` every 20 ms for up to `seconds`; true once it holds.
inline bool waitFor(const std::function<bool()>& condition, double seconds = 120) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < until) {
        if (condition()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return condition();
}

/// Size of a file, 0 if it is not there.
inline std::uintmax_t sizeOf(const fs::path& p) {
    std::error_code ec;
    const auto n = fs::file_size(p, ec);
    return ec ? 0 : n;
}

/// Whether the JSON file parses with an independent parser, python3's json module (strict: the
/// NaN and Infinity it would accept by default are not JSON). Empty when it does, else python's
/// message.
inline std::string pythonJsonProblem(const fs::path& file) {
    const fs::path log = file.parent_path() / "_python-json.txt";
    std::string cmd = "python3 -c 'import json,sys\n"
                      "def no(c): raise ValueError(\"not JSON: \" + c)\n"
                      "json.load(open(sys.argv[1], encoding=\"utf-8\"), parse_constant=no)' ";
    cmd += shellQuote(file.string());
    cmd += " >";
    cmd += shellQuote(log.string());
    cmd += " 2>&1";
    const int raw = std::system(cmd.c_str());
    std::string message = readFile(log);
    fs::remove(log);
    if (raw != -1 && WIFEXITED(raw) && WEXITSTATUS(raw) == 0) return "";
    return message.empty() ? std::string("python3 failed") : message;
}

/// Every file under dir whose name ends in `extension` (e.g. ".json"), sorted.
inline std::vector<fs::path> filesEndingIn(const fs::path& dir, const std::string& extension) {
    std::vector<fs::path> v;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file() && e.path().extension() == extension) v.push_back(e.path());
    std::sort(v.begin(), v.end());
    return v;
}

/// The names listed in a folder's .crowdhealth-manifest (comment lines left out), sorted.
inline std::vector<std::string> manifestOf(const fs::path& dir) {
    std::vector<std::string> names;
    std::ifstream in(dir / ".crowdhealth-manifest");
    for (std::string l; std::getline(in, l);)
        if (!l.empty() && l[0] != '#') names.push_back(l);
    std::sort(names.begin(), names.end());
    return names;
}

/// The names in a folder (sub-folders with a trailing '/'), sorted; `_`-prefixed capture files
/// of these helpers left out.
inline std::vector<std::string> entriesOf(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string n = e.path().filename().string();
        if (n[0] == '_') continue;
        names.push_back(n + (e.is_directory() ? "/" : ""));
    }
    std::sort(names.begin(), names.end());
    return names;
}

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
