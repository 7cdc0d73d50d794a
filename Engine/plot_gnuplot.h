// crowdhealth plot / compare — talking to gnuplot (through gnuplot-iostream) to draw PNG files.
//
// gnuplot is found on PATH (or named by the environment variable CROWDHEALTH_GNUPLOT, as for
// `crowdhealth render`) before anything is started: gnuplot-iostream runs it through popen, and a
// missing program would otherwise only show as a broken pipe. PNGs are written to `<name>.tmp`
// and renamed once gnuplot has finished, so a file under the final name is always complete.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace chplot {

/// The gnuplot program: $CROWDHEALTH_GNUPLOT, else "gnuplot".
std::string gnuplotProgram();

/// The full path of an external tool if it can be run: $envName if set, else `fallback`,
/// searched on PATH unless the name holds a '/'; nullopt when it cannot be run.
std::optional<std::string> findProgram(const char* envName, const char* fallback);

/// The full path of the gnuplot program if it can be run: findProgram("CROWDHEALTH_GNUPLOT", "gnuplot").
std::optional<std::string> findGnuplot();

/// `s` quoted for /bin/sh.
std::string shellQuote(const std::string& s);

/// The error message for a missing gnuplot, naming `what` (e.g. "--plot"), without a trailing
/// newline.
std::string missingGnuplotMessage(const std::string& what);

/// Inline data for one plot element: rows of numbers (one line each).
using Rows = std::vector<std::vector<double>>;

/// A gnuplot script with inline data blocks ('-'), in the order gnuplot reads them.
class GnuplotJob {
public:
    /// Appends a command line (a newline is added).
    GnuplotJob& cmd(const std::string& line) {
        parts_.emplace_back(line);
        return *this;
    }
    /// Appends an inline data block (read by the next '-' of a plot command).
    GnuplotJob& data(Rows rows) {
        parts_.emplace_back(std::move(rows));
        return *this;
    }
    const std::vector<std::variant<std::string, Rows>>& parts() const { return parts_; }

private:
    std::vector<std::variant<std::string, Rows>> parts_;
};

/// The `set terminal` line for a width × height PNG: pngcairo when gnuplot has it, else png.
std::string pngTerminal(int width, int height);
/// True if gnuplot has the pngcairo terminal (asked once, then remembered).
bool hasPngCairo();

/// A string literal for a gnuplot script ('…', quotes doubled).
std::string gpString(const std::string& s);

/// Runs gnuplot on `job` (which must not set the output itself) writing `png` (via png.tmp).
/// Returns "" on success, else an error message.
std::string drawPng(const GnuplotJob& job, const std::string& terminal, const std::filesystem::path& png);

}  // namespace chplot
