// crowdhealth calibrate — see calibrate.h and docs/sweeps.md (Calibration).
#include "calibrate.h"

#include "exit_codes.h"
#include "cli.h"
#include "job_pool.h"
#include "text_numbers.h"

#include "nelder_mead.h"
#include "plot_gnuplot.h"
#include "progress.h"
#include "scenario_run.h"
#include "signals.h"
#include "sweep.h"

#include <crowdhealth/core/simulation.h>
#include <crowdhealth/io/json.h>
#include <crowdhealth/io/output.h>
#include <crowdhealth/io/xml.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace chcli {

namespace fs = std::filesystem;
namespace po = boost::program_options;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();



/// The shortest text that reads back as exactly `v`.
std::string shortest(double v) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, res.ptr);
}



std::string trim(const std::string& s) {
    const auto a = s.find_first_not_of(" \t\r");
    if (a == std::string::npos) return "";
    const auto b = s.find_last_not_of(" \t\r");
    return s.substr(a, b - a + 1);
}


bool isName(const std::string& s) {
    if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
    return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

const std::vector<std::string> kObservables = {"flow", "speed", "evacuation_time"};

// ---- ${EXPR} ----------------------------------------------------------------------------------

/// expr := term (('+'|'-') term)*; term := unary (('*'|'/') unary)*;
/// unary := ('+'|'-') unary | NUMBER | NAME | NAME '(' expr ')' | '(' expr ')'.
class Expression {
public:
    Expression(const std::string& text, const std::map<std::string, double>& vars, std::set<std::string>& used)
        : s_(text), vars_(vars), used_(used) {}
    double value() {
        const double v = expr();
        skip();
        if (pos_ != s_.size()) fail("unexpected '" + s_.substr(pos_) + "'");
        return v;
    }

private:
    [[noreturn]] void fail(const std::string& why) { throw std::runtime_error(why); }
    void skip() {
        while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t')) ++pos_;
    }
    bool eat(char c) {
        skip();
        if (pos_ < s_.size() && s_[pos_] == c) {
            ++pos_;
            return true;
        }
        return false;
    }
    double expr() {
        double v = term();
        for (;;) {
            if (eat('+')) v += term();
            else if (eat('-')) v -= term();
            else return v;
        }
    }
    double term() {
        double v = unary();
        for (;;) {
            if (eat('*')) {
                v *= unary();
            } else if (eat('/')) {
                const double d = unary();
                if (d == 0) fail("division by zero");
                v /= d;
            } else {
                return v;
            }
        }
    }
    double unary() {
        if (eat('-')) return -unary();
        if (eat('+')) return unary();
        if (eat('(')) {
            const double v = expr();
            if (!eat(')')) fail("a '(' without its ')'");
            return v;
        }
        skip();
        if (pos_ >= s_.size()) fail("the expression ends too early");
        const char c = s_[pos_];
        if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
            double v = 0;
            const auto res = std::from_chars(s_.data() + pos_, s_.data() + s_.size(), v);
            if (res.ec != std::errc()) fail("a bad number at '" + s_.substr(pos_) + "'");
            pos_ = static_cast<std::size_t>(res.ptr - s_.data());
            return v;
        }
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
            const std::size_t from = pos_;
            while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) ++pos_;
            const std::string name = s_.substr(from, pos_ - from);
            if (eat('(')) {
                const double a = expr();
                if (!eat(')')) fail("a '(' without its ')'");
                if (name == "sqrt") {
                    if (a < 0) fail("sqrt of a negative number");
                    return std::sqrt(a);
                }
                if (name == "floor") return std::floor(a);
                if (name == "ceil") return std::ceil(a);
                if (name == "round") return std::round(a);
                if (name == "abs") return std::abs(a);
                fail("unknown function '" + name + "' (there are sqrt, floor, ceil, round, abs)");
            }
            const auto it = vars_.find(name);
            if (it == vars_.end()) {
                std::string known;
                for (const auto& [k, v] : vars_) known += (known.empty() ? "" : ", ") + k;
                fail("'" + name + "' is not a column of the data file (its variables: " + known + ")");
            }
            used_.insert(name);
            return it->second;
        }
        fail("unexpected '" + s_.substr(pos_) + "'");
    }

    const std::string& s_;
    const std::map<std::string, double>& vars_;
    std::set<std::string>& used_;
    std::size_t pos_ = 0;
};

}  // namespace

std::optional<std::string> fillPlaceholders(const std::string& text, const std::string& path,
                                            const std::map<std::string, double>& variables,
                                            std::set<std::string>& used, std::string& error) {
    std::string out;
    std::size_t at = 0;
    auto lineOf = [&](std::size_t pos) { return 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(pos), '\n'); };
    for (;;) {
        const std::size_t open = text.find("${", at);
        if (open == std::string::npos) break;
        out.append(text, at, open - at);
        const std::size_t close = text.find('}', open);
        const std::size_t newline = text.find('\n', open);
        if (close == std::string::npos || (newline != std::string::npos && newline < close)) {
            error = path + ":" + std::to_string(lineOf(open)) + ": error: a placeholder '${' without its '}' on the same line";
            return std::nullopt;
        }
        const std::string expr = text.substr(open + 2, close - open - 2);
        double v = 0;
        try {
            if (trim(expr).empty()) throw std::runtime_error("it is empty");
            Expression e(expr, variables, used);
            v = e.value();
            if (!std::isfinite(v)) throw std::runtime_error("its value is not a finite number");
        } catch (const std::exception& e) {
            error = path + ":" + std::to_string(lineOf(open)) + ": error: placeholder ${" + expr + "}: " + e.what();
            return std::nullopt;
        }
        if (v == 0) v = 0;  // no "-0"
        out += shortest(v);
        at = close + 1;
    }
    out.append(text, at, std::string::npos);
    return out;
}

// ---- the data file ----------------------------------------------------------------------------

std::optional<CalibrationData> parseCalibrationData(const std::string& text, const std::string& path, std::string& error) {
    CalibrationData d;
    std::istringstream in(text);
    std::string line;
    int number = 0, observableColumn = -1, weightColumn = -1;
    std::vector<std::string> header;
    auto fail = [&](int at, const std::string& why) {
        error = path + ":" + std::to_string(at) + ": error: " + why;
        return std::nullopt;
    };
    while (std::getline(in, line)) {
        ++number;
        const std::string t = trim(line);
        if (t.empty() || t[0] == '#') continue;
        std::vector<std::string> cells = splitOn(t, ',');
        for (std::string& c : cells) c = trim(c);
        if (header.empty()) {
            header = cells;
            std::set<std::string> seen;
            for (std::size_t k = 0; k < header.size(); ++k) {
                const std::string& h = header[k];
                if (!isName(h))
                    return fail(number, "column " + std::to_string(k + 1) + " of the header, '" + h +
                                            "', is not a name (letters, digits and _, not starting with a digit)");
                if (!seen.insert(h).second) return fail(number, "the column '" + h + "' appears twice in the header");
                if (h == "weight") {
                    weightColumn = static_cast<int>(k);
                } else if (std::find(kObservables.begin(), kObservables.end(), h) != kObservables.end()) {
                    if (observableColumn >= 0)
                        return fail(number, "two observables, '" + header[static_cast<std::size_t>(observableColumn)] +
                                                "' and '" + h + "': a data file compares one");
                    observableColumn = static_cast<int>(k);
                } else {
                    d.variables.push_back(h);
                }
            }
            if (observableColumn < 0)
                return fail(number, "no observable in the header '" + t +
                                        "': one column must be flow (persons/s), speed (m/s) or evacuation_time (s)");
            if (d.variables.empty())
                return fail(number, "no experimental variable in the header '" + t +
                                        "': name at least one column besides the observable (e.g. width,flow)");
            d.observableName = header[static_cast<std::size_t>(observableColumn)];
            d.observable = d.observableName == "flow"    ? Observable::Flow
                           : d.observableName == "speed" ? Observable::Speed
                                                         : Observable::EvacuationTime;
            continue;
        }
        if (cells.size() != header.size())
            return fail(number, std::to_string(cells.size()) + " values, but the header has " +
                                    std::to_string(header.size()) + " columns");
        CalibrationData::Row row;
        row.line = number;
        for (std::size_t k = 0; k < cells.size(); ++k) {
            double v = 0;
            if (!parseDouble(cells[k], v))
                return fail(number, header[k] + ": '" + cells[k] + "' is not a number");
            if (static_cast<int>(k) == observableColumn) row.y = v;
            else if (static_cast<int>(k) == weightColumn) row.weight = v;
            else row.x.push_back(v);
        }
        if (!(row.weight > 0)) return fail(number, "weight: must be positive, not " + cells[static_cast<std::size_t>(weightColumn)]);
        const auto it = std::find(d.conditions.begin(), d.conditions.end(), row.x);
        row.condition = static_cast<std::size_t>(it - d.conditions.begin());
        if (it == d.conditions.end()) d.conditions.push_back(row.x);
        d.rows.push_back(std::move(row));
    }
    if (header.empty()) return fail(std::max(number, 1), "no header: the first line that is not a comment names the columns, e.g. width,flow");
    if (d.rows.empty()) return fail(number, "no data rows after the header");
    return d;
}

namespace {

// ---- one run ----------------------------------------------------------------------------------

/// One --fit TARGET=LO:HI.
struct FitParameter {
    std::string target;
    ch::RampSpec ramp;
    double lo = 0, hi = 0;
};

/// What every process needs to run a job (built the same way on every MPI rank).
struct CalibrationSetup {
    std::string input;                       ///< the template's path (messages, relative paths)
    std::vector<std::string> scenarioTexts;  ///< per condition, the filled-in template
    std::vector<FitParameter> fits;
    Observable observable = Observable::Flow;
    double measureFrom = 0;                  ///< s, speed: measured from this time on
    std::optional<double> endTime;
};

/// The options a run is planned with (no files: the runs write nothing).
Options runOptions(const CalibrationSetup& s) {
    Options o;
    o.input = s.input;
    o.endTime = s.endTime;
    o.quiet = true;
    o.overwrite = true;
    o.trajectories = "none";
    return o;
}

/// The scenario of one job: the condition's text with `seed`, every fitted value held from t = 0
/// by a ramp (as sweep --vary). Diagnostics into `diags`.
std::optional<ch::ScenarioSpec> jobSpec(const CalibrationSetup& s, std::size_t condition, std::uint64_t seed,
                                        const std::vector<double>& values, ch::Diagnostics& diags) {
    ch::LoadOptions lo;
    lo.seed = seed;
    lo.text = s.scenarioTexts[condition];
    std::optional<ch::ScenarioSpec> spec = ch::loadScenario(s.input, diags, lo);
    if (!spec || diags.hasErrors()) return std::nullopt;
    for (std::size_t k = 0; k < s.fits.size(); ++k) {
        ch::RampSpec r = s.fits[k].ramp;
        r.from = r.to = values[k];
        r.start = r.end = 0;
        spec->ramps.push_back(r);
    }
    return spec;
}

bool insidePolygon(const std::vector<ch::Vec2>& poly, const ch::Vec2& p) {
    bool in = false;
    for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
        const ch::Vec2 &a = poly[i], &b = poly[j];
        if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
            in = !in;
    }
    return in;
}

/// Job text "CONDITION SEED VALUE…" → "ok MEASURED" or "failed REASON". Never throws.
std::string runJob(const CalibrationSetup& s, const std::string& job, std::atomic<double>& clock) {
    try {
        std::istringstream in(job);
        std::size_t condition = 0;
        std::uint64_t seed = 0;
        in >> condition >> seed;
        std::vector<double> values(s.fits.size());
        for (double& v : values) {
            std::string w;
            in >> w;
            if (!parseDouble(w, v)) throw std::runtime_error("a malformed job '" + job + "'");
        }
        if (!in || condition >= s.scenarioTexts.size()) throw std::runtime_error("a malformed job '" + job + "'");
        ch::Diagnostics diags;
        const std::optional<ch::ScenarioSpec> spec = jobSpec(s, condition, seed, values, diags);
        if (!spec) throw std::runtime_error("the scenario could not be loaded");
        ch::Simulation sim(*spec);
        const Options o = runOptions(s);
        std::ostringstream quiet;
        const std::optional<RunPlan> plan = planRun(o, sim.spec(), false, quiet);
        if (!plan) throw std::runtime_error("the run cannot be planned");
        RunSession session(sim, *plan, fs::temp_directory_path(), 1);
        const std::vector<ch::Vec2>* area =
            s.observable == Observable::Speed && !sim.spec().measurement.areas.empty() ? &sim.spec().measurement.areas.front().polygon : nullptr;
        double speedSum = 0;
        std::size_t speedSamples = 0;
        session.begin();
        while (!session.done()) {
            if (interruptRequested()) throw std::runtime_error("interrupted");
            session.step();
            clock.store(sim.time(), std::memory_order_relaxed);
            if (area != nullptr && sim.time() >= s.measureFrom - 1e-9) {
                // The mean speed of those inside, averaged over the steps with someone inside.
                const ch::AgentStore& A = sim.agents();
                double sum = 0;
                std::size_t inside = 0;
                for (std::size_t i = 0; i < A.size(); ++i)
                    if (insidePolygon(*area, A.pos[i])) sum += A.vel[i].norm(), ++inside;
                if (inside > 0) speedSum += sum / static_cast<double>(inside), ++speedSamples;
            }
        }
        session.end();
        std::optional<double> value;
        switch (s.observable) {
            case Observable::Flow: value = ch::runFlow(sim); break;
            case Observable::EvacuationTime: value = ch::runEvacuationTime(sim); break;
            case Observable::Speed:
                if (speedSamples > 0) value = speedSum / static_cast<double>(speedSamples);
                break;
        }
        if (!value || !std::isfinite(*value))
            throw std::runtime_error(s.observable == Observable::Speed ? "nobody was in the measurement area"
                                                                        : "not everybody reached the exit before the end time");
        return "ok " + exactNumber(*value);
    } catch (const std::exception& e) {
        return std::string("failed ") + e.what();
    }
}

// ---- the objective ----------------------------------------------------------------------------

/// One evaluation: the model at one parameter vector.
struct Evaluation {
    std::vector<double> values;
    std::string step;
    double objective = kInf;
    std::vector<double> mean, sd;  ///< per condition, over the seeds
    std::string error;             ///< why it has no objective
};

/// Σ weight · residual² with the residual absolute or relative to the data.
double objectiveOf(const CalibrationData& d, const std::vector<double>& mean, bool relative) {
    double sum = 0;
    for (const CalibrationData::Row& r : d.rows) {
        const double res = mean[r.condition] - r.y;
        const double q = relative ? res / r.y : res;
        sum += r.weight * q * q;
    }
    return sum;
}

/// Solves the small symmetric system A X = B in place by Gauss–Jordan with partial pivoting;
/// false when A is singular.
bool invert(std::vector<std::vector<double>>& a) {
    const std::size_t n = a.size();
    std::vector<std::vector<double>> inv(n, std::vector<double>(n, 0.0));
    for (std::size_t i = 0; i < n; ++i) inv[i][i] = 1;
    for (std::size_t c = 0; c < n; ++c) {
        std::size_t piv = c;
        for (std::size_t r = c + 1; r < n; ++r)
            if (std::abs(a[r][c]) > std::abs(a[piv][c])) piv = r;
        if (!(std::abs(a[piv][c]) > 1e-300)) return false;
        std::swap(a[c], a[piv]);
        std::swap(inv[c], inv[piv]);
        const double d = a[c][c];
        for (std::size_t k = 0; k < n; ++k) a[c][k] /= d, inv[c][k] /= d;
        for (std::size_t r = 0; r < n; ++r) {
            if (r == c) continue;
            const double f = a[r][c];
            for (std::size_t k = 0; k < n; ++k) a[r][k] -= f * a[c][k], inv[r][k] -= f * inv[c][k];
        }
    }
    a = inv;
    return true;
}

// ---- resume ----------------------------------------------------------------------------------
//
// OUTDIR/.calibrate/arguments holds what defines the runs (as sweep's .sweep/arguments): the
// template's and the data's paths and content hashes, the files the template reads and the
// plugins (readFilesText), the fits with their ranges, the seeds, the
// search's settings. OUTDIR/.calibrate/runs.txt gets one line per run that finished with a value,
// "JOB<TAB>ok VALUE", as the results arrive (a job is "condition seed value..." with every number
// exact). The search is deterministic given its runs' results, so a second call with the same
// arguments asks for the same jobs in the same order: those recorded are taken from the file, the
// others run, and the outputs are those of a calibration made in one go. Runs that failed are not
// recorded (they are run again: a failure here is the scenario's, and happens again).

/// The text of OUTDIR/.calibrate/arguments.
std::string calibrationArguments(const CalibrationSetup& s, const std::vector<std::string>& included,
                                 const std::string& dataPath, std::size_t seeds, std::uint64_t firstSeed,
                                 std::size_t maxEvaluations, double tolerance, bool relative) {
    std::string t = "crowdhealth calibrate 1\nscenario " + canonicalPath(s.input) + "\nscenario_content " +
                    fileHash(s.input) + "\n" + readFilesText(included) + "data " + canonicalPath(dataPath) +
                    "\ndata_content " + fileHash(dataPath) + "\n";
    for (const FitParameter& f : s.fits) t += "fit " + f.target + "=" + shortest(f.lo) + ":" + shortest(f.hi) + "\n";
    t += "seeds " + std::to_string(seeds) + "\nseed " + std::to_string(firstSeed) + "\n";
    t += "max_evaluations " + std::to_string(maxEvaluations) + "\ntolerance " + shortest(tolerance) + "\n";
    t += std::string("residuals ") + (relative ? "relative" : "absolute") + "\n";
    t += "measure_from " + exactNumber(s.measureFrom) + "\nend_time " +
         (s.endTime ? exactNumber(*s.endTime) : std::string("scenario")) + "\n";
    return t;
}

/// The recorded runs of runs.txt: job → "ok VALUE". A last line cut short (the program killed while
/// writing it) is dropped, and the file cut back to its last whole line so that new lines start
/// afresh; a line that does not read as a record is ignored (its run is made again).
std::map<std::string, std::string> readRunRecords(const fs::path& file) {
    std::map<std::string, std::string> records;
    std::ifstream in(file, std::ios::binary);
    if (!in) return records;
    std::ostringstream all;
    all << in.rdbuf();
    in.close();
    std::string text = all.str();
    const std::size_t end = text.rfind('\n');
    const std::size_t whole = end == std::string::npos ? 0 : end + 1;
    if (whole < text.size()) {
        text.resize(whole);
        std::error_code ec;
        fs::resize_file(file, whole, ec);
    }
    for (const std::string& line : splitOn(text, '\n')) {
        const std::size_t tab = line.find('\t');
        if (tab == std::string::npos) continue;
        const std::string result = line.substr(tab + 1);
        double v = 0;
        if (result.rfind("ok ", 0) != 0 || !parseDouble(result.substr(3), v)) continue;
        records[line.substr(0, tab)] = result;
    }
    return records;
}

// ---- the command ------------------------------------------------------------------------------

void printCalibrateHelp(std::ostream& out, const po::options_description& visible) {
    out << "Usage: crowdhealth calibrate -i SCENARIO --fit TARGET=LO:HI [--fit ...] --data FILE\n"
           "                             [--seeds N] [-o OUTDIR] [--seed S] [--jobs N] [--quiet]\n\n"
           "Fits the --fit parameters, each within [LO, HI], so that the mean over N seeds of what\n"
           "the scenario's runs measure matches the data: Nelder-Mead in the box of the ranges,\n"
           "minimising the sum over the data rows of weight * (model mean - data)^2. Every\n"
           "evaluation runs each distinct row of variable values with the seeds S ... S+N-1 (the\n"
           "same seeds every time), at most --jobs runs at a time.\n\n"
           "FILE is a CSV: a header naming the experimental variables (e.g. width), one observable\n"
           "(flow: persons/s as summary.json's flow; speed: m/s, the mean speed in the scenario's\n"
           "first measurement <Area>; evacuation_time: s) and optionally weight; '#' lines are\n"
           "comments. SCENARIO is a template: each ${EXPR} in it is replaced per row by the value of\n"
           "EXPR, a variable or an expression of them (${width}, ${4 - width/2}; + - * / ( ) sqrt\n"
           "floor ceil round abs). Every variable must appear in a placeholder.\n\n"
           "TARGET names a parameter as in 'crowdhealth sweep --vary' (0.SPH.restDensityMax,\n"
           "agents.pref_speed); its value holds for the whole run.\n\n"
           "Writes OUTDIR/calibration.csv (every evaluation: its values and objective),\n"
           "OUTDIR/calibration-result.json (fitted values with standard errors, the model against the\n"
           "data) and OUTDIR/calibration.png. Same arguments, same results, whatever --jobs.\n\n"
           "Resume: every run that gives a value is recorded in OUTDIR/.calibrate/runs.txt as it\n"
           "finishes; the same command again (after Ctrl-C, a kill, a crash or a job's time limit)\n"
           "takes those from the record, runs the others, and writes the files a calibration made in\n"
           "one go writes. Other arguments, data or scenario (or an edited file it reads, or a rebuilt\n"
           "plugin) with the same OUTDIR are refused.\n\n";
    out << visible << "\n"
        << "Exit status: 0 fitted; 1 every evaluation failed or OUTDIR cannot be written; 2 bad\n"
           "arguments, data or scenario; 130 interrupted (the same command resumes).\n";
}

/// An ostream that discards everything (worker ranks validate quietly).
struct NullBuffer : std::streambuf {
    int overflow(int c) override { return c; }
};

}  // namespace

int calibrateCommand(int argc, char* argv[]) {
    po::options_description visible("Options");
    // clang-format off
    visible.add_options()
        ("input,i", po::value<std::string>()->value_name("SCENARIO"), "scenario template (XML with ${...} placeholders)")
        ("fit", po::value<std::vector<std::string>>()->composing()->value_name("TARGET=LO:HI"),
         "a parameter to fit and its range, e.g. agents.pref_speed=0.8:1.6; repeat for more")
        ("data", po::value<std::string>()->value_name("FILE"), "the experimental data (CSV)")
        ("seeds", po::value<std::string>()->value_name("N"), "seeds per evaluation (default 5)")
        ("output,o", po::value<std::string>()->value_name("OUTDIR"), "folder for the outputs (default: calibration)")
        ("seed", po::value<std::string>()->value_name("S"), "first seed (default: Simulation@seed)")
        ("jobs,j", po::value<std::string>()->value_name("N"), "runs at a time, each on one thread (default: one per hardware thread)")
        ("max-evaluations", po::value<std::string>()->value_name("N"), "stop after about N evaluations (default 60)")
        ("tolerance", po::value<std::string>()->value_name("T"),
         "stop when the simplex is within T of the range's width (default 0.01)")
        ("residuals", po::value<std::string>()->value_name("absolute|relative"),
         "model - data (default), or (model - data) / data")
        ("measure-from", po::value<std::string>()->value_name("T"), "speed: measured from this time on (s, default 0)")
        ("end-time", po::value<std::string>()->value_name("T"), "simulated time to stop at (s), overrides Simulation@end_time")
        ("plugin", po::value<std::vector<std::string>>()->composing()->value_name("FILE"),
         "load a plugin before the scenario (as 'crowdhealth --plugin'; a scenario can also name it with <Plugin file=...>); repeatable")
        ("quiet,q", "no progress line and no closing lines")
        ("help,h", "show this help");
    // clang-format on
    po::variables_map vm;
    std::string parseError;
    try {
        po::store(po::command_line_parser(argc, argv).options(visible).positional({}).run(), vm);
        po::notify(vm);
    } catch (const std::exception& e) {
        parseError = e.what();
    }
    const auto str = [&](const char* name) { return vm[name].as<std::string>(); };
    std::uint64_t u = 0;
    JobPoolOptions poolOptions;
    std::string jobsError;
    if (parseError.empty() && vm.count("jobs")) {
        if (!parseUnsigned(str("jobs"), u) || u < 1 || u > 4096) jobsError = "--jobs must be a whole number from 1 to 4096, not '" + str("jobs") + "'";
        else poolOptions.localJobs = u;
    }

    // Every process builds the pool first; only the controller speaks (job_pool.h).
    std::shared_ptr<const CalibrationSetup> setup;
    JobPool pool([&setup](const std::string& job, std::atomic<double>& clock) { return runJob(*setup, job, clock); },
                 poolOptions);
    NullBuffer nullBuffer;
    std::ostream nullStream(&nullBuffer);
    std::ostream& err = pool.controller() ? std::cerr : nullStream;
    // Every rank calls agree() exactly once after its checks (job_pool.h): a rank that returns
    // early does it here, on the way out, so that the others learn it failed instead of waiting.
    struct AgreeOnReturn {
        JobPool& pool;
        bool agreed = false;
        int status = kExitInput;
        ~AgreeOnReturn() {
            if (!agreed) pool.agree(status);
        }
    } agreement{pool};
    auto usage = [&](const std::string& message) {
        err << "crowdhealth: error: " << message << "\nTry 'crowdhealth calibrate --help' for more information.\n";
        return kExitInput;
    };
    if (!parseError.empty()) return usage(parseError);
    if (vm.count("help")) {
        if (pool.controller()) printCalibrateHelp(std::cout, visible);
        return kExitOk;
    }
    if (!jobsError.empty()) return usage(jobsError);
    if (!vm.count("input") || str("input").empty()) return usage("no scenario given: use -i SCENARIO");
    if (!vm.count("fit")) return usage("nothing to fit: give at least one --fit TARGET=LO:HI");
    if (!vm.count("data") || str("data").empty()) return usage("no data given: use --data FILE");

    if (vm.count("plugin") && !loadPlugins(vm["plugin"].as<std::vector<std::string>>(), err)) return kExitInput;
    CalibrationSetup s;
    s.input = str("input");
    const std::string dataPath = str("data");
    const fs::path output = vm.count("output") ? fs::path(str("output")) : fs::path("calibration");
    if (output.empty()) return usage("-o: an empty folder name");
    const bool quiet = vm.count("quiet") != 0;
    std::size_t seeds = 5, maxEvaluations = 60;
    double tolerance = 0.01;
    bool relative = false;
    std::optional<std::uint64_t> firstSeedArg;
    if (vm.count("seeds")) {
        if (!parseUnsigned(str("seeds"), u) || u < 1 || u > 100000)
            return usage("--seeds must be a whole number from 1 to 100000, not '" + str("seeds") + "'");
        seeds = u;
    }
    if (vm.count("seed")) {
        if (!parseUnsigned(str("seed"), u)) return usage("--seed must be a whole number, not '" + str("seed") + "'");
        firstSeedArg = u;
    }
    if (vm.count("max-evaluations")) {
        if (!parseUnsigned(str("max-evaluations"), u) || u < 1 || u > 1000000)
            return usage("--max-evaluations must be a whole number from 1 to 1000000, not '" + str("max-evaluations") + "'");
        maxEvaluations = u;
    }
    if (vm.count("tolerance")) {
        if (!parseDouble(str("tolerance"), tolerance) || !(tolerance > 0) || tolerance >= 1)
            return usage("--tolerance must be a number between 0 and 1 (a share of each range), not '" + str("tolerance") + "'");
    }
    if (vm.count("residuals")) {
        if (str("residuals") != "absolute" && str("residuals") != "relative")
            return usage("--residuals must be absolute or relative, not '" + str("residuals") + "'");
        relative = str("residuals") == "relative";
    }
    if (vm.count("measure-from")) {
        if (!parseDouble(str("measure-from"), s.measureFrom) || s.measureFrom < 0)
            return usage("--measure-from must be a number of seconds >= 0, not '" + str("measure-from") + "'");
    }
    if (vm.count("end-time")) {
        double t = 0;
        if (!parseDouble(str("end-time"), t) || t <= 0)
            return usage("--end-time must be a positive number of seconds, not '" + str("end-time") + "'");
        s.endTime = t;
    }
    std::set<std::string> seenTargets;
    for (const std::string& f : vm["fit"].as<std::vector<std::string>>()) {
        const std::string arg = "--fit '" + f + "'";
        const auto eq = f.find('=');
        if (eq == std::string::npos) return usage(arg + ": give TARGET=LO:HI, e.g. agents.pref_speed=0.8:1.6");
        FitParameter p;
        p.target = f.substr(0, eq);
        if (const auto problem = parseSweepTarget(p.target, p.ramp)) return usage(arg + ": " + *problem);
        const std::vector<std::string> range = splitOn(f.substr(eq + 1), ':');
        if (range.size() != 2) return usage(arg + ": the range is LO:HI (two numbers), not '" + f.substr(eq + 1) + "'");
        if (!parseDouble(range[0], p.lo)) return usage(arg + ": LO '" + range[0] + "' is not a number");
        if (!parseDouble(range[1], p.hi)) return usage(arg + ": HI '" + range[1] + "' is not a number");
        if (!(p.lo < p.hi)) return usage(arg + ": LO (" + range[0] + ") must be below HI (" + range[1] + ")");
        p.ramp.loc.file = "--fit " + p.target;
        if (!seenTargets.insert(p.ramp.column() + "@" + (p.ramp.policyId ? std::to_string(*p.ramp.policyId) : "")).second)
            return usage(arg + ": " + p.target + " is fitted twice");
        s.fits.push_back(std::move(p));
    }

    // ---- the data and the template, every condition loaded, before anything is written ----
    std::string dataText, templateText;
    {
        std::ifstream in(dataPath, std::ios::binary);
        if (!in || fs::is_directory(dataPath)) {
            err << dataPath << ":0: error: cannot read the data file\n";
            return kExitInput;
        }
        std::ostringstream t;
        t << in.rdbuf();
        dataText = t.str();
    }
    std::string problem;
    const std::optional<CalibrationData> data = parseCalibrationData(dataText, dataPath, problem);
    if (!data) {
        err << problem << "\n";
        return kExitInput;
    }
    if (relative)
        for (const CalibrationData::Row& r : data->rows)
            if (r.y == 0) {
                err << dataPath << ":" << r.line << ": error: " << data->observableName
                    << " is 0, which a relative residual cannot divide by; use --residuals absolute\n";
                return kExitInput;
            }
    s.observable = data->observable;
    {
        std::ifstream in(s.input, std::ios::binary);
        if (!in || fs::is_directory(s.input)) {
            err << s.input << ":0: error: cannot read the scenario\n";
            return kExitInput;
        }
        std::ostringstream t;
        t << in.rdbuf();
        templateText = t.str();
    }
    std::set<std::string> used;
    for (const std::vector<double>& c : data->conditions) {
        std::map<std::string, double> vars;
        for (std::size_t k = 0; k < data->variables.size(); ++k) vars[data->variables[k]] = c[k];
        const std::optional<std::string> text = fillPlaceholders(templateText, s.input, vars, used, problem);
        if (!text) {
            err << problem << "\n";
            return kExitInput;
        }
        s.scenarioTexts.push_back(*text);
    }
    for (const std::string& v : data->variables)
        if (!used.count(v)) {
            err << s.input << ":1: error: the data's variable '" << v << "' (" << dataPath
                << ") appears in no placeholder of the scenario: write ${" << v
                << "} where its value goes, or leave the column out of the data\n";
            return kExitInput;
        }
    std::uint64_t firstSeed = 0;
    std::vector<std::string> included;  // the files the conditions' scenarios read, each once
    for (std::size_t c = 0; c < s.scenarioTexts.size(); ++c) {
        ch::Diagnostics diags;
        ch::LoadOptions lo;
        lo.seed = firstSeedArg;
        lo.text = s.scenarioTexts[c];
        std::optional<ch::ScenarioSpec> spec;
        try {
            spec = ch::loadScenario(s.input, diags, lo);
        } catch (const std::exception& e) {
            diags.error(ch::SourceLoc{s.input, 0}, std::string("cannot load the scenario: ") + e.what());
        }
        if (!spec || diags.hasErrors()) {
            diags.print(err);
            std::string at;
            for (std::size_t k = 0; k < data->variables.size(); ++k)
                at += (k ? ", " : "") + data->variables[k] + " = " + shortest(data->conditions[c][k]);
            err << "crowdhealth: error: the scenario " << s.input << " with " << at
                << " (the data's line " << std::find_if(data->rows.begin(), data->rows.end(), [&](const auto& r) { return r.condition == c; })->line
                << ") is not valid; nothing was simulated or written\n";
            return kExitInput;
        }
        for (const std::string& f : spec->includedFiles)
            if (std::find(included.begin(), included.end(), f) == included.end()) included.push_back(f);
        if (c == 0) {
            diags.print(err);  // the warnings, once (the first condition), as a run shows them
            firstSeed = spec->seed;
            if (firstSeed > std::numeric_limits<std::uint64_t>::max() - (seeds - 1))
                return usage("the seeds " + std::to_string(firstSeed) + " ... +" + std::to_string(seeds - 1) +
                             " do not fit in 64 bits; give a smaller --seed");
            for (const FitParameter& p : s.fits) {
                const std::string arg = "--fit '" + p.target + "=" + shortest(p.lo) + ":" + shortest(p.hi) + "'";
                for (const double v : {p.lo, p.hi}) {
                    ch::RampSpec r = p.ramp;
                    r.from = r.to = v;
                    const std::string why = ch::rampTargetProblem(*spec, r);
                    if (!why.empty()) return usage(arg + ": " + why);
                }
                for (const ch::RampSpec& r : spec->ramps)
                    if (r.column() == p.ramp.column())
                        return usage(arg + ": the scenario ramps " + r.column() + " itself (" + r.loc.file + ":" +
                                     std::to_string(r.loc.line) + "); calibrate holds the value for the whole run, remove that <Ramp>");
            }
            if (s.observable == Observable::Speed && spec->measurement.areas.empty()) {
                err << s.input << ":1: error: the data's observable is speed, measured in the scenario's first <Area> of "
                                  "<Measurement>, and the scenario has none\n";
                return kExitInput;
            }
        }
        // Build every condition's simulation once (at the box's centre): unknown components and
        // the like show here (exit 2).
        std::vector<double> centre;
        for (const FitParameter& p : s.fits) centre.push_back(0.5 * (p.lo + p.hi));
        ch::Diagnostics again;
        const std::optional<ch::ScenarioSpec> held = jobSpec(s, c, firstSeed, centre, again);
        try {
            if (!held) throw std::runtime_error("the scenario could not be loaded");
            ch::Simulation sim(*held);
            if (!planRun(runOptions(s), sim.spec(), c == 0 && pool.controller(), err)) return kExitInput;
        } catch (const std::exception& e) {
            err << "crowdhealth: error: " << e.what() << "\n";
            return kExitInput;
        }
    }
    setup = std::make_shared<const CalibrationSetup>(s);

    // ---- OUTDIR (the controller's alone): new, or a calibration with the same arguments ----
    const fs::path state = output / ".calibrate", runsFile = state / "runs.txt";
    std::map<std::string, std::string> recorded;
    if (pool.controller()) {
        const std::string arguments =
            calibrationArguments(s, included, dataPath, seeds, firstSeed, maxEvaluations, tolerance, relative);
        std::error_code ec;
        if (fs::exists(state / "arguments", ec)) {
            std::ifstream in(state / "arguments", std::ios::binary);
            std::ostringstream was;
            was << in.rdbuf();
            if (was.str() != arguments) {
                std::cerr << "crowdhealth: error: " << output.string()
                          << " holds a calibration made with other arguments, data, scenario or files it reads ("
                          << firstDifference(was.str(), arguments)
                          << "); it is not resumed: give another -o OUTDIR, or the same arguments as before\n";
                return kExitInput;
            }
        }
        fs::create_directories(state, ec);
        if (ec || !fs::is_directory(state)) {
            std::cerr << "crowdhealth: error: cannot create the output folder " << output.string() << ": " << ec.message() << "\n";
            agreement.status = kExitRuntime;
            return kExitRuntime;
        }
        try {
            if (!fs::exists(state / "arguments")) ch::writeFileAtomic(state / "arguments", arguments);
        } catch (const std::exception& e) {
            std::cerr << "crowdhealth: error: cannot write to " << output.string() << ": " << e.what() << "\n";
            agreement.status = kExitRuntime;
            return kExitRuntime;
        }
        recorded = readRunRecords(runsFile);
        if (!quiet && !recorded.empty())
            std::cerr << "calibrate: resuming: " << plural(recorded.size(), "run") << " already made ("
                      << runsFile.string() << ")\n";
    }
    agreement.agreed = true;
    if (const int status = pool.agree(kExitOk); status != kExitOk) {
        if (pool.controller() && status != kExitOk)
            std::cerr << "crowdhealth: error: another MPI rank could not load the scenario or the data (a file missing or "
                         "unreadable on its host?); nothing was run\n";
        return status;
    }

    // ---- workers (MPI ranks other than the controller) run jobs until the study is over ----
    if (!pool.controller()) {
        pool.serve();
        return pool.exitStatus();
    }
    // ---- the controller: the search, the errors, the outputs ----
    const int status = [&]() -> int {

        // ---- the search ----
        const std::size_t p = s.fits.size(), conditions = data->conditions.size();
        std::vector<Evaluation> evaluations;
        const bool drawProgress = !quiet;
        const bool terminal = ProgressBar::stderrIsTerminal();
        const auto wallStart = std::chrono::steady_clock::now();
        std::size_t best = std::numeric_limits<std::size_t>::max();
        auto describe = [&](const std::vector<double>& v) {
            std::string t;
            for (std::size_t k = 0; k < p; ++k) t += (k ? " " : "") + s.fits[k].target + "=" + csvCell(v[k]);
            return t;
        };
        auto progressLine = [&](std::size_t done, std::size_t total) {
            std::string t = "calibrate: evaluation " + std::to_string(evaluations.size()) + ", runs " + std::to_string(done) +
                            "/" + std::to_string(total);
            if (best < evaluations.size())
                t += " | best " + csvCell(evaluations[best].objective) + " at " + describe(evaluations[best].values);
            t += " | " + formatDuration(std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count());
            return t;
        };
        installInterruptHandlers();
        // One batch: every point × condition × seed, run as one set of jobs.
        auto evaluateBatch = [&](const std::vector<std::vector<double>>& points, const std::string& step) -> std::optional<std::vector<double>> {
            std::vector<std::string> jobs;
            for (const std::vector<double>& x : points)
                for (std::size_t c = 0; c < conditions; ++c)
                    for (std::size_t k = 0; k < seeds; ++k) {
                        std::string j = std::to_string(c) + " " + std::to_string(firstSeed + k);
                        for (const double v : x) j += " " + exactNumber(v);
                        jobs.push_back(std::move(j));
                    }
            // The runs recorded by an earlier call are taken from the record; the others run, and
            // each that gives a value is appended to it as it arrives.
            std::vector<std::string> results(jobs.size()), missing;
            std::vector<std::size_t> missingAt;
            for (std::size_t k = 0; k < jobs.size(); ++k) {
                const auto it = recorded.find(jobs[k]);
                if (it != recorded.end()) {
                    results[k] = it->second;
                } else {
                    missing.push_back(jobs[k]);
                    missingAt.push_back(k);
                }
            }
            const std::size_t already = jobs.size() - missing.size();
            bool complete = true;
            if (!missing.empty()) {
                std::ofstream log(runsFile, std::ios::binary | std::ios::app);
                complete = pool.run(
                    missing,
                    [&](std::size_t index, const std::string& r) {
                        results[missingAt[index]] = r;
                        if (r.rfind("ok ", 0) == 0 && log) {
                            log << missing[index] << '\t' << r << '\n' << std::flush;
                            recorded[missing[index]] = r;
                        }
                    },
                    [&](const JobPoolState& st) {
                        if (drawProgress && terminal)
                            std::cerr << "\r\033[K" << progressLine(already + st.done, jobs.size()) << std::flush;
                    });
            }
            if (!complete || interruptRequested()) return std::nullopt;
            std::vector<double> values;
            for (std::size_t q = 0; q < points.size(); ++q) {
                Evaluation e;
                e.values = points[q];
                e.step = step;
                e.mean.assign(conditions, std::nan(""));
                e.sd.assign(conditions, std::nan(""));
                for (std::size_t c = 0; c < conditions && e.error.empty(); ++c) {
                    std::vector<double> xs;
                    for (std::size_t k = 0; k < seeds; ++k) {
                        const std::string& r = results[(q * conditions + c) * seeds + k];
                        double v = 0;
                        if (r.rfind("ok ", 0) != 0 || !parseDouble(r.substr(3), v)) {
                            e.error = "seed " + std::to_string(firstSeed + k) + ", " + data->variables[0] + " = " +
                                      shortest(data->conditions[c][0]) + ": " + (r.rfind("failed ", 0) == 0 ? r.substr(7) : r);
                            break;
                        }
                        xs.push_back(v);
                    }
                    if (!e.error.empty()) break;
                    double sum = 0;
                    for (const double v : xs) sum += v;
                    e.mean[c] = sum / static_cast<double>(xs.size());
                    double ss = 0;
                    for (const double v : xs) ss += (v - e.mean[c]) * (v - e.mean[c]);
                    e.sd[c] = xs.size() > 1 ? std::sqrt(ss / static_cast<double>(xs.size() - 1)) : 0.0;
                }
                if (e.error.empty()) e.objective = objectiveOf(*data, e.mean, relative);
                values.push_back(e.objective);
                if (step != "jacobian" && (best >= evaluations.size() || e.objective < evaluations[best].objective))
                    if (std::isfinite(e.objective)) best = evaluations.size();
                evaluations.push_back(std::move(e));
                if (drawProgress && !terminal) std::cerr << progressLine(jobs.size(), jobs.size()) << "\n";
            }
            if (drawProgress && terminal) std::cerr << "\r\033[K" << progressLine(jobs.size(), jobs.size()) << std::flush;
            return values;
        };

        BoxSearchOptions search;
        for (const FitParameter& f : s.fits) {
            search.lo.push_back(f.lo);
            search.hi.push_back(f.hi);
        }
        search.tolerance = tolerance;
        search.maxEvaluations = maxEvaluations;
        const BoxSearchResult found = nelderMeadInBox(evaluateBatch, search);
        const std::size_t searchEvaluations = evaluations.size();
        if (drawProgress && terminal) std::cerr << "\n";
        if (found.interrupted || interruptRequested()) {
            std::cerr << "crowdhealth: interrupted after " << plural(evaluations.size(), "evaluation")
                      << "; the finished runs are kept in " << state.string()
                      << ": run the same command again to resume\n";
            return kExitInterrupted;
        }
        for (const Evaluation& e : evaluations)
            if (!e.error.empty()) {
                std::cerr << "crowdhealth: warning: evaluation at " << describe(e.values) << " failed: " << e.error << "\n";
                break;
            }
        if (best >= evaluations.size()) {
            std::cerr << "crowdhealth: error: every evaluation failed (see the warning above); nothing was fitted\n";
            return kExitRuntime;
        }
        const Evaluation fitted = evaluations[best];

        // ---- errors: Gauss–Newton from a central-difference Jacobian of the ensemble means ----
        // J_ij = d residual_i / d theta_j from theta ± h (h = 5 % of the range, kept inside it);
        // A = J^T W J. Fit error: s^2 A^-1 with s^2 = objective / (rows − p) (the scatter of the data
        // about the model); seed error: A^-1 J^T W C W J A^-1 with C the variance of the ensemble
        // means (sd^2 / N, rows of one condition fully correlated).
        std::vector<double> seFit(p, std::nan("")), seSeeds(p, std::nan(""));
        std::string errorNote;
        {
            std::vector<std::vector<double>> points;
            for (std::size_t j = 0; j < p; ++j) {
                const double h = 0.05 * (s.fits[j].hi - s.fits[j].lo);
                std::vector<double> a = fitted.values, b = fitted.values;
                a[j] = std::max(s.fits[j].lo, a[j] - h);
                b[j] = std::min(s.fits[j].hi, b[j] + h);
                points.push_back(a);
                points.push_back(b);
            }
            const std::optional<std::vector<double>> v = evaluateBatch(points, "jacobian");
            if (drawProgress && terminal) std::cerr << "\n";
            if (!v) {
                std::cerr << "crowdhealth: interrupted; the finished runs are kept in " << state.string()
                          << ": run the same command again to resume\n";
                return kExitInterrupted;
            }
            const std::size_t n = data->rows.size();
            bool ok = true;
            std::vector<std::vector<double>> J(n, std::vector<double>(p, 0.0));
            for (std::size_t j = 0; j < p && ok; ++j) {
                // Central where both sides ran; one-sided (with the optimum itself) where one failed.
                const Evaluation* lo = &evaluations[searchEvaluations + 2 * j];
                const Evaluation* hi = &evaluations[searchEvaluations + 2 * j + 1];
                if (!lo->error.empty() && !hi->error.empty()) {
                    ok = false;
                    errorNote = "the runs on both sides of the optimum failed for " + s.fits[j].target;
                    break;
                }
                if (!lo->error.empty()) lo = &fitted;
                if (!hi->error.empty()) hi = &fitted;
                const double dx = hi->values[j] - lo->values[j];
                if (!(dx > 0)) {
                    ok = false;
                    errorNote = "no step around the optimum for " + s.fits[j].target;
                    break;
                }
                if (lo == &fitted || hi == &fitted)
                    errorNote = "one-sided differences for " + s.fits[j].target + " (the runs on one side failed)";
                for (std::size_t i = 0; i < n; ++i) {
                    const CalibrationData::Row& r = data->rows[i];
                    const double scale = relative ? r.y : 1.0;
                    J[i][j] = (hi->mean[r.condition] - lo->mean[r.condition]) / dx / scale;
                }
            }
            std::vector<std::vector<double>> A(p, std::vector<double>(p, 0.0));
            if (ok) {
                for (std::size_t a = 0; a < p; ++a)
                    for (std::size_t b = 0; b < p; ++b)
                        for (std::size_t i = 0; i < n; ++i) A[a][b] += data->rows[i].weight * J[i][a] * J[i][b];
                if (!invert(A)) {
                    ok = false;
                    errorNote = "the model does not change with the parameters near the optimum (singular J^T W J)";
                }
            }
            if (ok) {
                if (n > p) {
                    const double s2 = fitted.objective / static_cast<double>(n - p);
                    for (std::size_t j = 0; j < p; ++j) seFit[j] = std::sqrt(std::max(0.0, s2 * A[j][j]));
                } else {
                    errorNote = "no more data rows than parameters: no fit error";
                }
                // G = A^-1 J^T W (p × n); cov = G C G^T with C_ik = var(mean of condition) when rows i, k share it.
                std::vector<std::vector<double>> G(p, std::vector<double>(n, 0.0));
                for (std::size_t a = 0; a < p; ++a)
                    for (std::size_t i = 0; i < n; ++i)
                        for (std::size_t b = 0; b < p; ++b) G[a][i] += A[a][b] * J[i][b] * data->rows[i].weight;
                for (std::size_t j = 0; j < p; ++j) {
                    double var = 0;
                    for (std::size_t i = 0; i < n; ++i)
                        for (std::size_t k = 0; k < n; ++k) {
                            const CalibrationData::Row &ri = data->rows[i], &rk = data->rows[k];
                            if (ri.condition != rk.condition) continue;
                            const double sd = fitted.sd[ri.condition];
                            const double c = sd * sd / static_cast<double>(seeds) / (relative ? ri.y * rk.y : 1.0);
                            var += G[j][i] * c * G[j][k];
                        }
                    seSeeds[j] = std::sqrt(std::max(0.0, var));
                }
            }
        }
        const double wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();

        // ---- outputs ----
        std::string csv = "evaluation,step";
        for (const FitParameter& f : s.fits) csv += "," + f.target;
        csv += ",objective,status\n";
        for (std::size_t k = 0; k < evaluations.size(); ++k) {
            const Evaluation& e = evaluations[k];
            csv += std::to_string(k) + "," + e.step;
            for (const double v : e.values) csv += "," + csvCell(v);
            csv += "," + csvCell(e.objective) + "," + (e.error.empty() ? "ok" : "failed") + "\n";
        }
        double weightSum = 0;
        for (const CalibrationData::Row& r : data->rows) weightSum += r.weight;
        ch::Json j = ch::Json::object();
        j["scenario"] = s.input;
        j["data"] = dataPath;
        j["observable"] = data->observableName;
        j["residuals"] = relative ? "relative" : "absolute";
        j["seeds"] = seeds;
        j["first_seed"] = firstSeed;
        j["evaluations"] = searchEvaluations;
        j["converged"] = found.converged;
        j["tolerance"] = ch::jsonNumber(tolerance);
        j["objective"] = ch::jsonNumber(fitted.objective);
        j["rms_residual"] = ch::jsonNumber(std::sqrt(fitted.objective / weightSum));
        j["error_method"] =
            "Gauss-Newton: J = d(model mean)/d(parameter) by central differences (5% of the range) at the optimum; "
            "standard_error = sqrt(diag(s^2 (J^T W J)^-1)), s^2 = objective / (data rows - parameters): the scatter of the "
            "data about the fitted model; seed_error: the part of it due to the finite ensemble (sd^2 / seeds of each "
            "model mean, propagated through the same matrices)";
        if (!errorNote.empty()) j["error_note"] = errorNote;
        j["parameters"] = ch::Json::array();
        for (std::size_t k = 0; k < p; ++k) {
            ch::Json q = ch::Json::object();
            q["target"] = s.fits[k].target;
            q["lo"] = ch::jsonNumber(s.fits[k].lo);
            q["hi"] = ch::jsonNumber(s.fits[k].hi);
            q["value"] = ch::jsonNumber(fitted.values[k], 17);
            q["standard_error"] = ch::jsonNumber(seFit[k]);
            q["seed_error"] = ch::jsonNumber(seSeeds[k]);
            const double margin = tolerance * (s.fits[k].hi - s.fits[k].lo);  // within the search's resolution
            q["at_bound"] = fitted.values[k] - s.fits[k].lo < margin || s.fits[k].hi - fitted.values[k] < margin;
            j["parameters"].push_back(q);
        }
        j["points"] = ch::Json::array();
        for (std::size_t c = 0; c < conditions; ++c) {
            ch::Json q = ch::Json::object();
            for (std::size_t k = 0; k < data->variables.size(); ++k) q[data->variables[k]] = ch::jsonNumber(data->conditions[c][k]);
            q["model_mean"] = ch::jsonNumber(fitted.mean[c]);
            q["model_sd"] = ch::jsonNumber(fitted.sd[c]);
            q["runs"] = seeds;
            q["data"] = ch::Json::array();
            for (const CalibrationData::Row& r : data->rows)
                if (r.condition == c) q["data"].push_back(ch::jsonNumber(r.y));
            j["points"].push_back(q);
        }
        try {
            ch::writeFileAtomic(output / "calibration.csv", csv);
            ch::writeFileAtomic(output / "calibration-result.json", ch::jsonText(j));
        } catch (const std::exception& e) {
            std::cerr << "crowdhealth: error: cannot write the outputs: " << e.what() << "\n";
            return kExitRuntime;
        }

        // ---- the plot: the fitted model (mean ± sd per condition) against the data ----
        bool plotted = false;
        if (chplot::findGnuplot()) {
            chplot::GnuplotJob job;
            std::string title = "fitted: ";
            for (std::size_t k = 0; k < p; ++k) {
                char v[32];
                std::snprintf(v, sizeof v, "%.4g", fitted.values[k]);
                title += (k ? ", " : "") + s.fits[k].target + " = " + v;
                if (std::isfinite(seFit[k])) {
                    char b[32];
                    std::snprintf(b, sizeof b, "%.2g", seFit[k]);
                    title += std::string(" +/- ") + b;
                }
            }
            const std::string& xname = data->variables[0];
            const std::string ylabel = data->observableName == "flow"    ? "flow (persons/s)"
                                       : data->observableName == "speed" ? "speed (m/s)"
                                                                         : "evacuation time (s)";
            job.cmd("set title " + chplot::gpString(title) + " noenhanced font ',13'");
            job.cmd("set grid");
            job.cmd("set key top left noenhanced");
            job.cmd("set xlabel " + chplot::gpString(xname) + " noenhanced");
            job.cmd("set ylabel " + chplot::gpString(ylabel) + " noenhanced");
            job.cmd("set offsets graph 0.05, graph 0.05, graph 0.05, graph 0.05");
            chplot::Rows model, points;
            std::vector<std::size_t> order(conditions);
            for (std::size_t c = 0; c < conditions; ++c) order[c] = c;
            std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return data->conditions[a] < data->conditions[b]; });
            for (const std::size_t c : order)
                model.push_back({data->conditions[c][0], fitted.mean[c], fitted.mean[c] - fitted.sd[c], fitted.mean[c] + fitted.sd[c]});
            for (const CalibrationData::Row& r : data->rows) points.push_back({r.x[0], r.y});
            job.cmd("plot '-' using 1:2:3:4 with yerrorlines lw 2 pt 7 lc rgb '#1f77b4' title " +
                    chplot::gpString("model (" + fs::path(s.input).filename().string() + "), fitted: mean +/- sd of " +
                                     std::to_string(seeds) + " seeds") +
                    ", '-' using 1:2 with points pt 9 ps 1.6 lc rgb '#d62728' title " +
                    chplot::gpString("data (" + fs::path(dataPath).filename().string() + ")"));
            job.data(std::move(model));
            job.data(std::move(points));
            const std::string e = chplot::drawPng(job, chplot::pngTerminal(1000, 700), output / "calibration.png");
            if (!e.empty()) std::cerr << "crowdhealth: warning: plot calibration.png: " << e << "\n";
            plotted = e.empty();
        } else {
            std::cerr << "crowdhealth: warning: " << chplot::missingGnuplotMessage("the calibration plot") << "\n";
        }

        if (!quiet) {
            std::cout << "crowdhealth calibrate: " << s.input << " against " << dataPath << " (" << data->observableName << ", "
                      << plural(data->rows.size(), "data row") << " at " << plural(conditions, "condition") << "), "
                      << plural(seeds, "seed") << " per evaluation: " << plural(searchEvaluations, "evaluation") << " ("
                      << (found.converged ? "converged" : "stopped at --max-evaluations") << ") + " << 2 * p
                      << " for the errors, " << evaluations.size() * conditions * seeds << " runs in "
                      << formatDuration(wallSeconds) << "\n";
            for (std::size_t k = 0; k < p; ++k)
                std::cout << "  " << s.fits[k].target << " = " << csvCell(fitted.values[k]) << " +/- "
                          << (std::isfinite(seFit[k]) ? csvCell(seFit[k]) : "?") << " (seeds: +/- "
                          << (std::isfinite(seSeeds[k]) ? csvCell(seSeeds[k]) : "?") << ")\n";
            if (!errorNote.empty()) std::cout << "  errors: " << errorNote << "\n";
            std::cout << "  objective " << csvCell(fitted.objective) << ", rms residual " << csvCell(std::sqrt(fitted.objective / weightSum))
                      << "\n  output  " << (output / "calibration.csv").string() << ", "
                      << (output / "calibration-result.json").string();
            if (plotted) std::cout << ", " << (output / "calibration.png").string();
            std::cout << "\n";
        }
        return kExitOk;
    }();
    pool.finish(status);
    return status;
}

}  // namespace chcli
