// crowdhealth plot / compare — running gnuplot (see plot_gnuplot.h).
#include "plot_gnuplot.h"

#include <gnuplot-iostream.h>

#include <unistd.h>

#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace chplot {

namespace fs = std::filesystem;

namespace {

bool executable(const fs::path& p) {
    std::error_code ec;
    return fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0;
}

/// Ignores SIGPIPE while alive: if gnuplot dies early, writing to it fails instead of killing us.
class IgnoreSigpipe {
public:
    IgnoreSigpipe() : old_(std::signal(SIGPIPE, SIG_IGN)) {}
    ~IgnoreSigpipe() { std::signal(SIGPIPE, old_ == SIG_ERR ? SIG_DFL : old_); }
    IgnoreSigpipe(const IgnoreSigpipe&) = delete;
    IgnoreSigpipe& operator=(const IgnoreSigpipe&) = delete;

private:
    void (*old_)(int);
};

std::string readText(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (const char c : s) {
        if (c == '\'') q += "'\\''";
        else q += c;
    }
    return q + "'";
}

std::string gnuplotProgram() {
    const char* v = std::getenv("CROWDHEALTH_GNUPLOT");
    return (v && *v) ? std::string(v) : std::string("gnuplot");
}

std::optional<std::string> findGnuplot() { return findProgram("CROWDHEALTH_GNUPLOT", "gnuplot"); }

std::optional<std::string> findProgram(const char* envName, const char* fallback) {
    const char* v = std::getenv(envName);
    const std::string program = (v && *v) ? std::string(v) : std::string(fallback);
    if (program.find('/') != std::string::npos) {
        if (executable(program)) return program;
        return std::nullopt;
    }
    const char* path = std::getenv("PATH");
    if (!path) return std::nullopt;
    std::string dirs = path;
    std::size_t start = 0;
    for (;;) {
        const std::size_t end = dirs.find(':', start);
        std::string dir = dirs.substr(start, end == std::string::npos ? std::string::npos : end - start);
        if (dir.empty()) dir = ".";
        const fs::path candidate = fs::path(dir) / program;
        if (executable(candidate)) return candidate.string();
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return std::nullopt;
}

std::string missingGnuplotMessage(const std::string& what) {
    const char* v = std::getenv("CROWDHEALTH_GNUPLOT");
    std::string m = what + " needs gnuplot (5.0 or later, with the pngcairo or png terminal), but ";
    if (v && *v) m += "CROWDHEALTH_GNUPLOT names '" + std::string(v) + "', which cannot be run";
    else m += "no 'gnuplot' program was found on PATH";
    m += "; install it (e.g. apt install gnuplot-nox) or set CROWDHEALTH_GNUPLOT to its path";
    return m;
}

std::string gpString(const std::string& s) {
    std::string q = "'";
    for (const char c : s) {
        if (c == '\'') q += "''";
        else q += c;
    }
    return q + "'";
}

bool hasPngCairo() {
    static const bool cairo = [] {
        const std::optional<std::string> gp = findGnuplot();
        if (!gp) return false;
        const std::string cmd =
            shellQuote(*gp) + " -e 'print (strstrt(GPVAL_TERMINALS, \"pngcairo\") > 0 ? \"yes\" : \"no\")' 2>&1 </dev/null";
        FILE* p = ::popen(cmd.c_str(), "r");
        if (!p) return false;
        std::string out;
        char buf[256];
        while (std::fgets(buf, sizeof buf, p)) out += buf;
        ::pclose(p);
        return out.find("yes") != std::string::npos;
    }();
    return cairo;
}

std::string pngTerminal(int width, int height) {
    const std::string size = " size " + std::to_string(width) + "," + std::to_string(height);
    if (hasPngCairo()) return "set terminal pngcairo enhanced color font 'Sans,12'" + size + " linewidth 1.5";
    return "set terminal png enhanced font 'Sans,11'" + size;
}

std::string drawPng(const GnuplotJob& job, const std::string& terminal, const fs::path& png) {
    const std::optional<std::string> gp = findGnuplot();
    if (!gp) return missingGnuplotMessage("drawing " + png.filename().string());
    const fs::path tmp = png.string() + ".tmp";
    const fs::path log = png.string() + ".log.tmp";
    std::error_code ec;
    fs::remove(tmp, ec);
    {
        IgnoreSigpipe guard;
        try {
            // gnuplot's messages go to a log, shown only when it fails.
            Gnuplot g(shellQuote(*gp) + " 2>" + shellQuote(log.string()));
            g << terminal << "\n";
            g << "set output " << gpString(tmp.string()) << "\n";
            for (const auto& part : job.parts()) {
                if (const auto* line = std::get_if<std::string>(&part)) g << *line << "\n";
                else g.send1d(std::get<Rows>(part));
            }
            g << "unset multiplot\nunset output\nexit\n";
            g.flush();
        } catch (const std::exception& e) {
            fs::remove(tmp, ec);
            fs::remove(log, ec);
            return "cannot run gnuplot (" + *gp + "): " + e.what();
        }
    }  // ~Gnuplot waits for gnuplot to finish
    const std::string messages = readText(log);
    fs::remove(log, ec);
    // Anything but warnings in gnuplot's messages is an error in the script.
    std::string errors;
    std::istringstream lines(messages);
    for (std::string l; std::getline(lines, l);) {
        std::string lower = l;
        for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (lower.find("warning") != std::string::npos || l.find_first_not_of(" \t^") == std::string::npos) continue;
        errors += "\n  gnuplot: " + l;
    }
    const bool drawn = fs::exists(tmp, ec) && fs::file_size(tmp, ec) > 0;
    if (!errors.empty() || !drawn) {
        fs::remove(tmp, ec);
        return "gnuplot failed to draw " + png.string() + (errors.empty() ? std::string(" (no output)") : errors);
    }
    fs::rename(tmp, png, ec);
    if (ec) {
        fs::remove(tmp, ec);
        return "cannot write " + png.string() + ": " + ec.message();
    }
    return "";
}

}  // namespace chplot
